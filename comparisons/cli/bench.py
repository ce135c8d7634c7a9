"""``chatterbench bench``: speed benchmarks, run by hand (never as timed tests).

    $ chatterbench bench reference
    $ chatterbench bench engines --steps 200000
    $ chatterbench bench platemap
    $ chatterbench bench sweep --points 40 --workers 2
"""

from __future__ import annotations

import argparse

import pandas as pd

from chatterbench.comparisons.studies.bench import bench_engines, bench_platemap, bench_reference, bench_sweep

from .common import positive_int, print_table


def cmd_bench(args: argparse.Namespace) -> int:
    if args.what == "reference":
        figures = bench_reference(periods=args.periods, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="reference on feigin-pair (best of repeats, one core):")
        print("goals: feigin mode < 20 ms per 100 periods; exhaustive mode < 20 us per impact")
        return 0
    if args.what == "sweep":
        figures = bench_sweep(points=args.points, workers=args.workers)
        print_table(pd.DataFrame([figures]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                    title="sweep overhead: feigin-pair, both engines, 3 periods, dt = 1e-4")
        print("goals: overhead_ratio (wall against the runs' own time) and engine_ratio (against engine stepping alone) "
              "<= 1.15; speedup (1 worker against --workers) >= 1.7")
        return 0
    if args.what == "platemap":
        figures = bench_platemap(strikes=args.strikes, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="plate map, feigin-pair lower wall, reference exhaustive mode (best of repeats):")
        print("goal: 100,000 strikes in under 30 s")
        return 0
    table = bench_engines(steps=args.steps, repeats=args.repeats)
    print_table(table, title="engines on feigin-pair (steps per second, best of repeats):")
    print("goal: adapter keeps >= 80% of the raw engine loop")
    return 0


def register(sub, formatter) -> None:
    """Add ``bench`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("bench", help="benchmarks: reference speed, engine steps per second, plate map, sweeps",
                       formatter_class=formatter)
    p.add_argument("what", choices=("reference", "engines", "platemap", "sweep"), help="what to time")
    p.add_argument("--points", type=positive_int, default=200, help="comparison points for `bench sweep`")
    p.add_argument("--workers", type=positive_int, default=2, help="workers for `bench sweep`")
    p.add_argument("--strikes", type=positive_int, default=100_000, help="strikes for `bench platemap`")
    p.add_argument("--periods", type=positive_int, default=100, help="forcing periods for `bench reference`")
    p.add_argument("--steps", type=positive_int, default=200_000, help="engine steps for `bench engines`")
    p.add_argument("--repeats", type=positive_int, default=5, help="repeats; the best counts")
    p.set_defaults(func=cmd_bench)
