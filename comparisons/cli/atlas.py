"""``chatterbench atlas``: the band-robust frontier of every engine on every scene, resumable, as tables and charts.

    $ chatterbench atlas --out atlas                                  # every built-in scene, every installed engine
    $ chatterbench atlas bouncing-ball feigin-pair --engines mujoco,pybullet --tolerance 0.05 --out atlas
    $ chatterbench atlas --engines mujoco,pybullet --dask tcp://scheduler:8786 --out atlas

Each case (scene x engine) is one ``tune`` (``studies.atlas``); its files are written as it
finishes, so a killed atlas rerun with the same --out keeps every finished case and runs the
rest. Exit codes: 0 every case ran (whatever it reached), 1 a case failed (its message is in the
table), 2 bad input.
"""

from __future__ import annotations

import argparse
import math
import shlex
from contextlib import contextmanager
from pathlib import Path

from chatterbench.comparisons.pipeline.budget import GIB
from chatterbench.comparisons.studies.limits import MAX_RUNS, ROBUST_FRACTION
from chatterbench.reference.scene import load_scene, split_assignment

from .commands import COMMANDS
from .common import (UsageError, add_budget, add_out, add_set, add_tolerance, budget_of, dask_client, engine_list,
                     integer_type, load_noted, local_workers, machine_memory, parse_tolerances, positive_float, positive_int,
                     print_table)
from .paths import check_dir, writing
from .progress import CountingExecutor, Progress, waited_s

SHOW = ["scene", "engine", "status", "robust_at_asked", "tightest_stick", "tightest_restitution", "settings",
        "cost_steps_per_s", "open_fraction", "frontier_points", "runs", "wall_s"]


def cmd_atlas(args: argparse.Namespace) -> int:
    from chatterbench.comparisons.outputs.atlas_files import atlas_frame, write_atlas_files
    from chatterbench.comparisons.studies.atlas import AtlasError, AtlasSpec, case_name, default_scenes
    from chatterbench.engines.registry import available_engines

    if not args.out:
        raise UsageError("atlas: --out DIR is needed (each case is written there as it finishes; rerun to resume)")
    out = Path(args.out)
    check_dir("--out", out)
    scenes = tuple(args.scenes) or default_scenes()
    for source in scenes:
        load_noted(source, [])
    engines = engine_list(args.engines) if args.engines else available_engines()
    fixed = {}
    for item in args.set or []:
        key, value = split_assignment(item)
        if "." not in key or key.split(".", 1)[0] not in engines:
            raise UsageError(f"--set {item}: atlas --set fixes an engine's knob (ENGINE.KNOB=VALUE) of one of "
                             f"--engines {','.join(engines)}; scene fields belong in a scene file")
        fixed[key] = value
    from chatterbench.comparisons.studies.tune.space import engine_space

    from .tune import fixed as held

    for engine in engines:  # a knob an engine does not search: refused before any case runs
        held(engine, engine_space(engine, load_scene(scenes[0])), args.set or [])
    spec = AtlasSpec(scenes=scenes, engines=engines, tolerance=parse_tolerances(args.tolerance),
                     max_runs=args.max_runs, robust_fraction=args.robust_fraction, fixed=fixed, max_cost=args.max_cost)
    try:
        for source in scenes:
            case_name(source)
    except AtlasError as exc:
        raise UsageError(str(exc)) from None
    if args.dask and args.cases_at_once not in (None, 1):
        raise UsageError(f"--cases-at-once {args.cases_at_once} with --dask: a cluster runs the cases one after "
                         "another (its workers take every candidate of a case at once); leave it out or give 1")
    budget = budget_of(args)
    command = _command_line(args)
    client = dask_client(args.dask)
    try:
        with writing("--out", out):
            try:  # another search in the folder, or a link in it: refused before any case runs
                provenance, cases = _run(out, spec, command, client, args.workers, budget, args.cases_at_once)
            except AtlasError as exc:
                raise UsageError(str(exc)) from None
            provenance = provenance | {"wall_s": sum(c.get("wall_s") or 0 for c in cases.values())}
            written = write_atlas_files(out, list(cases.values()), provenance)
    finally:
        if client is not None:
            client.close()
    atlas = atlas_frame(cases.values())
    print_table(atlas[SHOW], title=f"the atlas under {out} ({len(atlas)} cases; every frontier point: "
                                   f"{out}/frontier.csv):")
    print(f"wrote under {out}: " + ", ".join(written))
    print(f"atlas took {waited_s():.1f} s since the command started")
    return 0 if (atlas["status"] == "ok").all() else 1


def _command_line(args: argparse.Namespace) -> str:
    """The command, rebuilt from the parsed options (the atlas's provenance)."""
    words = ["chatterbench", "atlas", *args.scenes]
    if args.engines:
        words += ["--engines", args.engines]
    for item in args.tolerance or []:
        words += ["--tolerance", item]
    words += ["--max-runs", str(args.max_runs)]
    if math.isfinite(args.max_cost):
        words += ["--max-cost", f"{args.max_cost:g}"]
    if args.robust_fraction != ROBUST_FRACTION:
        words += ["--robust-fraction", f"{args.robust_fraction:g}"]
    for item in args.set or []:
        words += ["--set", item]
    if args.dask:
        words += ["--dask", args.dask]
    return " ".join(shlex.quote(w) for w in [*words, "--out", args.out])


def _run(out: Path, spec, command: str, client, workers: int | None, budget, at_once: int | None):
    """Every case not done, each through a pool of its own, ``at_once`` side by side (or the Dask cluster's, one after
    another), with a progress line per case."""
    from chatterbench.comparisons.studies.atlas import run_atlas
    from chatterbench.comparisons.studies.pools import RENEW_TASKS, process_pool

    running: dict[str, str] = {}

    def started(scene: str, engine: str, k: int, n: int) -> str:
        running[f"{scene}/{engine}"] = f"{k}"
        return f"case{'s' if len(running) > 1 else ''} {', '.join(running.values())} of {n}: " + \
            "; ".join(f"tune {c.replace('/', ' --engines ')}" for c in running)

    def finished(case: dict) -> None:
        running.pop(f"{case['scene']}/{case['engine']}", None)
        print(f"{case['scene']} / {case['engine']}: {case['status']}, {case['runs']} runs, {case['wall_s']:.1f} s"
              + (f"; {case['message']}" if case.get("message") else ""), flush=True)

    if client is not None:
        with Progress(None, "atlas", unit="candidate") as bar:
            return run_atlas(out, spec, command, executor=CountingExecutor(client.get_executor(), bar),
                             started=lambda *a: bar.stage(started(*a)), finished=finished)
    n = local_workers(workers, budget.max_memory)
    at_once = cases_at_once(at_once, n, budget.max_memory)

    @contextmanager
    def case_pool():  # a pool of its own per case (``run_atlas``), its candidates counted on the progress line
        with process_pool(n, renew=RENEW_TASKS) as pool:
            yield CountingExecutor(pool, bar)

    with Progress(None, "atlas", unit="candidate") as bar:
        return run_atlas(out, spec, command, pool=case_pool, at_once=at_once,
                         expected=_kept_walls() if at_once > 1 else None,
                         started=lambda *a: bar.stage(started(*a)), finished=finished)


def _kept_walls() -> dict[tuple[str, str], float]:
    """(scene, engine) -> the wall time [s] of the case in the atlas kept with chatterbench (none: empty)."""
    from chatterbench.comparisons.outputs.atlas_section import packaged_atlas

    kept = packaged_atlas()
    return {} if kept is None else {(c["scene"], c["engine"]): c["wall_s"] for c in kept.cases
                                    if c.get("status") == "ok" and c.get("wall_s")}


def cases_at_once(requested: int | None, workers: int, max_memory: float) -> int:
    """``--cases-at-once``: ``requested`` (None: ``CASES_AT_ONCE``) when this machine's memory holds that many cases'
    pools of ``workers`` at ``max_memory`` [B] a worker, else a UsageError (None: as many as it holds, at least 1)."""
    memory = machine_memory()
    fits = max(1, int(memory // (max_memory * workers)))
    if requested is not None and requested > fits:
        raise UsageError(f"--cases-at-once {requested}: must be in [1, {fits}] on this machine ({memory / GIB:.0f} GiB "
                         f"of memory, {workers} workers a case at {max_memory / GIB:g} GiB per worker)")
    return requested or min(CASES_AT_ONCE, fits)


MOST_AT_ONCE = 8  # cases side by side at most (each a pool of --workers: more only fight for the cores)
CASES_AT_ONCE = 2  # cases side by side by default (``studies.side_by_side``: the second takes the first's idle time)


def register(sub, formatter) -> None:
    """Add ``atlas`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("atlas", help=COMMANDS["atlas"], formatter_class=formatter)
    p.add_argument("scenes", nargs="*", metavar="SCENE",
                   help="built-in scene names or scene TOML files; none: every built-in scene")
    p.add_argument("--engines", "--engine", default=None, metavar="E[,E...]",
                   help="the engines, comma-separated; None: every engine installed here")
    add_tolerance(p)
    p.set_defaults(tolerance=None)
    p.add_argument("--workers", type=positive_int, default=None,
                   help="parallel candidate runs of a case; None: all cores (with --dask: the cluster's)")
    p.add_argument("--cases-at-once", type=integer_type(1, MOST_AT_ONCE), default=None, metavar="K",
                   help=f"cases run side by side, each with a pool of --workers, in [1, {MOST_AT_ONCE}]; None: "
                        f"{CASES_AT_ONCE} (a case leaves workers idle between its passes; the next one takes them)")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="run each case's candidates on a Dask cluster (tcp://host:8786) instead of local processes")
    p.add_argument("--max-runs", type=integer_type(1, 100_000), default=MAX_RUNS,
                   help="each case's budget, as tune's --max-runs")
    p.add_argument("--max-cost", type=positive_float, default=math.inf, metavar="STEPS_PER_S",
                   help="no candidate of more engine steps per simulated second, as tune's --max-cost")
    from .tune import fraction_type

    p.add_argument("--robust-fraction", type=fraction_type, default=ROBUST_FRACTION, metavar="F",
                   help="the share of a band that must pass, in (0, 1], as tune's")
    add_set(p)
    add_out(p, what="the atlas's folder: atlas.json (spec, provenance), cases/SCENE/ENGINE/ (each case, written as it "
                    "finishes), atlas.csv/.parquet, frontier.csv/.parquet, atlas.md, figures/; rerun to resume")
    add_budget(p)
    p.set_defaults(func=cmd_atlas)
