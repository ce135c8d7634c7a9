"""The ``chatterbench gate`` subcommand: run a gate file's accuracy checks, for CI.

    $ chatterbench gate gates/default.toml
    $ chatterbench gate gates/default.toml --junit out/gate.xml

Validates the whole file first (format: ``ci/gate.py`` docstring; ``--tolerance KEY=VALUE``
sets the tolerances every check's own ``tolerances`` table starts from), runs every check, prints one
line per limit (measured value, limit, pass/FAIL) and writes JUnit XML where ``--junit``
says (one testcase per check, a <failure> with the numbers). Exit codes: 0 every check
passed, 1 a check failed, 2 bad input (the gate file, a scene, a setting).
"""

from __future__ import annotations

import argparse
import sys

from chatterbench.comparisons.ci.checks import run_gate
from chatterbench.comparisons.ci.gate import load_gate
from chatterbench.comparisons.ci.junit import write_junit

from .common import add_budget, add_timeout, add_tolerance, budget_of, parse_tolerances, print_table
from .paths import check_file


def cmd_gate(args: argparse.Namespace) -> int:
    check_file("--junit", args.junit)
    gate = load_gate(args.gates, base_tolerances=parse_tolerances(args.tolerance))
    print(f"{gate.path}: {len(gate.checks)} checks" + (f" ({gate.description})" if gate.description else ""), file=sys.stderr)
    result = run_gate(gate, progress=lambda line: print(line, file=sys.stderr, flush=True), timeout=args.timeout,
                      budget=budget_of(args))
    print_table(result.table(), title=f"{gate.path}: {len(result.results)} checks in {result.wall_s:.1f} s")
    failed = [r for r in result.results if not r.passed]
    for r in failed:
        print("\n" + r.failure_message())
    if args.junit:
        write_junit(result, args.junit)
        print(f"wrote {args.junit}")
    print(f"{'PASS' if not failed else 'FAIL'}: {len(result.results) - len(failed)} of {len(result.results)} checks passed")
    return 0 if not failed else 1


def register(sub, formatter) -> None:
    """Add ``gate`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("gate", help="run accuracy checks from a gate file; exit 1 if any fails (for CI)",
                       formatter_class=formatter)
    p.add_argument("gates", metavar="GATES.toml", help="gate file (format: chatterbench.comparisons.ci.gate docstring)")
    p.add_argument("--junit", metavar="PATH", default=None, help="write JUnit XML here (one testcase per check)")
    add_tolerance(p)
    add_timeout(p)
    add_budget(p)
    p.set_defaults(func=cmd_gate)
