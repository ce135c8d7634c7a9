"""``chatterbench judge``: any simulator's trajectory file, judged against the reference, episode by episode.

    $ chatterbench judge my-scene.toml run.csv --engine jolt --out out/jolt
    $ chatterbench judge bouncing-ball run.parquet --tolerance stick=0.02

TRAJECTORY is CSV or Parquet with the columns t, x1, x2, v1, v2 and optionally force_lower,
force_upper (``pipeline/trajectory_file.py``). Prints the same episode table and summary as
``compare`` and says how contact was taken; ``--out`` writes the same files and figures.
Exit 0 when every episode agrees (``match``, or ``none``: nothing to judge on either side),
1 otherwise, 2 on bad input (one line naming the column or row).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from chatterbench.comparisons.pipeline.trajectory_file import judge_trajectory
from chatterbench.comparisons.pipeline.vocabulary import combine
from chatterbench.reference.scene import load_scene

from .common import add_out, add_scene, add_tolerance, parse_tolerances, print_table
from .compare import EPISODE_SHOW, SUMMARY_SHOW
from .paths import check_dir, writing

AGREE = ("match", "none")  # the run's combined verdict that exits 0


def cmd_judge(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    scene = load_scene(args.scene)
    tol = parse_tolerances(args.tolerance)
    engine = args.engine or Path(args.trajectory).stem
    result = judge_trajectory(scene, args.trajectory, engine=engine, tol=tol)
    print(f"{engine}: {result.provenance['trajectory']['samples']} samples from {args.trajectory}; "
          f"{result.provenance['trajectory']['contact']}")
    print_table(result.table[EPISODE_SHOW],
                title=f"{scene.name}: {engine}'s episodes against the reference (errors in s; _rel: fraction of the "
                      f"episode's scale; _steps: in median sample spacings); {tol.describe()}")
    print_table(result.summary()[SUMMARY_SHOW], title="summary:")
    if args.out:
        from chatterbench.comparisons.outputs.comparison_files import write_comparison  # draws: loads matplotlib

        with writing("--out", args.out):
            paths = write_comparison(result, Path(args.out), figures=not args.no_figures)
        print(f"wrote {len(paths)} files under {args.out}")
    return 0 if combine(result.table["verdict"]) in AGREE else 1


def register(sub, formatter) -> None:
    """Add ``judge`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("judge", help="judge any simulator's trajectory file (CSV, Parquet) against the reference",
                       formatter_class=formatter)
    add_scene(p)
    p.add_argument("trajectory", help="CSV or Parquet: t, x1, x2, v1, v2 [, force_lower, force_upper] in SI units")
    p.add_argument("--engine", "--engines", dest="engine", default=None, metavar="NAME",
                   help="the judged engine's name in the tables, as --engines names the engines compare runs "
                        "(default: the file's stem)")
    add_tolerance(p)
    add_out(p, what="write tables (CSV, Parquet), event logs, impacts, provenance and figures under DIR")
    p.add_argument("--no-figures", action="store_true", help="skip the figures under --out")
    p.set_defaults(func=cmd_judge)
