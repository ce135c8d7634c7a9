"""A sweep's ``[refine]`` table and the cells of an adaptive map: where to split, and the fine map it stands for.

    >>> from chatterbench.comparisons.studies.sweep.refine import (
    ...     make_refine, lattice, split_points, refine_axis_values)
    >>> refine = make_refine({"axes": ["dt", "restitution"], "depth": 2}, {"dt": (1e-4, 1e-3, 1e-2),
    ...                      "restitution": (0.3, 0.5)}, ValueError)
    >>> refine.depth, refine.boundary
    (2, 'verdict')
    >>> lattice(refine_axis_values((1e-4, 1e-3, 1e-2)), 1)        # a log axis: split at the geometric mean
    (0.0001, 0.000316227766017, 0.001, 0.00316227766017, 0.01)
    >>> run, inferred = split_points({(0, 0): "match", (4, 0): "late", (0, 4): "match", (4, 4): "late"}, level=1, depth=2)
    >>> sorted(run), sorted(inferred.items())                      # the centre and the edges whose ends differ
    ([(2, 0), (2, 2), (2, 4)], [((0, 2), 'match'), ((4, 2), 'late')])

Spec table (TOML)::

    [refine]
    axes = ["dt", "restitution"]   # two keys of [grid], numbers, at least two values each
    depth = 2                      # levels of refinement, 1..6
    boundary = "verdict"           # what differs across a boundary (below); default "verdict"
    threshold = 1e-3               # with a metric as boundary: the value that splits it

``boundary``: ``verdict`` (any change of verdict), ``passing`` (the run reproduced the
episodes or not: ``vocabulary.PASSING``), a verdict name (``match``: in that verdict or
not), or a metric column (``exit_error_max``: at most ``threshold`` or not; a missing
value is a side of its own).

Cells and levels: the grid's values of the two axes are the coarse map. Its fine map at
depth ``d`` has ``(n - 1) * 2**d + 1`` values per axis, points named by their fine indices
``(i, j)``: a coarse value sits at a multiple of ``2**d``. A cell split halves it along both
axes in the axis's own scale (``studies/axes.py``: the geometric mean on a log axis,
the arithmetic mean otherwise). Level 0 runs the coarse grid; level ``k`` splits every cell
of level ``k - 1`` (side ``2**(d - k + 1)``) whose four corners differ (``boundary_label``):
it runs the cell's centre and the midpoints of the edges whose ends differ; the midpoint of
an edge whose ends agree is inferred to share their label, as the inside of a cell whose
corners agree is (it is a corner of the next level's cells, never a row). Each engine
refines on its own verdicts, in each combination of the other grid keys (a *slice*).

The fine map an adaptive one stands for (``fill``): a point added at level ``k`` owns the
rectangle of its level's spacing centred on it, drawn coarse levels first and finer ones
over them; a fine point takes the label of the last rectangle that covers it (one on the
edge between two rectangles of a level, the later's in ``(i, j)`` order). The stability map
draws these rectangles. Promise: a cell not split had four equal corners, so every fine
point inside it takes their label unless a finer neighbour's point reaches in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS
from chatterbench.comparisons.pipeline.vocabulary import NAMES, PASSING
from chatterbench.comparisons.studies.axes import axis_scale
from chatterbench.reference.errors import check_integer, check_number, did_you_mean, is_number, shown

REFINE_KEYS = ("axes", "depth", "boundary", "threshold")
MAX_DEPTH = 6  # (n - 1) * 64 + 1 values an axis: past that a fine map is no map
BOUNDARIES = ("verdict", "passing", *NAMES, *METRIC_COLUMNS)
DIGITS = 12  # significant digits of a split value: one float per fine point, the same on every machine


@dataclass(frozen=True)
class Refine:
    """A validated ``[refine]`` table (the module docstring says what each field means)."""

    axes: tuple[str, str]  # two [grid] keys: x, y
    depth: int  # levels of refinement, 1 <= depth <= MAX_DEPTH
    boundary: str = "verdict"  # one of BOUNDARIES
    threshold: float | None = None  # with a metric boundary only; same unit as the metric

    def to_table(self) -> dict[str, Any]:
        table: dict[str, Any] = {"axes": list(self.axes), "depth": self.depth, "boundary": self.boundary}
        if self.threshold is not None:
            table["threshold"] = self.threshold
        return table


def make_refine(table: Any, grid: Mapping[str, Sequence], error: Callable[[str], Exception] | type) -> Refine:
    """A ``Refine`` from a spec's ``[refine]`` table, checked against its ``[grid]``; ``error(message)`` is raised.

    Every refusal names the field: ``refine.axes``, ``refine.depth``, ``refine.boundary``,
    ``refine.threshold`` or an unknown key.
    """
    if isinstance(table, Refine):
        table = table.to_table()
    if not isinstance(table, Mapping):
        raise error(f"refine = {shown(table)}: must be a table ([refine] with axes, depth, boundary)")
    for k in table:
        if k not in REFINE_KEYS:
            raise error(f"refine.{k}: unknown key; allowed: {', '.join(REFINE_KEYS)}" + did_you_mean(str(k), REFINE_KEYS))
    axes = table.get("axes")
    if isinstance(axes, str) or not isinstance(axes, (list, tuple)) or len(axes) != 2:
        raise error(f"refine.axes = {shown(axes)}: must be two [grid] keys, e.g. axes = [\"dt\", \"restitution\"]")
    for a in axes:
        if not isinstance(a, str):
            raise error(f"refine.axes: {shown(a)} is not a key name; give two [grid] keys as strings")
        if a not in grid:
            raise error(f"refine.axes: {a!r} is not a key of [grid]; refined axes are grid keys "
                        f"({', '.join(map(repr, grid)) or 'none'})" + did_you_mean(str(a), list(grid)))
        values = grid[a]
        if len(values) < 2 or not all(_finite(v) for v in values) or len(set(map(float, values))) != len(values):
            raise error(f"refine.axes: grid.{a} = {shown(list(values))}: a refined axis needs two or more distinct finite numbers")
    if axes[0] == axes[1]:
        raise error(f"refine.axes = {list(axes)!r}: names {axes[0]!r} twice; give two different grid keys")
    if "depth" not in table:
        raise error(f"refine.depth: missing; give the levels of refinement, an integer in [1, {MAX_DEPTH}]")
    depth = check_integer("refine.depth", table["depth"], lo=1, hi=MAX_DEPTH, error=error)
    boundary = table.get("boundary", "verdict")
    if boundary not in BOUNDARIES:
        raise error(f"refine.boundary = {shown(boundary)}: unknown; allowed: verdict, passing, a verdict "
                    f"({', '.join(NAMES)}) or a metric ({', '.join(METRIC_COLUMNS)})" + did_you_mean(str(boundary), BOUNDARIES))
    threshold = table.get("threshold")
    if boundary in METRIC_COLUMNS:
        if threshold is None:
            raise error(f"refine.threshold: missing; boundary = {boundary!r} is a metric and needs the value that splits it")
        threshold = check_number("refine.threshold", threshold, error=error)
    elif threshold is not None:
        raise error(f"refine.threshold = {shown(threshold)}: only for a metric boundary, not boundary = {boundary!r}")
    return Refine(axes=(str(axes[0]), str(axes[1])), depth=depth, boundary=str(boundary), threshold=threshold)


def _finite(value: Any) -> bool:
    """A number that is a finite float (an int past 1e308 is not one)."""
    try:
        return is_number(value) and math.isfinite(float(value))
    except OverflowError:
        return False


def boundary_label(row: Mapping[str, Any], refine: Refine) -> Any:
    """What must be equal at a cell's corners for it to stay whole: the row's side of ``refine.boundary``."""
    verdict = str(row.get("verdict"))
    if refine.boundary == "verdict":
        return verdict
    if refine.boundary == "passing":
        return verdict in PASSING
    if refine.boundary in NAMES:
        return verdict == refine.boundary
    value = row.get(refine.boundary)
    if not is_number(value) or math.isnan(value):
        return "missing"
    return bool(value <= refine.threshold)


def refine_axis_values(values: Iterable) -> tuple[float, ...]:
    """A refined axis's coarse values: sorted, as floats."""
    return tuple(sorted(float(v) for v in values))


def lattice(coarse: Sequence[float], depth: int) -> tuple[float, ...]:
    """The fine axis at ``depth``: ``(n - 1) * 2**depth + 1`` values, the coarse ones exactly.

    Between two coarse values ``lo``, ``hi`` the fine value at fraction ``f`` is
    ``lo * (hi / lo)**f`` on a log axis and ``lo + f (hi - lo)`` otherwise (``axis_scale``),
    rounded to ``DIGITS`` significant digits.
    """
    log = axis_scale(coarse) == "log"
    steps = 2 ** depth
    out = []
    for lo, hi in zip(coarse[:-1], coarse[1:]):
        out.append(lo)
        for k in range(1, steps):
            f = k / steps
            v = 10.0 ** (math.log10(lo) + f * (math.log10(hi) - math.log10(lo))) if log else lo + f * (hi - lo)
            out.append(float(f"{v:.{DIGITS}g}"))
    out.append(coarse[-1])
    return tuple(out)


def split_points(labels: Mapping[tuple[int, int], Any], level: int, depth: int
                 ) -> tuple[set[tuple[int, int]], dict[tuple[int, int], Any]]:
    """What level ``level`` adds in the level-``level - 1`` cells whose corners differ: points to run, points inferred.

    ``labels``: every known point's fine indices ``(i, j)`` -> its label (run, or inferred
    at a level before). A cell of level ``k`` has side ``2**(depth - k)`` fine steps; one
    whose corners are not all known is not split. A split cell runs its centre and the
    midpoint of each edge whose ends differ; the midpoint of an edge whose ends agree is
    inferred to have their label (a cell of agreeing corners stays whole, and so does such
    an edge). Returns (points to run, inferred points -> label), none of them known before.
    """
    side = 2 ** (depth - level + 1)
    half = side // 2
    run: set[tuple[int, int]] = set()
    inferred: dict[tuple[int, int], Any] = {}
    for (i, j), lab in labels.items():
        if i % side or j % side:
            continue
        corners = [(i, j), (i + side, j), (i + side, j + side), (i, j + side)]
        if any(c not in labels for c in corners) or all(labels[c] == lab for c in corners):
            continue
        run.add((i + half, j + half))
        for a, b in zip(corners, corners[1:] + corners[:1]):
            mid = ((a[0] + b[0]) // 2, (a[1] + b[1]) // 2)
            if labels[a] != labels[b]:
                run.add(mid)
            elif mid not in run:
                inferred[mid] = labels[a]
    run -= set(labels)
    return run, {c: lab for c, lab in inferred.items() if c not in run and c not in labels}


def fill(points: Mapping[tuple[int, int], tuple[int, Any]], shape: tuple[int, int], depth: int) -> np.ndarray:
    """The fine map an adaptive one stands for: ``(nx, ny)`` object array of labels (None where nothing reaches).

    ``points``: fine indices -> (level added, label). A point of level ``k`` covers the
    fine points within ``2**(depth - k) / 2`` steps (its cell), coarse levels first, then
    finer ones over them; within a level, points in ``(i, j)`` order.
    """
    out = np.full(shape, None, dtype=object)
    for (i, j), (level, lab) in sorted(points.items(), key=lambda kv: (kv[1][0], kv[0])):
        h = 2 ** (depth - level) // 2
        out[max(i - h, 0):i + h + 1, max(j - h, 0):j + h + 1] = lab
    return out
