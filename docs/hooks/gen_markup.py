"""Text taken from the code, made safe to put in a Markdown page: nothing in it becomes markup.

    >>> from gen_markup import cell, code, table
    >>> cell("a|b <i>*c*</i>")
    'a&#124;b &lt;i&gt;&#42;c&#42;&lt;/i&gt;'
    >>> table(["key", "what"], [[code("dt"), cell("the step, s")]]).splitlines()[2]
    '| <code>dt</code> | the step, s |'

Promises: ``cell`` and ``code`` turn every character that Markdown, its tables or HTML would read as
syntax into a character reference (Python-Markdown leaves those as they are and the browser shows the
character), and a newline into a space, so a help text, a docstring or a default value taken from the
code shows as written and never opens a tag, a link, a table column or emphasis.
"""

from __future__ import annotations

import re
from typing import Iterable, Sequence

# what Markdown, its table extension or HTML can read as syntax inside a table cell or a line of text
_SPECIAL = "|*_`[]\\#~"
_REFERENCE = {ord(c): f"&#{ord(c)};" for c in _SPECIAL}
_REFERENCE.update({ord("&"): "&amp;", ord("<"): "&lt;", ord(">"): "&gt;"})


def cell(text: object) -> str:
    """``text`` as a table cell or a line of a paragraph: every syntax character a reference, lines joined (a run of
    white space is one space, kept at either end: pieces join as they were written)."""
    return re.sub(r"\s+", " ", str(text)).translate(_REFERENCE)


def code(text: object) -> str:
    """``text`` as inline code (an HTML ``code`` element, so a ``|`` or a backtick in it is safe in a table)."""
    return f"<code>{cell(str(text).strip())}</code>" if str(text).strip() else ""


def fence(text: str, language: str = "text") -> str:
    """``text`` as a fenced block whose fence is longer than any run of backticks in it."""
    longest = max(map(len, re.findall("`+", text)), default=0)
    ticks = "`" * max(3, longest + 1)
    return f"{ticks}{language}\n{text.rstrip()}\n{ticks}"


def table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """A Markdown table; ``header`` and ``rows`` are already made safe (``cell``, ``code``)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)
