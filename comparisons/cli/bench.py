"""``chatterbench bench``: speed benchmarks, run by hand (never as timed tests).

    $ chatterbench bench reference
    $ chatterbench bench engines --steps 200000
    $ chatterbench bench platemap
    $ chatterbench bench sweep --points 40 --workers 2
    $ chatterbench bench sweep --only refine --refine examples/sweeps/feigin-pair-refine.toml

Each prints its figures, what one repeat is, and ``PASS``/``FAIL`` per goal (``GOALS``);
the exit code is 1 when a goal fails, so a benchmark can gate a performance job.
"""

from __future__ import annotations

import argparse

import pandas as pd

from chatterbench.comparisons.studies.bench import bench_engines, bench_platemap, bench_reference, bench_refine, bench_sweep, \
    bench_warp
from chatterbench.engines.registry import unavailable_reason

from .common import positive_int, print_table


# each benchmark's goals: (figure, "<=" or ">=", bound, what it means)
GOALS = {
    "reference": [("feigin_ms_per_100_periods", "<=", 20.0, "Feigin mode, ms per 100 forcing periods"),
                  ("exhaustive_us_per_impact", "<=", 20.0, "exhaustive mode, us per impact")],
    "sweep": [("overhead_ratio", "<=", 1.15, "sweep wall time against the runs' own time"),
              ("engine_ratio", "<=", 1.15, "sweep wall time against engine stepping alone"),
              ("speedup", ">=", 1.7, "1 worker against --workers"),
              ("refine_agreement", ">=", 0.95, "adaptive map's verdicts against the full fine grid's, share of fine cells"),
              ("refine_speedup", ">=", 1.5, "adaptive map's cells per minute against the full fine grid's")],
    "platemap": [("seconds", "<=", 30.0 * 1e-5, "seconds per strike (100,000 strikes in under 30 s)")],
    "engines": [("ratio", ">=", 0.8, "adapter steps/s against the raw engine loop, each engine")],
}
REPEAT = {  # what one repeat is, and which counts
    "reference": "one repeat = one run of each chatter mode over --periods; the best of --repeats counts",
    "engines": "one repeat = --steps steps of each engine, adapter and raw loop; the best of --repeats counts",
    "platemap": "one repeat = the whole grid of --strikes strikes; the best of --repeats counts (time of one repeat)",
    "sweep": "one sweep of --points points x 2 engines, once with --workers and once with 1 worker; the adaptive map "
             "of --refine and its full fine grid, once each with --workers (no repeats)",
}


def goal_lines(what: str, figures: dict[str, float] | pd.DataFrame, strikes: int = 1) -> tuple[list[str], bool]:
    """``PASS``/``FAIL`` per goal of benchmark ``what`` with the measured value; and whether all passed."""
    lines, ok = [], True
    for key, op, bound, meaning in GOALS[what]:
        if isinstance(figures, dict) and key not in figures:  # a part not run (bench sweep --only)
            continue
        values = list(figures[key]) if isinstance(figures, pd.DataFrame) else [figures[key]]
        if what == "platemap":
            values = [v / strikes for v in values]
        passed = all((v <= bound) if op == "<=" else (v >= bound) for v in values)
        ok &= passed
        shown = ", ".join(f"{v:.4g}" for v in values)
        lines.append(f"{'PASS' if passed else 'FAIL'}: {key} = {shown} (goal {op} {bound:g}: {meaning})")
    return lines, ok


def _world_counts(text: str) -> tuple[int, ...]:
    """argparse type of ``--worlds``: comma-separated integers > 0."""
    return tuple(positive_int(w) for w in text.split(",") if w.strip())


def _print_warp(worlds: tuple[int, ...]) -> None:
    """MuJoCo Warp's world-steps per second on the device it finds, per number of worlds (``bench_warp``)."""
    reason = unavailable_reason("mujoco_warp")
    if reason:
        print(f"mujoco_warp world-steps per second: not measured: {reason}")
        return
    figures = bench_warp(worlds=worlds)
    print_table(figures, title=f"mujoco_warp world-steps per second on device {figures['device'].iloc[0]} "
                               f"({figures['precision'].iloc[0]}), feigin-pair, dt = 1e-3, against MuJoCo C (1 thread):")


def cmd_bench(args: argparse.Namespace) -> int:
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
            refined, per_engine = bench_refine(args.refine, workers=args.workers)
            print_table(pd.DataFrame([refined]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                        title=f"adaptive map against the full fine grid ({args.refine or 'feigin-pair, 1 period, dt x R, depth 2'}):")
            print_table(per_engine, title="fine cells per engine whose verdict the adaptive map gets right:")
            figures.update({f"refine_{k}": v for k, v in refined.items()})
        if args.only in (None, "warp"):
            _print_warp(args.worlds)
    elif args.what == "platemap":
        figures = bench_platemap(strikes=args.strikes, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="plate map, feigin-pair lower wall, reference exhaustive mode (best of repeats):")
    else:
        figures = bench_engines(steps=args.steps, repeats=args.repeats)
        print_table(figures, title="engines on feigin-pair (steps per second, best of repeats):")
    print(REPEAT[args.what])
    lines, ok = goal_lines(args.what, figures, strikes=args.strikes)
    print("\n".join(lines))
    return 0 if ok else 1


def register(sub, formatter) -> None:
    """Add ``bench`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("bench", help="benchmarks: reference speed, engine steps per second, plate map, sweeps",
                       formatter_class=formatter)
    p.add_argument("what", choices=("reference", "engines", "platemap", "sweep"), help="what to time")
    p.add_argument("--points", type=positive_int, default=200, help="comparison points for `bench sweep`")
    p.add_argument("--workers", type=positive_int, default=2, help="workers for `bench sweep`")
    p.add_argument("--refine", metavar="SPEC.toml", default=None,
                   help="`bench sweep`: the adaptive map (a spec with [refine]) timed against its full fine grid; "
                        "None: feigin-pair, 1 forcing period, dt x R 5 x 5, depth 2")
    p.add_argument("--only", choices=("overhead", "refine", "warp"), default=None,
                   help="`bench sweep`: only the sweep overhead (--points), or only the adaptive map (--refine), or only "
                        "mujoco_warp's world-steps per second (--worlds); None: all")
    p.add_argument("--worlds", type=_world_counts, default=(1, 16, 256), metavar="N[,N...]",
                   help="`bench sweep`: worlds per mujoco_warp batch, timed on the device warp finds (cuda, else cpu)")
    p.add_argument("--strikes", type=positive_int, default=100_000, help="strikes for `bench platemap`")
    p.add_argument("--periods", type=positive_int, default=100, help="forcing periods for `bench reference`")
    p.add_argument("--steps", type=positive_int, default=200_000, help="engine steps for `bench engines`")
    p.add_argument("--repeats", type=positive_int, default=5, help="repeats; the best counts")
    p.set_defaults(func=cmd_bench)
