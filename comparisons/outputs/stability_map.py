"""The stability map of a sweep: the verdict of every grid cell over two parameters, one panel per engine.

    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.comparisons.pipeline.summary import summarize
    >>> rows = pd.DataFrame([summarize(compare(load_scene("bouncing-ball", [f"restitution={r}"]), engines=("pybullet",),
    ...                                        dt=dt), "pybullet", {"dt": dt, "restitution": r})
    ...                      for dt in (1e-3, 3e-4) for r in (0.3, 0.5)])          # a small sweep's rows
    >>> fig = stability_map_figure(rows, "dt", "restitution")      # one panel per engine
    >>> len(fig.axes)
    1

``stability_map_figure``: the verdict of every grid cell over two parameters, one panel per
engine, one colour per verdict class (``VERDICT_COLORS``), worst verdict where other
parameters vary within a cell.

"""

from __future__ import annotations

from typing import Sequence

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from chatterbench.comparisons.pipeline.vocabulary import combine, text_colour

from .sweep_data import (VERDICT_ABBREV, VERDICT_COLORS, VERDICT_MEANING, VERDICT_ORDER, ChartError, check_columns,
                         engines_of, fmt, folded_parameters, parameter_columns, suptitle)

LOG_SPAN = 10.0  # an axis whose values span this ratio (a decade) or more is log-scaled
IRREGULAR = 2.0  # a linear axis whose steps differ by more than this factor gets equal cells
ANNOTATE_MAX_CELLS = 150  # write the verdict in the cells up to this many per panel


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
    """Cell centres, cell edges and scale (``log``, ``linear`` or ``category``) of one map axis.

    Positive numbers spanning a decade or more: log. Other numbers: linear when evenly
    enough spaced (largest step at most ``IRREGULAR`` times the smallest), else equal
    cells in value order, like strings (0, 0.1, 0.5 or 0, 0.1, 1, 10 would otherwise
    squeeze the small values into slivers).
    """
    vals = list(values)
    numeric = all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) for v in vals)
    v = np.asarray(vals, float) if numeric else np.empty(0)
    log = numeric and v.min() > 0 and v.max() / v.min() >= LOG_SPAN
    if numeric and not log and len(v) > 2:
        steps = np.diff(v)
        numeric = steps.max() <= IRREGULAR * steps.min()
    if not numeric:
        pos = np.arange(len(vals), dtype=float)
        return pos, np.arange(len(vals) + 1) - 0.5, "category"
    scale = "log" if log else "linear"
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
    (ax.set_xticks if which == "x" else ax.set_yticks)(centres, labels=[fmt(v) for v in values])
    (ax.xaxis if which == "x" else ax.yaxis).set_minor_locator(matplotlib.ticker.NullLocator())


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
    cmap = ListedColormap([VERDICT_COLORS[v] for v in VERDICT_ORDER]).with_extremes(bad="white")  # no run: blank
    norm = BoundaryNorm(np.arange(len(VERDICT_ORDER) + 1) - 0.5, len(VERDICT_ORDER))
    n = len(grids)
    fig = Figure(figsize=(max(5.0, 0.45 * max(g.shape[1] for g in grids.values()) + 3.0) * n, 5.4), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)
    seen: set[str] = set()
    for ax, (eng, grid) in zip(axes[0], grids.items()):
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
        ax.set_xlabel(x + (" [s]" if x == "dt" else ""))
        ax.set_ylabel(y + (" [s]" if y == "dt" else ""))
        sub = rows[rows["engine"] == eng].dropna(subset=[x, y])
        folded = folded_parameters(sub, (x, y), parameter_columns(rows))
        note = ("\nworst over " + ", ".join(f"{c} ({sub[c].nunique()})" for c in folded)) if folded else ""
        ax.set_title(f"{eng}: {len(sub)} runs{note}", fontsize=10)
    handles = [Patch(facecolor=VERDICT_COLORS[v], edgecolor="0.5", label=f"{VERDICT_ABBREV[v]}  {v}: {VERDICT_MEANING[v]}")
               for v in VERDICT_ORDER if v in seen]
    ncol = max(1, min(3, len(handles), int(fig.get_figwidth() // 3.6)))
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8, frameon=False)
    scene = ", ".join(sorted(rows["scene"].astype(str).unique())) if "scene" in rows else ""
    suptitle(fig, f"{scene}: verdict over {x} and {y}")
    return fig
