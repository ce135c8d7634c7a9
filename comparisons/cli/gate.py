"""The ``chatterbench gate`` subcommand: run a gate file's accuracy checks, for CI.

    $ chatterbench gate gates/default.toml
    $ chatterbench gate gates/default.toml --junit out/gate.xml --json out/bench.json
    $ chatterbench gate gates/default.toml --save-baseline baseline.json      # on the main branch
    $ chatterbench gate gates/default.toml --baseline baseline.json           # on a pull request

Validates the whole file first (format: ``ci/gate.py`` docstring; ``--tolerance KEY=VALUE``
sets the tolerances every check's own ``tolerances`` table starts from), runs every check, prints one
line per limit (measured value, limit, pass/FAIL) and writes what a CI job reads: JUnit XML
(``--junit``), a Markdown job summary (``--summary``, appended to ``$GITHUB_STEP_SUMMARY`` when
that is set), ``::error`` annotations on stdout when ``GITHUB_ACTIONS=true``, a benchmark JSON
(``--json``, ``customSmallerIsBetter``), a baseline to compare later runs with
(``--save-baseline``; ``--baseline`` fails a run whose errors grew beyond ``--band``).
Exit codes: 0 every check passed (and nothing regressed), 1 a check failed or a metric
regressed, 2 bad input (the gate file, a scene, a setting, a baseline file).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from chatterbench.comparisons.ci.baseline import BAND, load_baseline, regressions, save_baseline
from chatterbench.comparisons.ci.checks import run_gate
from chatterbench.comparisons.ci.gate import load_gate
from chatterbench.comparisons.ci.job_outputs import _escape, annotations, benchmark_json, job_summary
from chatterbench.comparisons.ci.junit import write_junit
from chatterbench.comparisons.outputs.atomic import write_text

from chatterbench.reference.errors import check_number

from .common import UsageError, add_budget, add_timeout, add_tolerance, budget_of, parse_tolerances, print_table
from .paths import check_file, writing


def cmd_gate(args: argparse.Namespace) -> int:
    for option in ("junit", "summary", "json", "save_baseline"):
        check_file(f"--{option.replace('_', '-')}", getattr(args, option))
    check_number("--band", args.band, lo=0.0, error=UsageError)
    base = load_baseline(args.baseline) if args.baseline else None  # a bad baseline costs no run
    gate = load_gate(args.gates, base_tolerances=parse_tolerances(args.tolerance))
    print(f"{gate.path}: {len(gate.checks)} checks" + (f" ({gate.description})" if gate.description else ""), file=sys.stderr)
    result = run_gate(gate, progress=lambda line: print(line, file=sys.stderr, flush=True), timeout=args.timeout,
                      budget=budget_of(args))
    print_table(result.table(), title=f"{gate.path}: {len(result.results)} checks in {result.wall_s:.1f} s")
    failed = [r for r in result.results if not r.passed]
    for r in failed:
        print("\n" + r.failure_message())
    grown = regressions(result, base, args.band) if base is not None else []
    for g in grown:
        print(f"REGRESSION: {g.message}")
    if os.environ.get("GITHUB_ACTIONS") == "true":  # workflow commands: annotations on the run's page
        for line in annotations(result):
            print(line)
        for g in grown:
            print(f"::error title={_escape('chatter gate regression ' + g.check, property_=True)}::{_escape(g.message)}")
    extra = "\n".join(["### Regressions against the baseline", ""] + [f"- {g.message}" for g in grown]) if grown else ""
    summary = job_summary(result, extra)
    if args.summary:
        with writing("--summary", args.summary):
            write_text(Path(args.summary), summary)
    if os.environ.get("GITHUB_STEP_SUMMARY"):  # GitHub's job summary file: appended to, as every step does
        with open(os.environ["GITHUB_STEP_SUMMARY"], "a", encoding="utf-8") as f:
            f.write(summary)
    if args.json:
        with writing("--json", args.json):
            write_text(Path(args.json), benchmark_json(result))
    if args.save_baseline:
        with writing("--save-baseline", args.save_baseline):
            save_baseline(result, args.save_baseline)
    if args.junit:
        with writing("--junit", args.junit):
            write_junit(result, args.junit)
    written = [p for p in (args.junit, args.summary, args.json, args.save_baseline) if p]
    if written:
        print(f"wrote {', '.join(written)}")
    ok = not failed and not grown
    print(f"{'PASS' if ok else 'FAIL'}: {len(result.results) - len(failed)} of {len(result.results)} checks passed"
          + (f"; {len(grown)} metric(s) regressed against {args.baseline}" if base is not None else ""))
    return 0 if ok else 1


def register(sub, formatter) -> None:
    """Add ``gate`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("gate", help="run accuracy checks from a gate file; exit 1 if any fails (for CI)",
                       formatter_class=formatter)
    p.add_argument("gates", metavar="GATES.toml", help="gate file (format: chatterbench.comparisons.ci.gate docstring)")
    p.add_argument("--junit", metavar="PATH", default=None, help="write JUnit XML here (one testcase per check)")
    p.add_argument("--summary", metavar="PATH", default=None,
                   help="write the Markdown job summary here (it is also appended to $GITHUB_STEP_SUMMARY when set)")
    p.add_argument("--json", metavar="PATH", default=None,
                   help="write every measured metric as customSmallerIsBetter benchmark JSON here")
    p.add_argument("--baseline", metavar="PATH", default=None,
                   help="a baseline written by --save-baseline: fail when an error metric grew beyond --band")
    p.add_argument("--save-baseline", metavar="PATH", default=None, help="write this run's metrics as a baseline here")
    p.add_argument("--band", type=float, default=BAND, metavar="FRACTION",
                   help="relative growth of an error metric over the baseline that counts as a regression")
    add_tolerance(p)
    add_timeout(p)
    add_budget(p)
    p.set_defaults(func=cmd_gate)
