"""The ``chatterbench`` command: one entry point, one module per subcommand (``cli/*.py``), all over ``common``.

    >>> from chatterbench.comparisons.cli.main import main
    >>> main(["scenes"])  # doctest: +ELLIPSIS
            scene   R ...
    0

Every subcommand prints a short table and writes files only where asked (``--out``,
``--events``, ``--junit``). Exit codes: 0 ok, 1 a check failed (gate, tune), 2 bad input:
one line naming the field, the value and what is allowed, never a traceback. Figures are
rendered with matplotlib's non-interactive backend, chosen here and nowhere else.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import Iterable

from chatterbench.engines.isolate import run_limit, set_run_limit
from chatterbench.reference.errors import InputError

from . import _COMMAND, Terminated, answered, interrupt, quiet_interrupts
from .commands import COMMANDS
from .common import HelpFormatter, Parser, UsageError, check_settings, held_warnings, one_line
from .paths import write_error
from .progress import heartbeat

SUBCOMMANDS = tuple(COMMANDS)  # in the order ``chatterbench --help`` lists them; module ``cli/NAME.py`` each


def build_parser(commands: Iterable[str] | None = None) -> Parser:
    """The argument parser; ``commands``: the subcommands registered in full (their modules imported), None: all.

    The others are listed by name and help only (``commands.COMMANDS``), so ``chatterbench NAME ...``
    and ``chatterbench --help`` load no module but NAME's.
    """
    parser = Parser(prog="chatterbench", formatter_class=HelpFormatter,
                    description="Cross-validate multibody engines' impact chatter against Feigin's sliding model.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    full = set(COMMANDS if commands is None else commands)
    for name, text in COMMANDS.items():
        if name in full:
            importlib.import_module(f"{__package__}.{name}").register(sub, HelpFormatter)
        else:
            sub.add_parser(name, help=text, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``chatterbench`` console script; returns the exit code."""
    if "matplotlib" in sys.modules:  # the command line draws to files; a library user keeps their own backend
        sys.modules["matplotlib"].use("Agg")
    else:  # read when a command first draws: importing matplotlib now would slow every refusal
        os.environ["MPLBACKEND"] = "Agg"
    for stream in (sys.stdout, sys.stderr):  # PYTHONIOENCODING=ascii, a C locale: an emoji name is shown as \U0001f3be
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser([w for w in argv[:1] if w in COMMANDS])  # the top level has no option but --help
    args = parser.parse_args(argv)
    limit = run_limit()
    try:
        with held_warnings() as held:  # numpy's overflow warnings, say: shown after the work, never around an error line
            held.keep = (code := _run(args)) != 2
    finally:  # --timeout holds the command's own runs, never a caller's after it (main called in a process that goes on)
        set_run_limit(limit)
    return code


def _run(args) -> int:
    """The subcommand, its refusals and failures turned into one line and an exit code."""
    quiet_interrupts(False)
    try:
        check_settings(args)
        with heartbeat(f"chatterbench {args.command}"):  # a line at least every LINE_EVERY_S s, whatever the output
            code = args.func(args)
        if interrupt.seen:  # a Ctrl-C whose KeyboardInterrupt a garbage-collection callback swallowed
            answered()  # its resend may still be armed
            raise KeyboardInterrupt
        return code
    except (InputError, UsageError) as exc:  # every refusal of user input
        text = "\n".join(map(one_line, str(exc).split("\n"))) if getattr(exc, "multiline", False) else one_line(str(exc))
        print(f"chatterbench: error: {text}", file=sys.stderr)
        return 2
    except OSError as exc:  # writing failed after the checks (a full disk): one line, no temp file left
        if isinstance(exc, BrokenPipeError):  # the reader left (``| head``): say nothing more
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 1
        print(f"chatterbench: error: {one_line(write_error(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        answered()  # no second KeyboardInterrupt inside this answer to the first
        print("chatterbench: interrupted", file=sys.stderr)
        if _COMMAND:  # as the command: leave now, before the interpreter's finalization gives SIGINT its
            # default action again (a Ctrl-C still pending there killed the process: -2 after this line)
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(130)
        return 130
    except Terminated:  # SIGTERM: what was being written is removed (atomic.staged), as for Ctrl-C
        print("chatterbench: terminated", file=sys.stderr)
        return 143
    finally:
        quiet_interrupts(True)  # a Ctrl-C while the interpreter shuts down (joining a pool) is one line, exit 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
