"""mkdocs hook: the reference pages' generated parts, written from the code at every build.

A page asks for a part with a line ``<!-- generated: NAME -->`` (NAME one of ``PARTS``); the build
puts the part there, so the page shows what the code does today and cannot go stale:

    <!-- generated: cli -->          every subcommand's options (gen_cli: the argparse parser)
    <!-- generated: scene -->        the scene file's keys (gen_scene: the scene's dataclasses)
    <!-- generated: recommended -->  recommended.json's keys (gen_recommended: tune/answer.py's code)
    <!-- generated: gate -->          the gate file's format (gen_gate: comparisons/ci/gate.py)

An unknown NAME, or a part whose code and page disagree (a ``DocsError``), stops the build.
``mkdocs build --strict`` runs in the suite (``tests/test_docs_site.py``).
"""

from __future__ import annotations

import re
from typing import Callable

import gen_cli
import gen_gate
import gen_recommended
import gen_scene

PARTS: dict[str, Callable[[], str]] = {
    "cli": gen_cli.commands_markdown,
    "scene": gen_scene.scene_markdown,
    "recommended": gen_recommended.recommended_markdown,
    "gate": gen_gate.gate_markdown,
}
MARKER = re.compile(r"^<!-- generated: ([\w-]+) -->$", re.M)


def fill(markdown: str, where: str = "a page") -> str:
    """``markdown`` with every marker line replaced by its part; KeyError naming the page for an unknown one."""
    def part(match: re.Match) -> str:
        if match[1] not in PARTS:
            raise KeyError(f"{where}: no generated part {match[1]!r}; known: {', '.join(PARTS)}")
        return PARTS[match[1]]()

    return MARKER.sub(part, markdown)


def on_page_markdown(markdown: str, page, config, files) -> str:
    """mkdocs's event: a page's Markdown before it is rendered."""
    return fill(markdown, page.file.src_path)
