"""``chatterbench bench``: speed benchmarks, run by hand (never as timed tests).

    $ chatterbench bench reference
    $ chatterbench bench engines --steps 200000
    $ chatterbench bench platemap
    $ chatterbench bench sweep --points 40 --workers 2
    $ chatterbench bench sweep --only refine --refine examples/sweeps/feigin-pair-refine.toml
    $ chatterbench bench tune --workers 2
    $ chatterbench bench ladder
    $ chatterbench bench help

Each prints its figures, what one repeat is, and ``PASS``/``FAIL`` per goal (``GOALS``);
the exit code is 1 when a goal fails, so a benchmark can gate a performance job.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from typing import TYPE_CHECKING

from chatterbench.engines.registry import unavailable_reason

from .commands import COMMANDS
from .common import UsageError, integer_type, local_workers, positive_int, print_table
from .progress import Progress

if TYPE_CHECKING:
    import pandas as pd


# each benchmark's goals: (figure, "<=" or ">=", bound, what it means)
GOALS = {
    "reference": [("feigin_ms_per_100_periods", "<=", 20.0, "Feigin mode, ms per 100 forcing periods"),
                  ("exhaustive_us_per_impact", "<=", 20.0, "exhaustive mode, us per impact")],
    "sweep": [("overhead_ratio", "<=", 1.15, "sweep wall time against the runs' own time"),
              ("engine_ratio", "<=", 1.15, "sweep wall time against engine stepping alone"),
              ("speedup", ">=", 1.7, "1 worker against --workers"),
              ("refine_agreement", ">=", 0.95, "adaptive map's verdicts against the full fine grid's, share of fine cells"),
              ("refine_speedup", ">=", 1.5, "adaptive map's cells per minute against the full fine grid's")],
    "platemap": [("us_per_strike", "<=", 300.0, "microseconds per strike of one repeat (100,000 strikes in under 30 s)")],
    "engines": [("ratio", ">=", 0.8, "adapter steps/s against the raw engine loop, each engine")],
    "tune": [("wall_s", "<=", 300.0, "seconds one tune of one scene and engine takes, each case (a few minutes)")],
    "ladder": [("same", ">=", 1.0, "the ladder's judge gives what judging each point on its own gives, every case"),
               ("speedup", ">=", 5.0, "runs judged at the whole ladder per CPU second, against one point at a time "
                                      "(issue 42)")],
    "atlas": [("same", ">=", 1.0, "the batched atlas gives the serial one's answers and frontiers, every case"),
              ("speedup", ">=", 2.0, "judged runs per wall second, batched against serial")],
    "help": [("best_s", "<=", 1.0, "seconds of `chatterbench --help` and of each subcommand's --help, each in a fresh "
                                   "process")],
}
REPEAT = {  # what one repeat is, and which counts
    "reference": "one repeat = one run of each chatter mode over --periods; the best of --repeats counts",
    "engines": "one repeat = --steps steps of each engine, adapter and raw loop; the best of --repeats counts",
    "platemap": "one repeat = the whole grid of --strikes strikes; the best of --repeats counts (time of one repeat)",
    "sweep": "one sweep of --points points x 2 engines, once with --workers and once with 1 worker; the adaptive map "
             "of --refine and its full fine grid, once each with --workers (no repeats)",
    "tune": "one tune per case (the four built-in scenes x mujoco and pybullet), with --workers and at most --max-runs "
            "runs, timed from the reference to the answer and its frontier (no repeats)",
    "ladder": "one repeat = one run judged at every point of tune's ladder (its engine run not timed), one point at a "
              "time and prepared once; the best of --repeats counts (CPU time)",
    "atlas": "one small atlas case (scene x engine, knobs held, dt capped at 300 steps/s) run serially (1 worker, the "
             "ladder judged one point at a time) and batched (--workers, the ladder judged from one prepared run); no "
             "repeats",
    "help": "one repeat = one fresh process printing the help (Python's start and the imports included); the best of "
            "--repeats counts",
}


def goal_lines(what: str, figures: dict[str, float] | pd.DataFrame) -> tuple[list[str], bool]:
    """``PASS``/``FAIL`` per goal of benchmark ``what`` with the measured value; and whether all passed."""
    lines, ok = [], True
    for key, op, bound, meaning in GOALS[what]:
        if isinstance(figures, dict) and key not in figures:  # a part not run (bench sweep --only)
            continue
        values = [figures[key]] if isinstance(figures, dict) else list(figures[key])
        passed = all((v <= bound) if op == "<=" else (v >= bound) for v in values)
        ok &= passed
        shown = ", ".join(f"{v:.4g}" for v in values)
        lines.append(f"{'PASS' if passed else 'FAIL'}: {key} = {shown} (goal {op} {bound:g}: {meaning})")
    return lines, ok


def _world_counts(text: str) -> tuple[int, ...]:
    """argparse type of ``--worlds``: comma-separated integers > 0."""
    return tuple(_world_count(w) for w in text.split(",") if w.strip())


_world_count = integer_type(1, 262_144)  # the largest measured batch; blocks keep any within the host's memory


def _warp_stage() -> str:
    """The progress stage of MuJoCo Warp's benchmark, naming the device it runs on."""
    from chatterbench.engines.mujoco_warp_engine.worlds import device_name

    return f"mujoco_warp on device {device_name('auto')}"


def _print_warp(worlds: tuple[int, ...], bar: Progress | None = None) -> None:
    """MuJoCo Warp's world-steps per second on the device it finds, per number of worlds, beside MuJoCo C's
    (``bench_warp``): the table, then the kernels' warm-up apart."""
    reason = unavailable_reason("mujoco_warp")
    if reason:
        print(f"mujoco_warp world-steps per second: not measured: {reason}")
        return
    from chatterbench.comparisons.studies.bench import bench_warp
    from chatterbench.engines.mujoco_warp_engine.worlds import device_name

    device = device_name("auto")
    if bar is not None:
        bar.stage(_warp_stage())
    figures = bench_warp(worlds=worlds)
    shown = figures.drop(columns=["device", "precision", "warmup_s", "kernels"])
    print_table(shown, title=f"mujoco_warp world-steps per second on device {device} ({figures['precision'].iloc[0]}), "
                             "feigin-pair, dt = 1e-3: the adapter (every sample recorded) against its bare step loop "
                             "(Python launches; captured graph) and MuJoCo C's bare rollout (1 thread; threads):")
    print(f"mujoco_warp kernels on {device}: {figures['kernels'].iloc[0] or 'loaded'} in {figures['warmup_s'].iloc[0]:.2f} s "
          "before the first run (warm-up: not in any rate above; cached by warp under ~/.cache/warp)")


# each option: the benchmarks it applies to and its default; given to another benchmark it is refused, not ignored
OPTIONS = {"points": (("sweep",), 200), "workers": (("sweep", "tune", "atlas"), 2), "max_runs": (("tune",), None), "refine": (("sweep",), None),
           "only": (("sweep",), None), "worlds": (("sweep",), (1, 16, 256)), "strikes": (("platemap",), 100_000),
           "periods": (("reference",), 100), "steps": (("engines",), 200_000),
           "repeats": (("reference", "engines", "platemap", "help", "ladder"), 5)}


def check_options(args: argparse.Namespace) -> None:
    """Fill each option's default; refuse one given to a benchmark it does not apply to, and a part that cannot run."""
    for name, (applies, default) in OPTIONS.items():
        if getattr(args, name) is None:
            setattr(args, name, default)
        elif args.what not in applies:
            raise UsageError(f"--{name.replace('_', '-')}: applies to {' and '.join(f'bench {a}' for a in applies)}, "
                             f"not bench {args.what}")
    if args.what in ("sweep", "tune", "atlas"):
        args.workers = local_workers(args.workers)
    if args.only == "warp" and unavailable_reason("mujoco_warp"):
        raise UsageError(f"--only warp: nothing to time: {unavailable_reason('mujoco_warp')}")


def cmd_bench(args: argparse.Namespace) -> int:
    check_options(args)
    if args.what == "tune":  # the studies load with the benchmarks that time them: not with --help, a refusal, bench help
        from chatterbench.comparisons.studies.bench_tune import TUNE_CASES
    parts = ([p for p in ("overhead", "refine", "warp") if args.only in (None, p)] if args.what == "sweep" else
             [*COMMANDS, "top"] if args.what == "help" else TUNE_CASES if args.what == "tune" else [args.what])
    with Progress(len(parts), f"bench {args.what}", unit="part") as bar:  # minutes of timing: say what runs
        figures = _run_bench(args, bar)
    print(REPEAT[args.what])
    lines, ok = goal_lines(args.what, figures)
    print("\n".join(lines))
    return 0 if ok else 1


def bench_help(repeats: int = 5, progress: Progress | None = None) -> pd.DataFrame:
    """Wall time [s] of ``chatterbench --help`` and of ``chatterbench NAME --help`` for every subcommand, each in a fresh
    process as a shell runs it (``python -m chatterbench.comparisons.cli``, which the console script's imports
    match); columns ``command``, ``best_s`` (of ``repeats``), ``median_s``."""
    import pandas as pd

    rows = []
    for words in ([], *([name] for name in COMMANDS)):
        if progress is not None:
            progress.stage(" ".join(["chatterbench", *words, "--help"]))
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", *words, "--help"], check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            times.append(time.perf_counter() - start)
        rows.append({"command": " ".join(["chatterbench", *words, "--help"]), "best_s": min(times),
                     "median_s": statistics.median(times)})
    return pd.DataFrame(rows)


def _run_bench(args: argparse.Namespace, bar: Progress):
    import pandas as pd

    if args.what == "help":
        figures = bench_help(args.repeats, bar)
        print_table(figures.round(3), title="seconds each --help takes in a fresh process (best and median of --repeats):")
        return figures
    from chatterbench.comparisons.studies.bench import bench_engines, bench_platemap, bench_reference, bench_refine, bench_sweep
    from chatterbench.comparisons.studies.bench_tune import bench_tune

    first = {None: "overhead", "overhead": "overhead", "refine": "refine"}.get(args.only) or _warp_stage()
    if args.what != "tune":  # tune: each case is a stage of its own (bench_tune's ``started``)
        bar.stage(first if args.what == "sweep" else "timing")
    if args.what == "reference":
        figures = bench_reference(periods=args.periods, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="reference on feigin-pair (best of repeats, one core):")
    elif args.what == "sweep":
        figures = {}
        if args.only in (None, "overhead"):
            figures = bench_sweep(points=args.points, workers=args.workers)
            print_table(pd.DataFrame([figures]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                        title="sweep overhead: feigin-pair, both engines, 3 periods, dt = 1e-4")
        if args.only in (None, "refine"):
            if args.only is None:
                bar.stage("refine")
            refined, per_engine = bench_refine(args.refine, workers=args.workers)
            print_table(pd.DataFrame([refined]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                        title=f"adaptive map against the full fine grid ({args.refine or 'feigin-pair, 1 period, dt x R, depth 2'}):")
            print_table(per_engine, title="fine cells per engine whose verdict the adaptive map gets right:")
            figures.update({f"refine_{k}": v for k, v in refined.items()})
        if args.only in (None, "warp"):
            _print_warp(args.worlds, bar if args.only is None else None)
    elif args.what == "tune":
        figures = bench_tune(workers=args.workers, max_runs=args.max_runs,
                             started=lambda scene, engine, tol: bar.stage(f"tune {scene} --engines {engine} --tolerance {tol:g}"),
                             finished=lambda row: bar.write(f"{row['scene']} / {row['engine']}: {row['runs']} runs, "
                                                            f"{row['wall_s']:.1f} s; {row['answer_line']}"))
        print_table(figures.drop(columns=["answer_line", "points", "transfers"]),
                    title="tune per case (runs, and wall time from the reference to the answer and its robust frontier):")
        for row in figures.itertuples():  # what each engine reaches, robustly, at what cost, and what transfers
            print(f"{row.scene} / {row.engine}: {row.answer_line}")
            print(f"  frontier points (the share of each one's band runs that passed): {row.points or 'none'}")
            print(f"  the written answer on the scene's family: {row.transfers}")
    elif args.what == "ladder":
        from chatterbench.comparisons.studies.bench_tune import bench_ladder

        figures, cases = bench_ladder(repeats=args.repeats)
        print_table(cases.round({"ms_before": 2, "ms_after": 2, "ms_extract": 2, "speedup": 2}), title="CPU ms of one run judged at every ladder point: one point at a time (before) "
                                          "and prepared once (after); ms_extract: the extractions both need:")
        shown = {k: v for k, v in figures.items() if not k.startswith("hash")}
        print_table(pd.DataFrame([shown]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                    title=f"over all cases (outputs hashed: before {figures['hash_before']}, after {figures['hash_after']}):")
        figures = shown
    elif args.what == "atlas":
        from chatterbench.comparisons.studies.bench_tune import bench_atlas

        table = bench_atlas(workers=args.workers, finished=lambda r: bar.write(
            f"{r['scene']} / {r['engine']} {r['way']}: {r['runs']} runs, {r['judged']} judged, {r['wall_s']:.1f} s"))
        print_table(table.round({"wall_s": 2, "runs_per_s": 1, "judged_per_s": 1}),
                    title="atlas cases, serial (1 worker, per-point judge) and batched (--workers, prepared judge):")
        serial, batched = table[table["way"] == "serial"], table[table["way"] == "batched"]
        figures = {"same": float(batched["same"].all()),
                   "speedup": batched["judged"].sum() / batched["wall_s"].sum()
                   / (serial["judged"].sum() / serial["wall_s"].sum()),
                   "serial_wall_s": serial["wall_s"].sum(), "batched_wall_s": batched["wall_s"].sum()}
        print_table(pd.DataFrame([figures]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                    title="over all cases:")
    elif args.what == "platemap":
        figures = bench_platemap(strikes=args.strikes, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="plate map, feigin-pair lower wall, reference exhaustive mode (best of repeats):")
    else:
        figures = bench_engines(steps=args.steps, repeats=args.repeats)
        print_table(figures, title="engines on feigin-pair (steps per second, best of repeats):")
    return figures


def register(sub, formatter) -> None:
    """Add ``bench`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("bench", help=COMMANDS["bench"], formatter_class=formatter)
    p.add_argument("what", choices=("reference", "engines", "platemap", "sweep", "tune", "ladder", "atlas", "help"), help="what to time")
    p.add_argument("--max-runs", type=positive_int, default=None,
                   help="`bench tune`: runs each tune makes at most; None: tune's default")
    p.add_argument("--points", type=integer_type(2, 10_000), default=None, help="comparison points for `bench sweep`, "
                   "in [2, 10000]; None: 200")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="workers for `bench sweep`, `bench tune` and `bench atlas`, at most one per core; None: 2")
    p.add_argument("--refine", metavar="SPEC.toml", default=None,
                   help="`bench sweep`: the adaptive map (a spec with [refine]) timed against its full fine grid; "
                        "None: feigin-pair, 1 forcing period, dt x R 5 x 5, depth 2")
    p.add_argument("--only", choices=("overhead", "refine", "warp"), default=None,
                   help="`bench sweep`: only the sweep overhead (--points), or only the adaptive map (--refine), or only "
                        "mujoco_warp's world-steps per second (--worlds; needs the warp extra); None: all")
    p.add_argument("--worlds", type=_world_counts, default=None, metavar="N[,N...]",
                   help="`bench sweep`: worlds per mujoco_warp batch, each in [1, 262144], timed on the device warp finds "
                        "(cuda, else cpu); None: 1,16,256")
    p.add_argument("--strikes", type=integer_type(1, 10**7), default=None,
                   help="strikes for `bench platemap`, in [1, 1e7]; None: 100000")
    p.add_argument("--periods", type=integer_type(1, 100_000), default=None,
                   help="forcing periods for `bench reference`, in [1, 100000]; None: 100")
    p.add_argument("--steps", type=integer_type(1, 10**8), default=None,
                   help="engine steps for `bench engines`, in [1, 1e8]; None: 200000")
    p.add_argument("--repeats", type=integer_type(1, 100), default=None,
                   help="repeats of `bench reference`, `engines`, `platemap`, `ladder`, `help`, in [1, 100]; the best counts; None: 5")
    p.set_defaults(func=cmd_bench)
