r"""Text from an input (a name, a description, a version from a baseline) made inert where it is shown: a CI log, Markdown.

    >>> from chatterbench.comparisons.pipeline.inert_text import log_text, md_code, md_escape
    >>> print(log_text("ball\n::warning title=INJ::x ##[error]y"))
    ball\n::warning title=INJ::x ## [error]y
    >>> print(md_escape("<img src=x>\n## INJ"), md_code("a`b"))
    \<img src=x\>\\n\#\# INJ ``a`b``

One encoder, ``log_text``, for every piece of an input that a command prints or writes to a
CI log or a job summary (``$GITHUB_STEP_SUMMARY``): the check's name, a gate's description,
a file's name, a scene's name, a key, a baseline's strings. After it no input can start a line
of its own, so none can be a workflow command (GitHub's runner reads ``::command::`` at the start
of a line, after its leading white space), a Markdown heading or a table row:

- every control character and Unicode line or paragraph separator is shown escaped
  (``\n``, ``\r``, ``\x1b``, ``\u2028``), never written;
- ``##[``, the runner's legacy command form that it reads anywhere in a line, becomes ``## [``;
- a text that begins (after white space) with ``::`` gets a backslash before it, for where the
  command's own format puts it at the start of a line (a table row).

It changes nothing else (a clean name is shown as it is) and applied twice gives what it gives
once. The escaping of GitHub's ``::error`` annotations themselves (``ci/job_outputs.py``) is
another matter, their data and properties, and stays as GitHub documents it.

``md_escape`` is ``log_text`` for Markdown text and table cells: every character Markdown or
HTML reads as markup backslash-escaped as well (no tag, link, heading or cell break from a
name); ``md_code`` a code span that no backtick or line break in the text can end.
"""

from __future__ import annotations

import re

_BREAKS = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")  # control characters (C0, DEL, C1) and line separators
_LEGACY = re.compile(r"##\[")  # the runner's ``##[command]``, read anywhere in a line
_MARKUP = set("\\`*_{}[]<>()#+!|~&")


def _escaped(match: re.Match) -> str:
    c = match[0]
    return repr(c)[1:-1] if c not in "\u2028\u2029" else f"\\u{ord(c):04x}"


def log_text(text: object) -> str:
    """``text`` on one line, inert in a CI log (module docstring)."""
    out = _BREAKS.sub(_escaped, str(text))
    while "##[" in out:
        out = _LEGACY.sub("## [", out)
    if out.lstrip().startswith("::"):
        out = "\\" + out
    return out


def md_escape(text: object) -> str:
    """``text`` as literal Markdown: ``log_text``, then every character Markdown or HTML reads as markup
    backslash-escaped (a name from a user's file shows as written, never as a link, code, tag, heading or cell)."""
    return "".join("\\" + c if c in _MARKUP else c for c in log_text(text))


def md_code(text: object) -> str:
    """``text`` as one Markdown code span: ``log_text`` (a line break would end the span's block), fenced by more
    backticks than any run in it."""
    text = log_text(text)
    fence = "`" * (1 + max((len(run) for run in re.findall(r"`+", text)), default=0))
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"
