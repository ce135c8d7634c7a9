"""The ``chatterbench gate`` subcommand: run a gate file's accuracy checks, for CI.

    $ chatterbench gate gates/default.toml
    $ chatterbench gate gates/default.toml --junit out/gate.xml --json out/bench.json
    $ chatterbench gate gates/default.toml --save-baseline baseline.json      # on the main branch
    $ chatterbench gate gates/default.toml --baseline baseline.json           # on a pull request

Validates the whole file first (format: ``ci/gate.py`` docstring; ``--tolerance KEY=VALUE``
sets the tolerances every check's own ``tolerances`` table starts from), runs every check and
decides each once (``ci/decision.py``: its limits, a failed run, its regressions against
``--baseline``), prints one line per limit and regressed metric (measured value, limit,
pass/FAIL), ends a failing run with the commands to run next for the worst check (its
``compare ... --out`` with figures, then ``tune``), and writes what a CI job reads: JUnit XML
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

from chatterbench.comparisons.ci.baseline import BAND, load_baseline, save_baseline
from chatterbench.comparisons.pipeline.atomic import write_text
from chatterbench.comparisons.pipeline.inert_text import log_text
from chatterbench.reference.errors import check_number

from .commands import COMMANDS
from .common import (UsageError, add_budget, add_timeout, add_tolerance, budget_of, file_notes, one_line, parse_tolerances,
                     print_table)
from .paths import check_distinct, check_file, same_file, writing
from .progress import Progress, waited_s


def cmd_gate(args: argparse.Namespace) -> int:
    from chatterbench.comparisons.ci.checks import run_gate
    from chatterbench.comparisons.ci.decision import decide, decide_check
    from chatterbench.comparisons.ci.gate import load_gate
    from chatterbench.comparisons.ci.job_outputs import annotations

    outputs = {f"--{o.replace('_', '-')}": getattr(args, o) for o in ("junit", "summary", "json", "save_baseline")}
    for option, path in outputs.items():
        check_file(option, path)
    # no output may replace another, or an input (--save-baseline may update the --baseline it read)
    check_distinct(outputs, {"GATES.toml": args.gates, "--baseline": args.baseline,
                             "$GITHUB_STEP_SUMMARY": os.environ.get("GITHUB_STEP_SUMMARY") or None},
                   may_replace={("--save-baseline", "--baseline")})
    check_number("--band", args.band, lo=0.0, error=UsageError)
    base = load_baseline(args.baseline) if args.baseline else None  # a bad baseline costs no run
    gate = load_gate(args.gates, base_tolerances=parse_tolerances(args.tolerance))
    print(log_text(f"{gate.path}: {len(gate.checks)} checks" + (f" ({gate.description})" if gate.description else "")),
          file=sys.stderr)
    file_notes([check.scene for check in gate.checks])
    if base is not None and base.get("gate") and not same_file(base["gate"], gate.path):
        print(f"chatterbench: note: --baseline {one_line(args.baseline)} was saved from gate file "
              f"{one_line(repr(base['gate']))}, not {one_line(repr(gate.path))}: its checks are compared by name, and one "
              "whose run differs (scene, engine, settings, tolerances) is reported as not in the baseline", file=sys.stderr)
    decided = []
    with Progress(len(gate.checks), f"gate {gate.path}", unit="check") as bar:
        def on_check(i: int, result) -> None:  # each check is decided once, as its run ends
            decided.append(decide_check(result, base, args.band))
            bar.write(decided[-1].progress_line(i, len(gate.checks)))

        result = run_gate(gate, on_check=on_check, timeout=args.timeout, budget=budget_of(args),
                          starting=lambda i, check: bar.stage(log_text(check.name)))
    decision = decide(result, base, args.band, args.baseline, checks=tuple(decided))
    print_table(decision.table(), title=f"{gate.path}: {len(result.results)} checks")
    for c in decision.checks:
        if not c.passed:
            print("\n" + c.account())
    if decision.baseline:
        print("\n" + decision.baseline_line())
    if os.environ.get("GITHUB_ACTIONS") == "true":  # workflow commands: annotations on the run's page
        for line in annotations(decision):
            print(line)
    try:
        written = _write_outputs(args, decision)
    except BaseException:  # a file that cannot be written (exit 2), Ctrl-C (130): the verdict is said all the same
        _verdict(decision, result)
        raise
    if written:
        print(log_text(f"wrote {', '.join(written)}"))
    _verdict(decision, result)
    return decision.exit_code


def _write_outputs(args: argparse.Namespace, decision) -> list[str]:
    """Write the files the options name and append the job summary to ``$GITHUB_STEP_SUMMARY``; returns what was
    written. A step summary that cannot be appended to is one warning line: it is GitHub's file, not an output the
    user asked for, and the verdict must still reach the log."""
    from chatterbench.comparisons.ci.job_outputs import append_step_summary, benchmark_json, job_summary
    from chatterbench.comparisons.ci.junit import write_junit

    summary = job_summary(decision)
    if args.summary:
        with writing("--summary", args.summary):
            write_text(Path(args.summary), summary)
    if os.environ.get("GITHUB_STEP_SUMMARY"):  # GitHub's job summary file: appended to, as every step does
        problem = append_step_summary(os.environ["GITHUB_STEP_SUMMARY"], summary)
        if problem:
            print(f"chatterbench: warning: $GITHUB_STEP_SUMMARY {one_line(problem)}; the verdict is in this log",
                  file=sys.stderr)
    if args.json:
        with writing("--json", args.json):
            write_text(Path(args.json), benchmark_json(decision))
    if args.save_baseline:
        with writing("--save-baseline", args.save_baseline):
            save_baseline(decision.result, args.save_baseline)
    if args.junit:
        with writing("--junit", args.junit):
            write_junit(decision, args.junit)
    return [p for p in (args.junit, args.summary, args.json, args.save_baseline) if p]


def _verdict(decision, result) -> None:
    """The run's time, the verdict and what to run next: the output's last lines."""
    print(f"gate: {len(result.results)} checks in {waited_s():.1f} s since the command started (their runs "
          f"{result.wall_s:.1f} s)")
    print(decision.headline(), flush=True)
    steps = decision.next_steps()
    if steps:
        print(steps[0] + "\n" + "\n".join(f"  {line}" for line in steps[1:]), flush=True)


def register(sub, formatter) -> None:
    """Add ``gate`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("gate", help=COMMANDS["gate"], formatter_class=formatter)
    p.add_argument("gates", metavar="GATES.toml", help="gate file (format: chatterbench.comparisons.ci.gate docstring)")
    p.add_argument("--junit", metavar="PATH", default=None,
                   help="write JUnit XML here (one testcase per check and per regressed metric)")
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
