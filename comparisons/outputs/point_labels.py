"""Labels of a chart's points (``dt=0.001``) placed where they overlap no other label: beside a point, or on a strip.

    >>> from matplotlib.figure import Figure
    >>> from chatterbench.comparisons.outputs.point_labels import StripLabel, write_strip_labels
    >>> ax = Figure().subplots()
    >>> ax.set_xscale("log"); _ = ax.set_xlim(1e-3, 1e1)
    >>> texts = write_strip_labels(ax, [StripLabel(0.031, "accuracy", v, "C1") for v in ("0.0001", "1e-05", "1e-06")])
    >>> [t.get_text() for t in texts]        # three points a label apart: one label, not three piled up
    ['accuracy=0.0001, 1e-05, 1e-06']

``write_point_labels``: each point of a log-log panel gets its label in the first of four
places around it (below right, above right, below left, above left) that overlaps no label
written before; a label whose text is already written at a coinciding point is left out, as
is one with no free place. ``write_strip_labels``: points drawn on a strip along the top of
a panel (failures with no measured error, at their cost) are labelled along the strip; the
labels of one curve whose points lie closer than a label's width are written as one
(``accuracy=0.0001, 1e-05, 1e-06``), and a label that would overlap another goes to the next
row below, up to ``STRIP_ROWS``. Boxes are measured in axes fractions (``LABEL_BOX``), so the
placement does not depend on the final layout; the x limits must be set first.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

LABEL_BOX = (0.0115, 0.04)  # [axes fraction] a label character's width and a label's height on a 6.4 x 5.6 in panel
STRIP_Y = 0.965  # [axes fraction] where the strip's points sit
STRIP_ROWS = 3  # rows of labels under the strip at most
_ROW_PT = 8.5  # [points] from one strip row to the next (the first's top 5 points under the strip's points)
STRIP_EDGE = 0.91  # [axes fraction] the strip's lower edge under one row of labels; each more row takes ROW_HEIGHT
ROW_HEIGHT = 0.028  # [axes fraction] a row on a 5.6 in panel
FONT = 6.5  # [points] the labels' font size


class StripLabel(NamedTuple):
    """A point on the strip: its cost (the x axis), its lever and the lever's value as written, the curve's colour."""

    x: float
    lever: str
    value: str
    colour: str


def _fx(ax, x: float) -> float:
    """``x`` as a fraction of the (log) x axis."""
    x0, x1 = ax.get_xlim()
    return math.log(x / x0) / math.log(x1 / x0)


def write_point_labels(ax, labels: Sequence[tuple[float, float, str, str]]) -> None:
    """Write each point's label, ``(x, y, text, colour)``, beside it where it overlaps no other label (log-log axes)."""
    (y0, y1) = ax.get_ylim()
    char, line = LABEL_BOX
    boxes: list[tuple[float, float, float, float, str, float, float]] = []
    for x, y, text, colour in labels:
        if not (x > 0 and y > 0 and math.isfinite(x) and math.isfinite(y)):
            continue
        fx, fy = _fx(ax, x), math.log(y / y0) / math.log(y1 / y0)
        if any(t == text and abs(px - fx) < 3 * char and abs(py - fy) < 1.5 * line for *_, t, px, py in boxes):
            continue  # the same label at a coinciding point: once is enough
        w = char * len(text)
        for dx, dy in ((1, -1), (1, 1), (-1, -1), (-1, 1)):
            bx0 = fx + 0.008 if dx > 0 else fx - 0.008 - w
            by0 = fy - 0.01 - line if dy < 0 else fy + 0.01
            if not any(bx0 < b[1] and b[0] < bx0 + w and by0 < b[3] and b[2] < by0 + line for b in boxes):
                ax.annotate(text, (x, y), xytext=(4 * dx, -9 if dy < 0 else 4), textcoords="offset points", fontsize=FONT,
                            color=colour, ha="left" if dx > 0 else "right")
                boxes.append((bx0, bx0 + w, by0, by0 + line, text, fx, fy))
                break


def write_strip_labels(ax, points: Sequence[StripLabel], taken: Sequence[tuple[float, float]] = ()) -> list:
    """Label the strip's points (module docstring); ``taken``: (start, end) axes fractions of row 0 already used (the
    strip's caption). Returns the texts written."""
    from matplotlib.transforms import blended_transform_factory

    char = LABEL_BOX[0]
    strip = blended_transform_factory(ax.transData, ax.transAxes)
    clusters: list[tuple[float, float, str, str, list[str]]] = []  # (fx, x, lever, colour, values)
    for p in sorted((p for p in points if p.x > 0 and math.isfinite(p.x)), key=lambda p: p.x):
        fx = _fx(ax, p.x)
        last = next((c for c in reversed(clusters) if (c[2], c[3]) == (p.lever, p.colour)), None)
        if last is not None and fx - last[0] < char * (len(f"{last[2]}=" + ", ".join(last[4])) + 2):
            if p.value not in last[4]:
                last[4].append(p.value)
            continue
        clusters.append((fx, p.x, p.lever, p.colour, [p.value]))
    rows: list[list[tuple[float, float]]] = [list(taken)] + [[] for _ in range(STRIP_ROWS - 1)]
    written = []
    for fx, x, lever, colour, values in clusters:
        text = f"{lever}=" + ", ".join(values)
        start, end = fx + 0.01, fx + 0.01 + char * len(text)
        row = next((k for k, used in enumerate(rows) if not any(start < b and a < end for a, b in used)), None)
        if row is None:
            continue  # no free place: the marker stays, as a coinciding point's label does
        rows[row].append((start, end))
        written.append(ax.annotate(text, (x, STRIP_Y), xycoords=strip, xytext=(4, -5 - _ROW_PT * row), va="top",
                                   textcoords="offset points", fontsize=FONT, color=colour, annotation_clip=False))
    return written
