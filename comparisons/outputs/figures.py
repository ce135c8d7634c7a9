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


def figure_files(fig: Figure) -> dict[str, bytes]:
    """``fig`` rendered in each of ``FORMATS``, the layout computed once: the PNG is drawn as ``figure_bytes`` draws
    it, the SVG then keeps the positions that drawing gave (constrained layout, 30-40 % of a drawing, is not run
    again); the figure's layout engine is back when this returns."""
    out = {FORMATS[0]: figure_bytes(fig, FORMATS[0])}
    engine = fig.get_layout_engine()
    if engine is not None:
        fig.set_layout_engine("none")  # placed as they are now
    try:
        out.update((fmt, figure_bytes(fig, fmt)) for fmt in FORMATS[1:])
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
    return out


def write_figure(fig: Figure, out: Path, stem: str, files: dict[str, bytes] | None = None) -> list[Path]:
    """Write ``fig`` as ``out/STEM.png`` and ``out/STEM.svg`` (each atomically); returns the paths. ``files``: its
    renderings already made (``figure_files``)."""
    files = files if files is not None else figure_files(fig)
    return [write_bytes(Path(out) / f"{stem}.{fmt}", files[fmt]) for fmt in FORMATS]
