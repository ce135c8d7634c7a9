r"""Where each check of a gate file, and each of its limits, is written: the lines an ``::error`` annotation points at.

    >>> from chatterbench.comparisons.ci.gate_lines import check_lines
    >>> text = '[defaults]\ndt = 1e-4\n\n[[check]]\nscene = "feigin-pair"\nlimits = [\n    "verdict == match",\n]\n'
    >>> check_lines(text, [["verdict == match"]])
    [(4, (7,))]
    >>> check_lines('[[check]]\nlimits = ["n_match >= 1", "n_match >= 1"]\n[[check]]\n', [["n_match >= 1"] * 2, []])
    [(1, (2, 2)), (3, ())]

A check's line is its ``[[check]]`` header (1 is the file's first line); a limit's, the line
where its string is written, searched in the check's own table from its ``limits`` key on (a
limit written twice gets each line in turn). 0 where the text does not say: a gate given as
a dict, checks written as an inline array (``check = [{...}]``), a limit spelt with escapes.
A header inside a multi-line string is not a header. The text is the one the gate was read
from, so the lines are those the user sees in the file.
"""

from __future__ import annotations

import re
from typing import Sequence

_HEADER = re.compile(r"^\s*\[\[\s*check\s*\]\]\s*(?:#.*)?$")
_TABLE = re.compile(r"^\s*\[")  # any table header ends a check's table
_LIMITS = re.compile(r"^\s*limits\s*=")
_QUOTES = ('"""', "'''")


def _code_lines(text: str) -> list[tuple[int, str, bool]]:
    """(line number from 1, line, whether it starts outside a multi-line string) for every line of ``text``."""
    out, inside = [], None
    # lines as TOML and GitHub count them (LF, CRLF): not str.splitlines, which also breaks at a U+2028 in a name
    for n, line in enumerate(text.removesuffix("\n").split("\n"), 1):
        line = line.removesuffix("\r")
        out.append((n, line, inside is None))
        for match in re.finditer(r'"""|\'\'\'', line):
            quote = match.group()
            if inside is None:
                inside = quote
            elif inside == quote:
                inside = None
    return out


def check_lines(text: str, limits: Sequence[Sequence[str]]) -> list[tuple[int, tuple[int, ...]]]:
    """For each check in file order (``limits``: the limit strings each was read with): (its header's line, each
    limit's line); 0 where the text does not say (module docstring)."""
    lines = _code_lines(text)
    headers = [i for i, (_, line, outside) in enumerate(lines) if outside and _HEADER.match(line)]
    found = []
    for k, texts in enumerate(limits):
        if k >= len(headers):
            found.append((0, tuple(0 for _ in texts)))
            continue
        start = headers[k]
        end = next((i for i in range(start + 1, len(lines)) if lines[i][2] and _TABLE.match(lines[i][1])), len(lines))
        block = lines[start:end]
        at = next((i for i, (_, line, outside) in enumerate(block) if outside and _LIMITS.match(line)), 0)
        seen: dict[str, int] = {}
        numbers = []
        for limit in texts:
            written = (f'"{limit}"', f"'{limit}'")
            hits = [num for num, line, _ in block[at:] for w in written for _ in range(line.count(w))]
            nth = seen[limit] = seen.get(limit, -1) + 1
            numbers.append(hits[nth] if nth < len(hits) else 0)
        found.append((block[0][0], tuple(numbers)))
    return found
