"""``chatterbench judge``: any simulator's trajectory file, judged against the reference, episode by episode.

    $ chatterbench judge my-scene.toml run.csv --engine jolt --out out/jolt
    $ chatterbench judge bouncing-ball run.parquet --tolerance stick=0.02

TRAJECTORY is CSV (or .csv.gz, .bz2, .xz) or Parquet with the columns t, x1, x2, v1, v2 and
optionally force_lower, force_upper (signed, compressive positive: ``pipeline/trajectory_file.py``).
Prints the same episode table and summary as ``compare``, says how contact was taken and
with which precision, one line per fact worth knowing (a resting offset, a wall that pulls,
where the force columns and the gap alone disagree), and why each episode that is not
``match`` got its verdict (``unresolved``: the bound and the step that would resolve it);
``--out`` writes the same files and figures. Exit 0 when every episode agrees (``match``, or
``none``: nothing to judge on either side), 1 otherwise, 2 on bad input (one line naming the
column or row).
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from chatterbench.reference.tables import printable

from .commands import COMMANDS
from .common import UsageError, add_out, add_scene, add_tolerance, load_noted, parse_tolerances, print_table
from .compare import EPISODE_SHOW, SUMMARY_SHOW
from .paths import check_dir, writing

PRECISIONS = ("float64", "float32")  # --precision: pipeline.gap_contact.PRECISIONS's keys (tested), read without numpy

AGREE = ("match", "none")  # the run's combined verdict that exits 0
LABEL = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}")  # an engine's name in tables and file names (events_NAME.csv)


def engine_label(text: str) -> str:
    """``--engine``: a name, never a path: letters, digits and ``_ . + -``, at most 64, starting with a letter or digit."""
    if not LABEL.fullmatch(text):
        raise UsageError(f"--engine {printable(text)[:80]!r}: a name for the tables and the file names under --out "
                         "(events_NAME.csv): letters, digits and _ . + -, at most 64 characters, starting with a letter "
                         "or digit; no '/' or other path characters")
    return text


def cmd_judge(args: argparse.Namespace) -> int:
    from chatterbench.comparisons.pipeline.trajectory_file import judge_trajectory  # with the work, not with --help
    from chatterbench.comparisons.pipeline.vocabulary import combine
    check_dir("--out", args.out)
    scene = load_noted(args.scene)
    tol = parse_tolerances(args.tolerance)
    engine = engine_label(getattr(args, "engine", None) or _stem(Path(args.trajectory)))
    result = judge_trajectory(scene, args.trajectory, engine=engine, tol=tol,
                              precision=getattr(args, "precision", None))
    facts = result.provenance["trajectory"]
    print(f"{engine}: {facts['samples']} samples from {facts['source']}; {facts['contact']}; positions "
          f"{facts['precision']} ({facts['precision_from']})")
    for note in facts["notes"]:
        print(f"note: {printable(note)}")
    table = result.table
    print_table(table[EPISODE_SHOW],
                title=f"{scene.name}: {engine}'s episodes against the reference (errors in s; _rel: fraction of the "
                      f"episode's scale; _steps: in median sample spacings); {tol.describe()}")
    for k, row in enumerate(table.itertuples()):
        if row.reason:
            print(f"episode {k} ({row.wall or 'run'}): {row.verdict}: {row.reason}")
    print_table(result.summary()[SUMMARY_SHOW], title="summary:")
    if args.out:
        from chatterbench.comparisons.outputs.comparison_files import write_comparison  # draws: loads matplotlib

        with writing("--out", args.out):
            paths = write_comparison(result, Path(args.out), figures=not args.no_figures)
        print(f"wrote {len(paths)} files under {args.out}")
    return 0 if combine(table["verdict"]) in AGREE else 1


def _stem(path: Path) -> str:
    """The file's name without its suffixes (``run.csv.gz`` -> ``run``), made a label where it is not one."""
    stem = path.name.split(".")[0] or "engine"
    return stem if LABEL.fullmatch(stem) else re.sub(r"[^A-Za-z0-9_.+-]", "_", stem)[:64].lstrip("._+-") or "engine"


def register(sub, formatter) -> None:
    """Add ``judge`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("judge", help=COMMANDS["judge"], formatter_class=formatter)
    add_scene(p)
    p.add_argument("trajectory", help="CSV (or .csv.gz, .bz2, .xz) or Parquet: t, x1, x2, v1, v2 [, force_lower, "
                                      "force_upper: signed, compressive positive] in SI units")
    p.add_argument("--engine", "--engines", dest="engine", default=argparse.SUPPRESS, metavar="NAME",
                   help="the judged engine's name in the tables and file names, as --engines names the engines "
                        "compare runs (default: the file's name up to its first dot)")
    p.add_argument("--precision", choices=PRECISIONS, default=argparse.SUPPRESS,
                   help="the floating-point type the positions were written in (default: inferred from the values: "
                        "all float32 numbers, or their shortest text, is float32)")
    add_tolerance(p)
    add_out(p, what="write tables (CSV, Parquet), event logs, impacts, provenance and figures under DIR")
    p.add_argument("--no-figures", action="store_true", help="skip the figures under --out")
    p.set_defaults(func=cmd_judge)
