"""The tuning map: the searched region, dt against the main knob, each run's cell coloured by its verdict, the answer circled.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.tradeoff import tradeoff_figure
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (1e-3, 3e-4), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...               ladder=None, check_robust=False)  # the asked tolerances alone (no frontier ladder, no neighbours)
    >>> fig = tradeoff_figure(result)
    >>> len(fig.axes), fig.axes[0].get_xlabel().startswith("dt")
    (1, True)

One panel per slice (a combination of the settings other than dt and the main knob:
``tune.grid.Grid``); x: dt on the search's lattice, coarse (cheap, 1 / dt steps per simulated
second) on the left, fine on the right, ticks at the coarse grid's values; y: the main knob's
lattice, ticks at its coarse values. Both axes are the lattice's index (equal cells, as the
sweep's adaptive maps are drawn): a run of refinement level k owns the cell of its level's
spacing centred on it (``sweep.refine.fill``'s rule: coarse runs large, refined ones and
neighbourhood runs small, finer ones drawn over coarser ones), coloured by its verdict
(``pipeline.vocabulary``; refused runs grey). Marks: the chosen candidate (the answer, or the
best reachable) circled; fragile passes (a neighbour fails) crossed; robust passes dotted.
Runs off the lattice (a neighbour half-way between two searched values of a slice's knob)
are in the table, not on the map.
"""

from __future__ import annotations

import math

from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from chatterbench.comparisons.pipeline.vocabulary import COLOURS, rank

from chatterbench.comparisons.studies.tune.runs import short_label

REFUSED_COLOUR = "#bdbdbd"  # a candidate whose settings the scene cannot run (not a verdict)
MAX_PANELS = 12  # slices drawn at most (the rest are in the table)


def _label(key: str, value) -> str:
    return f"{key.split('.', 1)[-1]}={value:g}" if isinstance(value, float) else f"{key.split('.', 1)[-1]}={value}"


def tradeoff_figure(result) -> Figure:
    """The searched region as a map (module docstring)."""
    grid = result.extra["grid"]
    n = min(len(grid.slices), MAX_PANELS)
    ncols = min(3, n)
    nrows = math.ceil(n / ncols)
    fig = Figure(figsize=(4.2 * ncols + 1.0, 3.4 * nrows + 1.6), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n:]:
        ax.set_visible(False)
    seen_verdicts: set[str] = set()
    for s, ax in enumerate(axes[:n]):
        for level, i, j, row in _cells(result.table, grid, s):
            seen_verdicts.add(row["verdict"])
            _draw_cell(ax, grid, level, i, j, row, result.chosen)
        _lattice_axes(ax, grid, s)
    tol = result.tolerance
    fig.suptitle(f"tune {result.engine} on {result.scene.name}: {len(result.table)} runs (stick {tol.stick:g}, "
                 f"exit {tol.exit:g}, first impact {tol.first_impact:g}, restitution {tol.restitution:g})\none panel per "
                 + (", ".join(k.split(".", 1)[-1] for k in grid.others) or "search") + "; cells: a run's lattice cell",
                 fontsize=10)
    fig.legend(handles=_legend_handles(axes[0], result, seen_verdicts), loc="outside lower center", ncol=3, fontsize=8,
               frameon=False)
    return fig


def _cells(table, grid, s: int) -> list[tuple[int, int, int, object]]:
    """Slice ``s``'s runs on the lattice as (level, dt index, knob index, row), coarse levels first."""
    keys = ["dt", *([grid.knob] if grid.knob else []), *grid.others]
    cells = []
    for _, row in table.iterrows():
        where = grid.place({k: row[k] for k in keys})
        if where is None or where[0] != s:
            continue
        level = row["level"] if not (isinstance(row["level"], float) and math.isnan(row["level"])) else grid.depth
        cells.append((int(level), where[1], where[2], row))
    return sorted(cells, key=lambda c: (c[0], c[1], c[2]))


def _draw_cell(ax, grid, level: int, i: int, j: int, row, chosen) -> None:
    """A run's cell of its level's spacing, coloured by its verdict, with its mark (robust, fragile, chosen)."""
    side = 2 ** (grid.depth - level) if len(grid.dt) > 1 else 1
    h_i = side / 2 if len(grid.dt) > 1 else 0.5
    h_j = side / 2 if len(grid.knob_values) > 1 else 0.5
    ax.add_patch(Rectangle((i - h_i, j - h_j), 2 * h_i, 2 * h_j, facecolor=COLOURS.get(row["verdict"], REFUSED_COLOUR),
                           edgecolor="white", linewidth=0.3, zorder=1 + level, gid="cell"))
    if row.get("robust") is True:
        ax.plot(i, j, "o", ms=3, color="black", zorder=10, gid="robust")
    elif row.get("robust") is False:
        ax.plot(i, j, "x", ms=6, mew=1.5, color="black", zorder=10, gid="fragile")
    if chosen is not None and row["settings"] == chosen["settings"]:
        ax.plot(i, j, "o", ms=16, mfc="none", mec="black", mew=2, zorder=11, gid="chosen")


def _lattice_axes(ax, grid, s: int) -> None:
    """Ticks at the coarse grid's values, limits past the coarse end cells, slice ``s`` as the title."""
    coarse_i = grid.coarse(grid.dt)
    ax.set_xticks(coarse_i, [f"{grid.dt[i]:.2g}" for i in coarse_i], rotation=45, fontsize=7)
    edge = (2 ** grid.depth) / 2 if len(grid.dt) > 1 else 0.0  # the coarse end cells reach past the axis's ends
    ax.set_xlim(-0.5 - edge, len(grid.dt) - 0.5 + edge)
    coarse_j = grid.coarse(grid.knob_values)
    ax.set_yticks(coarse_j, [f"{grid.knob_values[j]:.3g}" if grid.knob else "-" for j in coarse_j], fontsize=7)
    pad = (2 ** grid.depth) / 2 if len(grid.knob_values) > 1 else 0.5
    ax.set_ylim(-pad, len(grid.knob_values) - 1 + pad)
    ax.set_title(", ".join(_label(k, v) for k, v in grid.slices[s].items()) or "every run", fontsize=8)
    ax.set_xlabel("dt [s]: coarse, cheap  \u2192  fine, costly", fontsize=8)
    ax.set_ylabel(grid.knob.split(".", 1)[-1] if grid.knob else "", fontsize=8)


def _legend_handles(ax, result, seen_verdicts: set[str]) -> list:
    """The verdicts drawn, the marks, the answer, the cells not run."""
    chosen = result.chosen
    handles = [ax.scatter([], [], s=60, marker="s", color=COLOURS.get(v, REFUSED_COLOUR), label=f"verdict {v}")
               for v in sorted(seen_verdicts, key=rank)]
    handles += [ax.plot([], [], "o", ms=3, color="black", ls="none", label="robust pass (its neighbours pass)")[0],
                ax.plot([], [], "x", ms=6, mew=1.5, color="black", ls="none", label="fragile pass (a neighbour fails)")[0]]
    if chosen is not None:
        word = "recommended" if result.best is not None else "best reachable"
        handles.append(ax.plot([], [], "o", ms=12, mfc="none", mec="black", mew=2, ls="none",
                               label=f"{word}: {short_label(chosen, result.extra.get('defaults', {}))}")[0])
    handles.append(ax.scatter([], [], s=60, marker="s", color="white", edgecolors="0.6",
                              label="not run (costlier than the answer, or past the budget)"))
    return handles
