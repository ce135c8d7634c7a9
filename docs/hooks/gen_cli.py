"""Every subcommand's options, from the argparse parser ``chatterbench`` itself builds.

    >>> from gen_cli import commands_markdown
    >>> text = commands_markdown()
    >>> "## `chatterbench compare`" in text and "<code>--tolerance</code>" in text
    True

One section per subcommand, in the order ``chatterbench --help`` lists them
(``comparisons/cli/commands.py``): its help line, its usage as ``--help`` prints it, and a table of
its arguments (the option strings, the value's name, the default and the help text, expanded as
``--help`` expands it). Nothing is written by hand, so a new option or a changed default shows at the
next build.
"""

from __future__ import annotations

import argparse

from gen_markup import cell, code, fence, table

from chatterbench.comparisons.cli.commands import COMMANDS
from chatterbench.comparisons.cli.main import build_parser


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The subcommands' parsers by name."""
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _default(action: argparse.Action) -> str:
    """The default as a user reads it: none for flags, positionals and defaults that are None or empty."""
    if not action.option_strings or action.nargs == 0 or action.default in (None, argparse.SUPPRESS, [], ()):
        return ""
    return code(action.default)


def _value(action: argparse.Action, parser: argparse.ArgumentParser) -> str:
    """The name of the value an option takes (``--dt DT``), or nothing for a flag."""
    if action.nargs == 0:
        return ""
    formatter = parser._get_formatter()
    default = action.dest.upper() if action.option_strings else action.dest
    names = formatter._metavar_formatter(action, default)(1)
    return code(names[0])


def _help(action: argparse.Action, parser: argparse.ArgumentParser) -> str:
    """The help text with ``%(default)s`` and the like filled in, as ``--help`` shows it (less the default that
    ``--help`` appends: the table has a column for it)."""
    if not action.help:
        return ""
    return cell(argparse.HelpFormatter(parser.prog)._expand_help(action))


def command_markdown(name: str, parser: argparse.ArgumentParser) -> str:
    """One subcommand's section: heading, help line, usage block and the table of its arguments."""
    rows = []
    for action in parser._actions:
        if action.help == argparse.SUPPRESS or isinstance(action, argparse._HelpAction):
            continue
        names = ", ".join(action.option_strings) or (action.metavar or action.dest)
        rows.append([code(names), _value(action, parser) if action.option_strings else "", _default(action),
                     _help(action, parser)])
    usage = parser.format_usage().removeprefix("usage: ").strip()
    parts = [f"## `chatterbench {name}`", "", cell(COMMANDS[name]) + ".", "", fence(usage), ""]
    if parser.description:
        parts += [cell(parser.description), ""]
    parts.append(table(["argument", "value", "default", "what"], rows))
    return "\n".join(parts)


def commands_markdown() -> str:
    """Every subcommand's section, in ``chatterbench --help``'s order."""
    parsers = _subparsers(build_parser())
    return "\n\n".join(command_markdown(name, parsers[name]) for name in COMMANDS)
