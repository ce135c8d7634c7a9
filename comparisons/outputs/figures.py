"""Figures to bytes: every chart is a matplotlib ``Figure`` built without pyplot, rendered here for files.

    >>> from chatterbench.comparisons.outputs.figures import figure_bytes
    >>> from matplotlib.figure import Figure
    >>> fig = Figure(figsize=(2, 1))
    >>> figure_bytes(fig, "png")[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
    True

The chart modules never import pyplot nor choose a backend: they build ``Figure`` objects,
which render without one, so a notebook user keeps theirs. The command line chooses
the non-interactive backend once, at start-up (``cli.main``).
"""

from __future__ import annotations

import io
from pathlib import Path

from matplotlib.figure import Figure

from chatterbench.comparisons.pipeline.atomic import write_bytes

DPI = 120  # PNG resolution: readable at report width
FORMATS = ("png", "svg")  # every figure a command writes: a picture to look at, a vector file to edit


def figure_bytes(fig: Figure, fmt: str) -> bytes:
    """Render a matplotlib Figure to bytes (``png`` at ``DPI``, or ``svg``)."""
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=DPI)
    return buf.getvalue()


def write_figure(fig: Figure, out: Path, stem: str) -> list[Path]:
    """Write ``fig`` as ``out/STEM.png`` and ``out/STEM.svg`` (each atomically); returns the paths."""
    return [write_bytes(Path(out) / f"{stem}.{fmt}", figure_bytes(fig, fmt)) for fmt in FORMATS]
