"""The stability map of a sweep: the verdict of every grid cell over two parameters, one panel per engine.

    >>> from chatterbench.reference.scene import load_scene
    >>> import pandas as pd
    >>> from chatterbench.comparisons.outputs.stability_map import stability_map_figure
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> from chatterbench.comparisons.pipeline.summary import summarize
    >>> rows = pd.DataFrame([summarize(compare(load_scene("bouncing-ball", [f"restitution={r}"]),
    ...                                        settings=settings_for(("pybullet",), dt=dt)), "pybullet", {"dt": dt, "restitution": r})
    ...                      for dt in (1e-3, 3e-4) for r in (0.3, 0.5)])          # a small sweep's rows
    >>> fig = stability_map_figure(rows, "dt", "restitution")      # one panel per engine
    >>> len(fig.axes)
    1

``stability_map_figure``: the verdict of every grid cell over two parameters, one panel per
engine, one colour per verdict class (``VERDICT_COLOURS``), worst verdict where other
parameters vary within a cell.

A refined sweep's rows (``refine_level``, ``studies/sweep/refine.py``) are drawn at their
size: a point added at level ``k`` is a cell of ``2**-k`` coarse cells along each refined
axis (an axis with values between the level-0 ones), centred on it, coarse levels first
and finer ones over them; exactly the fine map ``refine.fill`` measures.

"""

from __future__ import annotations

from typing import Sequence

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.collections import PolyCollection
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from chatterbench.comparisons.pipeline.summary import REFINE_LEVEL
from chatterbench.comparisons.pipeline.vocabulary import combine, text_colour
from chatterbench.comparisons.studies.axes import axis_scale

from .sweep_data import (VERDICT_ABBREV, VERDICT_COLOURS, VERDICT_MEANING, VERDICT_ORDER, ChartError,
                         check_columns, engines_of, fmt, folded_parameters, parameter_columns, suptitle)

ANNOTATE_MAX_CELLS = 150  # write the verdict in the cells up to this many per panel
TICK_CHARS = 60  # x tick labels longer than this in all are turned, so that they do not overlap


def verdict_grid(rows: pd.DataFrame, x: str, y: str, engine: str) -> pd.DataFrame:
    """The worst verdict per (``y``, ``x``) cell of one engine's rows.

    Returns a DataFrame indexed by the sorted values of ``y`` with the sorted values of
    ``x`` as columns; a cell with no row is NaN.
    """
    check_columns(rows, [x, y])
    sub = rows[(rows["engine"] == engine)].dropna(subset=[x, y])
    if sub.empty:
        return pd.DataFrame()
    cells = sub.groupby([y, x])["verdict"].agg(lambda s: combine(s.astype(str)))
    grid = cells.unstack(x)
    return grid.sort_index().sort_index(axis=1)


def _axis(values: Sequence) -> tuple[np.ndarray, np.ndarray, str]:
    """Cell centres, cell edges and scale (``studies/axes.py``) of one map axis."""
    vals = list(values)
    scale = axis_scale(vals)
    if scale == "category":
        pos = np.arange(len(vals), dtype=float)
        return pos, np.arange(len(vals) + 1) - 0.5, "category"
    v = np.asarray(vals, float)
    u = np.log10(v) if scale == "log" else v
    if len(u) == 1:
        half = 0.5 if scale == "log" else (0.5 * abs(u[0]) or 0.5)
        edges = np.array([u[0] - half, u[0] + half])
    else:
        mid = 0.5 * (u[:-1] + u[1:])
        edges = np.concatenate(([u[0] - (mid[0] - u[0])], mid, [u[-1] + (u[-1] - mid[-1])]))
    return v, (10.0 ** edges if scale == "log" else edges), scale


def _set_axis(ax, which: str, values: Sequence, centres: np.ndarray, edges: np.ndarray, scale: str) -> None:
    setter = ax.set_xscale if which == "x" else ax.set_yscale
    setter("log" if scale == "log" else "linear")
    (ax.set_xlim if which == "x" else ax.set_ylim)(edges[0], edges[-1])
    # three digits on a tick: a refined log axis has values such as 0.000177828 (its geometric midpoints)
    labels = [f"{v:.3g}" if isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) else fmt(v)
              for v in values]
    (ax.set_xticks if which == "x" else ax.set_yticks)(centres, labels=labels)
    if which == "x" and sum(len(t) + 2 for t in labels) > TICK_CHARS:  # side by side they would overlap
        ax.tick_params(axis="x", labelrotation=30)
        for t in ax.get_xticklabels():
            t.set_horizontalalignment("right")
    (ax.xaxis if which == "x" else ax.yaxis).set_minor_locator(matplotlib.ticker.NullLocator())


def _refined(rows: pd.DataFrame) -> bool:
    return REFINE_LEVEL in rows and bool((pd.to_numeric(rows[REFINE_LEVEL], errors="coerce") > 0).any())


class _CoarseAxis:
    """A refined map's axis: its level-0 values, and positions in coarse cells (index ``k`` at the ``k``-th value)."""

    def __init__(self, coarse: Sequence[float], all_values: Sequence[float]) -> None:
        self.values = np.sort(np.asarray(coarse, float))
        self.scale = axis_scale(self.values)
        self.u = np.log10(self.values) if self.scale == "log" else self.values
        self.refined = bool(set(map(float, all_values)) - set(self.values.tolist()))

    def index(self, v: np.ndarray) -> np.ndarray:
        """Values -> coarse positions, piecewise linear in the axis's scale."""
        v = np.asarray(v, float)
        return np.interp(np.log10(v) if self.scale == "log" else v, self.u, np.arange(len(self.u)))

    def at(self, c: np.ndarray) -> np.ndarray:
        """Coarse positions -> where to draw them (values; positions themselves on a category axis), ends extended."""
        if self.scale == "category":
            return np.asarray(c, float)
        n, c = len(self.u), np.asarray(c, float)
        k = np.clip(np.floor(c), 0, max(n - 2, 0)).astype(int)
        step = np.diff(self.u)[k] if n > 1 else np.ones_like(c)
        u = self.u[k] + (c - k) * step
        return 10.0 ** u if self.scale == "log" else u

    def set(self, ax, which: str) -> None:
        n = len(self.values)
        _set_axis(ax, which, self.values, self.at(np.arange(n)), self.at(np.array([-0.5, n - 0.5])), self.scale)


def _draw_refined(ax, sub: pd.DataFrame, x: str, y: str, cmap, norm, codes: dict[str, int]) -> set[str]:
    """A refined sweep's cells at their size, coarse levels first (module docstring); returns the verdicts drawn."""
    level = pd.to_numeric(sub[REFINE_LEVEL], errors="coerce").fillna(0).astype(int)
    cells = sub.assign(_level=level).groupby([x, y]).agg(verdict=("verdict", lambda v: combine(v.astype(str))),
                                                         level=("_level", "min")).reset_index()
    level0 = cells[cells["level"] == 0]
    ax_x, ax_y = (_CoarseAxis(level0[k].unique() if len(level0) else cells[k].unique(), cells[k]) for k in (x, y))
    annotate = len(cells) <= ANNOTATE_MAX_CELLS
    for lv, at in cells.groupby("level"):
        nx, ny = (2 ** int(lv) if a.refined else 1 for a in (ax_x, ax_y))  # cells per coarse cell
        i = np.rint(ax_x.index(at[x].to_numpy()) * nx).astype(int)
        j = np.rint(ax_y.index(at[y].to_numpy()) * ny).astype(int)
        x0, x1 = ax_x.at((i - 0.5) / nx), ax_x.at((i + 0.5) / nx)
        y0, y1 = ax_y.at((j - 0.5) / ny), ax_y.at((j + 0.5) / ny)
        boxes = [[(a, c), (b, c), (b, d), (a, d)] for a, b, c, d in zip(x0, x1, y0, y1)]
        colours = cmap(norm([codes.get(v, codes["error"]) for v in at["verdict"]]))
        ax.add_collection(PolyCollection(boxes, facecolors=colours, edgecolors="white", linewidths=0.8 / 2 ** int(lv),
                                         zorder=1 + int(lv)))
        if annotate:
            for xv, yv, v in zip(at[x], at[y], at["verdict"]):
                ax.text(ax_x.at(ax_x.index(xv)), ax_y.at(ax_y.index(yv)), VERDICT_ABBREV.get(v, v), ha="center",
                        va="center", fontsize=max(5.0, 8.0 * 0.8 ** int(lv)), color=text_colour(v), zorder=20)
    ax_x.set(ax, "x")
    ax_y.set(ax, "y")
    return set(cells["verdict"])


def _width(sub: pd.DataFrame, x: str, grid: pd.DataFrame) -> float:
    """A panel's width in cells: its columns; a refined one's coarse columns, one and a half times (cells split)."""
    if not _refined(sub):
        return float(grid.shape[1])
    return 1.5 * sub.loc[pd.to_numeric(sub[REFINE_LEVEL], errors="coerce") == 0, x].nunique()


def stability_map_figure(rows: pd.DataFrame, x: str, y: str, engine: str | None = None) -> Figure:
    """Verdict of each grid cell over the parameters ``x`` and ``y``, one panel per engine.

    Parameters
    ----------
    rows : sweep dataset.
    x, y : str
        Parameter columns (dotted keys: ``dt``, ``restitution``, ``mujoco.w0_dt``, ...).
        An axis whose values span more than a decade is log-scaled.
    engine : str, optional
        Draw only this engine; default: every engine that has values of both ``x`` and ``y``.

    A cell takes the worst verdict of its rows (other swept parameters folded in); a cell
    with no row is left blank.
    """
    if x == y:
        raise ChartError(f"x and y are both {x!r}: choose two different parameters")
    check_columns(rows, [x, y], parameter_columns(rows), what="parameter")
    grids = {e: verdict_grid(rows, x, y, e) for e in engines_of(rows, engine)}
    grids = {e: g for e, g in grids.items() if not g.empty}
    if not grids:
        raise ChartError(f"no rows{' of ' + engine if engine else ''} have values of both {x!r} and {y!r}"
                         " (an engine's settings apply to that engine only)")
    codes = {v: i for i, v in enumerate(VERDICT_ORDER)}
    cmap = ListedColormap([VERDICT_COLOURS[v] for v in VERDICT_ORDER]).with_extremes(bad="white")  # no run: blank
    norm = BoundaryNorm(np.arange(len(VERDICT_ORDER) + 1) - 0.5, len(VERDICT_ORDER))
    n = len(grids)
    widths = [_width(rows[rows["engine"] == e], x, g) for e, g in grids.items()]
    fig = Figure(figsize=(max(5.0, 0.45 * max(widths) + 3.0) * n, 5.4), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)
    seen: set[str] = set()
    for ax, (eng, grid) in zip(axes[0], grids.items()):
        sub = rows[rows["engine"] == eng].dropna(subset=[x, y])
        if _refined(sub):
            seen |= _draw_refined(ax, sub, x, y, cmap, norm, codes)
            _titles(ax, rows, sub, x, y, eng, f", refined to level {int(pd.to_numeric(sub[REFINE_LEVEL]).max())}")
            continue
        xc, xe, xs = _axis(grid.columns)
        yc, ye, ys = _axis(grid.index)
        c = np.ma.masked_invalid(np.array([[codes.get(v, codes["error"]) if isinstance(v, str) else np.nan
                                            for v in row] for row in grid.to_numpy()], float))
        ax.pcolormesh(xe, ye, c, cmap=cmap, norm=norm, edgecolors="white", linewidth=0.8)
        _set_axis(ax, "x", grid.columns, xc, xe, xs)
        _set_axis(ax, "y", grid.index, yc, ye, ys)
        present = {v for v in grid.to_numpy().ravel() if isinstance(v, str)}
        seen |= present
        if grid.size <= ANNOTATE_MAX_CELLS:
            for i, yv in enumerate(yc):
                for j, xv in enumerate(xc):
                    v = grid.iat[i, j]
                    if isinstance(v, str):
                        ax.text(xv, yv, VERDICT_ABBREV.get(v, v), ha="center", va="center", fontsize=8,
                                color=text_colour(v))
        _titles(ax, rows, sub, x, y, eng)
    handles = [Patch(facecolor=VERDICT_COLOURS[v], edgecolor="0.5", label=f"{VERDICT_ABBREV[v]}  {v}: {VERDICT_MEANING[v]}")
               for v in VERDICT_ORDER if v in seen]
    ncol = max(1, min(3, len(handles), int(fig.get_figwidth() // 3.6)))
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8, frameon=False)
    scene = ", ".join(sorted(rows["scene"].astype(str).unique())) if "scene" in rows else ""
    suptitle(fig, f"{scene}: verdict over {x} and {y}")
    return fig


def _titles(ax, rows: pd.DataFrame, sub: pd.DataFrame, x: str, y: str, eng: str, extra: str = "") -> None:
    """Axis labels, and the panel's title: the engine, its runs, what is folded in."""
    ax.set_xlabel(x + (" [s]" if x == "dt" else ""))
    ax.set_ylabel(y + (" [s]" if y == "dt" else ""))
    folded = folded_parameters(sub, (x, y), parameter_columns(rows))
    note = ("\nworst over " + ", ".join(f"{c} ({sub[c].nunique()})" for c in folded)) if folded else ""
    ax.set_title(f"{eng}: {len(sub)} runs{extra}{note}", fontsize=10)
