"""``chatterbench engines``: every engine the suite knows, built in or a plugin, its extra or package, version, status.

    $ chatterbench engines                  # the table; exit 2 when an installed plugin is broken
    $ chatterbench engines pymunk           # one engine: exit 2 unless it can run here

One row per engine of the table (``engines.registry.engine_rows``), and one per plugin whose
name is refused (``reference``, a built-in engine's, another plugin's): ``status`` is ``ok``,
``not installed`` (an optional engine's extra is missing: the line says what installs it) or
``broken`` (a plugin that does not load: the line names its package and what is wrong). Each
plugin is loaded in a forked child first, so a broken one is its row, never this command's
crash. A broken plugin, or a named engine that cannot run, is also the command's one-line
error on stderr, and the exit code is 2; the other engines are listed as usual.
"""

from __future__ import annotations

import argparse
import sys

from chatterbench.engines.plugins import LOAD_LIMIT
from chatterbench.engines.registry import DECLARED, check_engine, engine_rows

from .commands import COMMANDS
from .common import one_line, print_table, timeout_seconds


def cmd_engines(args: argparse.Namespace) -> int:
    import pandas as pd  # with the work, not with --help
    named = list(dict.fromkeys(args.names or ()))
    declared = {d.name for d in DECLARED}
    for name in named:
        if name not in declared:
            check_engine(name)  # not one of them: refused with the names and the nearest
    shown = engine_rows(named or None)
    table = pd.DataFrame([{"engine": r.name, "from": r.source, "installed by": r.install, "version": r.version,
                           "status": r.status} for r in shown])
    print_table(table)
    notes = [r for r in shown if r.reason]
    for r in notes:
        print(f"  {r.name}: {r.reason}")
    failing = [r for r in notes if r.status == "broken" or named]
    for r in failing:
        print(f"chatterbench: error: {one_line(r.reason)}", file=sys.stderr)
    return 2 if failing else 0


def register(sub, formatter) -> None:
    """Add ``engines`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("engines", help=COMMANDS["engines"], formatter_class=formatter)
    p.add_argument("names", nargs="*", metavar="ENGINE",
                   help="show only these engines; exit 2 unless each can run here (default: all)")
    p.add_argument("--timeout", type=timeout_seconds, default=LOAD_LIMIT, metavar="SECONDS",
                   help="wall-clock limit of each plugin's load [s], in (0, 86400]: a plugin still loading is broken")
    p.set_defaults(func=cmd_engines)
