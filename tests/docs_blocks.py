"""The fenced code blocks of the README and the docs pages, with what precedes each (a ``not run`` marker).

    >>> from docs_blocks import blocks
    >>> text = "Run it:\\n\\n<!-- not run: needs a GPU -->\\n```bash\\nnvidia-smi\\n```\\n"
    >>> [(b.language, b.lines, b.not_run) for b in blocks(text, "page.md")]
    [('bash', ['nvidia-smi'], 'needs a GPU')]

A command block is a fence whose language is in ``COMMAND_LANGUAGES``; its ``lines`` are its commands,
a backslash-continued line joined, comments and blank lines left out. ``not_run`` is the reason of a
``<!-- not run: REASON -->`` line right above the fence ("" when there is none), ``file`` the path of
a ``<!-- file: PATH -->`` line there (the block is that file of the repository, as it is). ``after`` is the
text block (```` ```text ````) that follows the fence, if one does with nothing between: what the
command prints.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMAND_LANGUAGES = ("bash", "sh", "shell", "console")
_FENCE = re.compile(r"^(`{3,})([\w+-]*)[^\n]*\n(.*?)^\1\s*$", re.M | re.S)
_NOT_RUN = re.compile(r"<!-- not run: (.*?) -->\s*$")
_FILE = re.compile(r"<!-- file: (\S+) -->\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced block of a page."""

    page: str  # the file, relative to the repository
    line: int  # the fence's line, from 1
    language: str  # "" when the fence names none
    text: str  # its content
    not_run: str  # the reason of the marker above it, "" when none
    after: str  # the text block right after it, "" when none
    file: str = ""  # the repository's file it shows, "" when none

    @property
    def lines(self) -> list[str]:
        """Its commands: continuation lines joined, comments and blank lines left out."""
        joined = re.sub(r"\\\n\s*", "", self.text)
        return [line.strip() for line in joined.splitlines() if line.strip() and not line.lstrip().startswith("#")]

    @property
    def is_command(self) -> bool:
        return self.language in COMMAND_LANGUAGES


def blocks(text: str, page: str) -> list[Block]:
    """Every fenced block of ``text`` (a page's Markdown), in order."""
    found = []
    matches = list(_FENCE.finditer(text))
    for i, m in enumerate(matches):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        marker, shown = _NOT_RUN.search(before), _FILE.search(before)
        nxt = matches[i + 1] if i + 1 < len(matches) else None
        after = nxt[3] if nxt is not None and nxt[2] == "text" and not text[m.end():nxt.start()].strip() else ""
        found.append(Block(page, text[:m.start()].count("\n") + 1, m[2], m[3], marker[1].strip() if marker else "",
                           after, shown[1] if shown else ""))
    return found


def pages() -> list[Path]:
    """The README and every page of the docs site (the hook's code left out)."""
    docs = sorted(p for p in (ROOT / "docs").rglob("*.md") if "hooks" not in p.parts)
    return [ROOT / "README.md", *docs]


def all_blocks() -> list[Block]:
    """Every fenced block of every page."""
    return [b for p in pages() for b in blocks(p.read_text(encoding="utf-8"), str(p.relative_to(ROOT)))]
