"""The ``chatterbench sweep`` subcommand: run a sweep spec, locally or on a Dask cluster.

    $ chatterbench sweep examples/sweeps/bouncing-ball-dt.toml --out out/bb --workers 4
    $ chatterbench sweep spec.toml --out out/bb --resume            # after an interruption
    $ chatterbench sweep spec.toml --out out/bb --dask tcp://scheduler:8786

Prints verdict counts per engine and writes only under ``--out`` (default
``./sweep-SPEC_STEM``): ``sweep.toml``, ``rows/`` and ``rows.parquet`` (see ``sweep.py``).
Exit codes: 0 the sweep finished (failed runs are rows, not errors), 2 bad input (the spec,
the options, an unreachable scheduler or one left without workers under
``--dask-no-workers stop``, an --out holding another sweep or written by another sweep
now), 130 interrupted. A resumed sweep says on stderr which part files it set aside.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from chatterbench.comparisons.pipeline.budget import GIB, MAX_MEMORY
from chatterbench.comparisons.pipeline.tolerances import tolerance_values
from chatterbench.comparisons.studies.limits import NO_WORKER_WAIT, NO_WORKERS

from .commands import COMMANDS
from .common import (UsageError, add_budget, dask_client, add_out, add_tolerance, budget_of, file_notes, local_workers, positive_int,
                     print_table, timeout_seconds)
from .paths import check_dir, writing
from .progress import Progress, waited_s


def _spec_path(args: argparse.Namespace) -> str:
    """The spec from the positional SPEC.toml or ``--spec`` (one of them; the same file if both)."""
    if args.spec is None and args.spec_option is None:
        raise UsageError("sweep: no spec; give SPEC.toml (or --spec SPEC.toml with --resume)")
    if args.spec is not None and args.spec_option is not None and Path(args.spec).resolve() != Path(args.spec_option).resolve():
        raise UsageError(f"sweep: two specs, SPEC.toml {args.spec!r} and --spec {args.spec_option!r}; give one")
    return args.spec if args.spec is not None else args.spec_option


def cmd_sweep(args: argparse.Namespace) -> int:
    import pandas as pd

    from chatterbench.comparisons.studies.sweep import FAILED, load_sweep, run_sweep

    args.spec = _spec_path(args)
    out = Path(args.out) if args.out else Path(f"sweep-{Path(args.spec).stem}")
    check_dir("--out", out)
    budget = budget_of(args)
    sweep = load_sweep(args.spec, budget)
    file_notes([sweep.scene])
    if args.timeout is not None:
        sweep = dataclasses.replace(sweep, timeout=args.timeout)
    if args.tolerance:
        sweep = dataclasses.replace(sweep, tolerances={**dict(sweep.tolerances), **tolerance_values(args.tolerance)})
    workers = args.workers if args.dask else local_workers(args.workers, budget.max_memory)
    client = dask_client(args.dask)
    try:
        with writing("--out", out):  # a full disk mid-sweep: one line naming the file; finished parts stay
            rows = run_sweep(sweep, out, executor=client, resume=args.resume, workers=workers, batch=args.batch,
                             no_worker_wait=args.dask_wait, no_workers=args.dask_no_workers,
                             progress=lambda total, done, desc: Progress(total, f"sweep {sweep.scene_name}"
                                                                          + ("" if desc == "sweep" else f", {desc}"),
                                                                          unit="run", eta=True, initial=done))
    finally:
        if client is not None:
            client.close()
    counts = rows.groupby(["engine", "verdict"]).size().unstack(fill_value=0).reset_index() if len(rows) else pd.DataFrame()
    print_table(counts, title=f"{sweep.scene_name}: {len(rows)} runs, verdicts per engine:")
    failed = rows[rows["status"].isin(FAILED)] if len(rows) else rows
    if len(failed):
        print_table(failed[["point_id", "engine", "status", "message"]].assign(message=failed["message"].str.split("\n").str[0]),
                    title="failed runs:")
    stats = rows.attrs.get("sweep", {})
    if stats.get("runs"):
        print(f"ran {stats['runs']} runs in {stats['wall_s']:.1f} s on {stats['workers']} workers "
              f"(runs' own time {stats['run_s_sum']:.1f} s)")
    print(f"wrote {out / 'rows.parquet'} ({len(rows)} rows), {out / 'sweep.toml'}")
    print(f"sweep took {waited_s():.1f} s since the command started")
    return 0


def register(sub, formatter) -> None:
    """Add ``sweep`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("sweep", help=COMMANDS["sweep"], formatter_class=formatter)
    p.add_argument("spec", metavar="SPEC.toml", nargs="?", default=None,
                   help="sweep spec (format: chatterbench.comparisons.sweep docstring)")
    p.add_argument("--spec", dest="spec_option", metavar="SPEC.toml", default=None,
                   help="the spec, as an option: `--out DIR --resume --spec SPEC.toml` resumes a directory whose "
                        "sweep.toml is damaged, if SPEC.toml wrote its rows (another spec is refused)")
    add_out(p, what="output directory; None: ./sweep-SPEC_STEM")
    p.add_argument("--resume", action="store_true", help="finish the sweep already under --out; skip its finished runs")
    p.add_argument("--workers", type=positive_int, default=None,
                   help=f"local worker processes, at most one per core and per {MAX_MEMORY / GIB:g} GiB of memory; None: that many. "
                        "With --dask: the runs in flight; None: the cluster's threads")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="run on this Dask scheduler (tcp://host:8786) instead of local processes")
    p.add_argument("--dask-wait", type=timeout_seconds, default=NO_WORKER_WAIT, metavar="SECONDS",
                   help="with --dask: a cluster with no worker this long [s], in (0, 86400], is said on stderr")
    p.add_argument("--dask-no-workers", choices=NO_WORKERS, default="wait",
                   help="with --dask, after --dask-wait s without a worker: wait for one, or stop (finished rows "
                        "kept; finish with --resume)")
    p.add_argument("--batch", type=positive_int, default=None,
                   help="runs per isolated unit of work, MuJoCo's batched through mujoco.rollout (one call per chunk); None: automatic, 1: each run alone")
    p.add_argument("--timeout", type=timeout_seconds, default=None, metavar="SECONDS",
                   help="wall-clock limit of one run [s], in (0, 86400]; None: the spec's")
    add_tolerance(p)
    add_budget(p)
    p.set_defaults(func=cmd_sweep)
