"""The ``chatterbench report`` subcommand: every scene on every engine, one HTML page and its Markdown twin.

    $ chatterbench report                                   # all built-in scenes, the default engines
    $ chatterbench report feigin-pair bouncing-ball --dt 5e-5 --out report-dt5e-5
    $ chatterbench report --sweep out/fp --set duration=20  # add a sweep's charts

Writes ``index.html`` (self-contained: figures embedded, no network) and ``report.md`` under
``--out`` (default ``report``), prints the summary table, and reports progress on stderr,
one line per scene and engine (and a bar, on a terminal). Exit codes: 0 written (a report is not a check: verdicts
other than ``match`` do not fail it; use ``chatterbench gate`` for that), 2 bad input.
"""

from __future__ import annotations

import argparse
import dataclasses
import shlex
import sys
from pathlib import Path

from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.tables import read_text

from .commands import COMMANDS
from .common import (ENGINE_TIMEOUT, UsageError, add_judging, add_out, budget_of, engine_list, file_notes, one_line,
                     parse_tolerances, print_table, settings_of, split_overrides)
from .paths import check_dir, writing
from .progress import Progress


def _command_line(args: argparse.Namespace) -> str:
    """The command, rebuilt from the parsed options (for the report's provenance)."""
    words = ["chatterbench", "report", *args.scenes, "--out", args.out, "--engines", args.engines]
    if args.dt is not None:
        words += ["--dt", f"{args.dt:g}"]
    for item in args.set or []:
        words += ["--set", item]
    for item in args.tolerance or []:
        words += ["--tolerance", item]
    for item in args.sweep or []:
        words += ["--sweep", item]
    for item in args.tune or []:  # before: left out of the provenance
        words += ["--tune", item]
    if args.atlas is not None:
        words += ["--atlas", args.atlas]
    if args.timeout != ENGINE_TIMEOUT:
        words += ["--timeout", f"{args.timeout:g}"]
    return " ".join(shlex.quote(w) for w in words)


GUIDE_MAX_BYTES = 16 * 2**20  # [bytes] of a guide section: tune writes about 0.3 MiB (four figures)


def guide_section(folder: str) -> str:
    """``FOLDER/guide_section.html`` as the report embeds it: a regular file of at most ``GUIDE_MAX_BYTES`` (not a
    link: ``reference.tables.open_in``), read without following it past that, made inert (``outputs.inert_html``: no script, nothing loaded, nothing left open);
    what was left out is said in one note line."""
    from chatterbench.comparisons.outputs.inert_html import inert_section

    path = Path(folder) / "guide_section.html"
    if not path.exists() and not path.is_symlink():
        raise UsageError(f"--tune {folder}: no guide_section.html there (write one with `chatterbench tune ... --out "
                         f"{folder}`)")
    text = read_text(path, f"--tune {folder}: guide_section.html", UsageError, limit=GUIDE_MAX_BYTES, kind="HTML",
                     folder=folder)  # a link in the folder is refused: the page would show any file it points to
    section = inert_section(text)
    if section.removed:
        print(f"chatterbench: note: --tune {one_line(folder)}: guide_section.html holds what `chatterbench tune` does not "
              f"write, left out of the report: {', '.join(section.removed)}", file=sys.stderr)
    return section.html


def atlas_of(option: str | None):
    """The atlas section: ``--atlas DIR``'s (``none``: no section), else the dataset kept with chatterbench; read
    before any run, so a bad folder costs nothing."""
    from chatterbench.comparisons.outputs.atlas_section import check_atlas, packaged_atlas
    from chatterbench.reference.errors import InputError

    if option is not None and option.strip().lower() == "none":
        return None
    try:
        return packaged_atlas() if option is None else check_atlas(option)
    except InputError as exc:
        raise UsageError(str(exc)) from None


def cmd_report(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    from chatterbench.comparisons.outputs.report import SUMMARY_COLUMNS, SweepSection, build_report  # draws: loads matplotlib (0.7 s), so only when asked
    from chatterbench.comparisons.outputs.report_page import write_report
    from chatterbench.comparisons.outputs.frontier_chart import read_frontiers
    from chatterbench.comparisons.studies.sweep.dataset import load_rows

    scene_over, engine_over = split_overrides(args.set)
    tol = parse_tolerances(args.tolerance)
    tuning = tuple(guide_section(d) for d in args.tune or ())  # read before any run, so a bad path costs nothing
    frontiers = read_frontiers(args.tune or ())  # each tune's recommended.json: the frontier chart per scene
    sweeps = [SweepSection(str(d), load_rows(d)) for d in args.sweep or ()]  # bad input before any run
    atlas = atlas_of(args.atlas)
    scenes, engines = args.scenes or tuple(CATALOGUE), engine_list(args.engines)
    file_notes(scenes, scene_over)
    with Progress(len(scenes) * (1 + len(engines)) + 1, "report", unit="step") as bar:  # + 1: the figures and pages
        report = build_report(
            scenes=scenes, engines=engines, dt=args.dt, settings=settings_of(engines, args.dt, engine_over),
            scene_overrides=scene_over, engine_overrides=engine_over, tol=tol, sweeps=sweeps,
            command=_command_line(args), timeout=args.timeout, budget=budget_of(args), progress=bar.write, stage=bar.stage,
        )
        if tuning:
            report = dataclasses.replace(report, tuning=tuning, frontiers=frontiers)
        if atlas is not None:
            report = dataclasses.replace(report, atlas=atlas)
        bar.stage("figures and pages")
        with writing("--out", args.out, together=True) as stage:  # both pages, or neither (Ctrl-C, a full disk)
            paths = [Path(args.out) / p.relative_to(stage) for p in write_report(report, stage)]
    print_table(report.summary[SUMMARY_COLUMNS], title=f"summary ({report.wall_time_s:.1f} s of runs; errors in s):")
    print(f"wrote {paths[0]} and {paths[1]}")
    return 0


def register(sub, formatter) -> None:
    """Add ``report`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("report", help=COMMANDS["report"], formatter_class=formatter)
    p.add_argument("scenes", nargs="*", metavar="SCENE",
                   help="built-in scene names or scene TOML files; none: every built-in scene")
    add_judging(p)
    add_out(p, default="report", what="output directory")
    p.add_argument("--sweep", action="append", metavar="DIR", default=None,
                   help="a sweep dataset (directory with rows.parquet, or a .parquet/.csv file): add its work-precision "
                        "chart and stability maps of the --engines; repeatable, one section each")
    p.add_argument("--tune", action="append", metavar="DIR", default=None,
                   help="include the tuning guide that `chatterbench tune ... --out DIR` wrote, and its robust frontier "
                        "in a chart per scene, one line per engine (repeatable)")
    p.add_argument("--atlas", metavar="DIR", default=None,
                   help="show the atlas that `chatterbench atlas --out DIR` wrote (default: the atlas kept with "
                        "chatterbench, with its provenance; `none`: no atlas section)")
    p.set_defaults(func=cmd_report)
