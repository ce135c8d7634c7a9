"""The calibration chart: each engine's effective restitution against impact speed, force-free and under the scene's forces.

    >>> from chatterbench.comparisons.outputs.restitution_curve import restitution_curve_figure
    >>> from chatterbench.comparisons.studies.restitution_curve import restitution_curve
    >>> from chatterbench.engines.registry import make_settings
    >>> fig = restitution_curve_figure(restitution_curve("pybullet", make_settings("pybullet", dt=1e-4), 0.5, [0.1, 1.0]))
    >>> fig.axes[0].get_xscale(), fig.axes[0].get_ylabel()
    ('log', "effective restitution e = -y'+ / y'- [-]")

Per engine (``studies/restitution_curve.py``, ``studies/scene_restitution.py``), in its
colour, every speed struck at ``PHASES`` places in a step (where in a step an impact falls
moves e, ``restitution_band``): with no force (the contact law alone) or under a constant
gravity, the median a line and min to max a band; under the scene's own forces at the speeds
the scene reaches, the median a filled marker on a thin dashed line and min to max an error
bar, each labelled with its range of e; and, when given, the resolved impacts of the whole run
(``impact_restitutions``) as large open markers numbered 1, 2, ... (every one). The nominal R
is a black line, the restitution tolerance a grey band around it (R (1 +- tolerance)), an
engine's calibration speed (where its settings name one) a star on R. Labels are placed where
they overlap neither another label nor a marker (``place_labels``). Speeds without a rebound
sit at e = 0; failed strikes leave a gap. The e axis spans the values, R and the band with a
margin (at least ``MIN_PAD``).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chatterbench.comparisons.studies.restitution_curve import restitution_band

from .style import engine_colour

MIN_PAD = 0.02  # [-] the e axis reaches at least this far beyond the values, R and the band
# engines that agree would hide one another: each gets its own line style and marker as well as its colour
_LINES = ("-", "--", ":", "-.")
_MARKERS = ("o", "^", "s", "D", "v")
# where a label may sit around its marker [points], tried in order: beside first, then further out
_OFFSETS = [(dx * r, dy * r) for r in (1.0, 1.9, 2.8, 3.7) for dx, dy in
            ((7, 6), (7, -13), (-7, 6), (-7, -13), (0, 11), (0, -18), (12, -3), (-12, -3))]
FORCE_FREE = ("none", "gravity")  # the ``forces`` of restitution_curve's strikes; "scene" for scene_restitution's


def place_labels(fig: Figure, ax, labels: list[tuple[float, float, str, str]], fontsize: float = 7.5,
                 bars: list[tuple[float, float, float]] = ()) -> None:
    """Annotate each (x, y, text, colour) next to its point where it overlaps no other label, no marker and no
    error bar (``bars``: (x, y_low, y_high) in data coordinates).

    Lays the figure out once, then fixes that layout (so the points stay where they were
    measured) and, label by label, takes the first offset (``_OFFSETS``) whose box is free;
    with none free, the one that overlaps least.
    """
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    fig.set_layout_engine("none")  # the axes keep the place the labels are measured against
    renderer = canvas.get_renderer()
    pts = ax.transData.transform(np.array([(x, y) for x, y, _, _ in labels], dtype=float).reshape(-1, 2))
    r = 5.0 * fig.dpi / 72.0  # a marker's half width [pixels]
    taken = [(px - r, py - r, px + r, py + r) for px, py in pts]
    for x, lo, hi in bars:  # an error bar and its caps
        (bx, by0), (_, by1) = ax.transData.transform([(x, lo), (x, hi)])
        taken.append((bx - r, by0, bx + r, by1))
    inside = ax.get_window_extent(renderer)

    def overlap(box) -> float:
        area = sum(max(0.0, min(box[2], b[2]) - max(box[0], b[0])) * max(0.0, min(box[3], b[3]) - max(box[1], b[1]))
                   for b in taken)
        outside = (box[0] < inside.x0) or (box[2] > inside.x1) or (box[1] < inside.y0) or (box[3] > inside.y1)
        return area + (1e9 if outside else 0.0)

    for x, y, text, color in labels:
        best = None
        for dx, dy in _OFFSETS:
            ann = ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy), fontsize=fontsize, color=color)
            bb = ann.get_window_extent(renderer)
            box = (bb.x0 - 1, bb.y0 - 1, bb.x1 + 1, bb.y1 + 1)
            cost = overlap(box)
            if best is None or cost < best[0]:
                if best is not None:
                    best[1].remove()
                best = (cost, ann, box)
            else:
                ann.remove()
            if cost == 0.0:
                break
        taken.append(best[2])


def restitution_curve_figure(curve: pd.DataFrame, impacts: pd.DataFrame | None = None, scene_name: str = "",
                             strikes: pd.DataFrame | None = None, tolerance: float | None = None) -> Figure:
    """e against log impact speed, per engine (module docstring).

    Parameters
    ----------
    curve : DataFrame
        ``CURVE_COLUMNS`` of ``restitution_curve``, any number of engines (concatenated).
    impacts : DataFrame, optional
        ``IMPACT_COLUMNS`` of ``impact_restitutions`` for the same engines.
    scene_name : str
        The scene the impacts and strikes come from, for the legend.
    strikes : DataFrame, optional
        ``CURVE_COLUMNS`` of ``scene_restitution``: under the scene's forces at its own impacts.
    tolerance : float, optional
        The restitution tolerance (relative): the grey band R (1 +- tolerance).
    """
    parts = [f for f in (curve, strikes) if f is not None and len(f)]
    engines = list(dict.fromkeys([*(e for f in parts for e in f["engine"]),
                                  *([] if impacts is None else impacts["engine"])]))
    colours = {name: engine_colour(name) for name in engines}
    fig = Figure(figsize=(9, 6.5), layout="constrained")
    ax = fig.subplots()
    R = float(parts[0]["restitution"].iloc[0]) if parts else math.nan
    ax.axhline(R, color="black", lw=1.2, label=f"nominal R = {R:g}")
    if tolerance is not None and np.isfinite(R):
        ax.axhspan(R * (1 - tolerance), R * (1 + tolerance), color="0.85", zorder=0,
                   label=f"R within the restitution tolerance ({100 * tolerance:g}%)")
    gravity = float(curve["gravity"].iloc[0]) if len(curve) else 0.0
    free = "under gravity g = %g m/s^2 alone" % gravity if gravity > 0 else "no force: the contact law alone"
    _draw_curves(ax, curve, engines, colours, R, free)
    labels, bars = _draw_strikes(ax, strikes, engines, colours, scene_name)
    labels += _draw_impacts(ax, impacts, engines, colours, scene_name)
    ax.set_xscale("log")
    ax.set_xlabel("impact speed |y'-| [m/s]")
    ax.set_ylabel("effective restitution e = -y'+ / y'- [-]")
    ax.set_ylim(*_e_range(parts, impacts, R, tolerance))
    ax.set_title("Effective restitution against impact speed, over where in a step the impact falls"
                 + (":\nforce-free and under the scene's own forces" if strikes is not None and len(strikes) else f"\n({free})"))
    ax.grid(True, which="both", alpha=0.3)
    fig.legend(loc="outside lower center", ncols=1, fontsize=8, frameon=False)  # below the axes: no curve hidden
    if labels:
        place_labels(fig, ax, labels, bars=bars)
    return fig


def _draw_curves(ax, curve: pd.DataFrame, engines: list[str], colours: dict[str, str], R: float, free: str) -> None:
    """Strikes at every phase of a step per speed, force-free or under gravity: per engine the median a line, min to
    max a band; its calibration speed a star on R."""
    for name, rows in curve.groupby("engine", sort=False):
        band = restitution_band(rows).sort_values("speed")
        i = engines.index(name)
        ax.fill_between(band["speed"], band["e_min"], band["e_max"], color=colours[name], alpha=0.18, lw=0)
        ax.plot(band["speed"], band["e_median"], ls=_LINES[i % len(_LINES)], lw=1.6, color=colours[name],
                label=f"{name} (dt = {rows['dt'].iloc[0]:g} s): {_phases(band)} per speed, {free}: median (line), "
                      "min to max (band)")
        v_cal = rows["calibration_speed"].dropna()
        if len(v_cal):  # where the engine's law was tuned to give R: a star on the R line, and its speed
            v = float(v_cal.iloc[0])
            ax.axvline(v, color=colours[name], lw=0.8, alpha=0.6)
            ax.plot([v], [R], ls="none", marker="*", ms=15, color=colours[name], mec="black",
                    label=f"{name}: calibrated to R at {v:.3g} m/s")


def _phases(band: pd.DataFrame) -> str:
    """"strikes at 10 places in a step" (the most strikes measured at one speed)."""
    n = int(band["phases"].max()) if len(band) else 0
    return f"strikes at {n} places in a step" if n > 1 else "one strike"


def _draw_strikes(ax, strikes: pd.DataFrame | None, engines: list[str], colours: dict[str, str],
                  scene_name: str) -> tuple[list[tuple[float, float, str, str]], list[tuple[float, float, float]]]:
    """The strikes under the scene's own forces, per impact over the phases of a step: the median a filled marker
    on a thin dashed line, min to max an error bar; returns their labels (the range of e) and the bars."""
    labels, bars = [], []
    for name, rows in ([] if strikes is None else strikes.groupby("engine", sort=False)):
        band = restitution_band(rows).sort_values("speed")
        marker = _MARKERS[engines.index(name) % len(_MARKERS)]
        mid = band["e_median"].to_numpy(float)
        ax.errorbar(band["speed"], mid, yerr=[mid - band["e_min"].to_numpy(float), band["e_max"].to_numpy(float) - mid],
                    ls="--", lw=0.9, marker=marker, ms=6, color=colours[name], elinewidth=1.4, capsize=3,
                    label=f"{name}: under {scene_name or 'the scene'}'s own forces at its impacts (struck from the "
                          f"reference, {_phases(band)}): median, min to max")
        labels += [(v, m, _range_text(lo, hi), colours[name])
                   for v, m, lo, hi in zip(band["speed"], mid, band["e_min"], band["e_max"]) if np.isfinite(m)]
        bars += [(v, lo, hi) for v, lo, hi in zip(band["speed"], band["e_min"], band["e_max"]) if np.isfinite(lo)]
    return labels, bars


def _range_text(lo: float, hi: float) -> str:
    """"0.437-0.464", or one number when the two agree to the digits shown."""
    return f"{lo:.3f}" if f"{lo:.3f}" == f"{hi:.3f}" else f"{lo:.3f}-{hi:.3f}"


def _draw_impacts(ax, impacts: pd.DataFrame | None, engines: list[str], colours: dict[str, str],
                  scene_name: str) -> list[tuple[float, float, str, str]]:
    """The run's resolved impacts: large open markers; returns their numbers as labels."""
    labels = []
    for name, rows in ([] if impacts is None else impacts.groupby("engine", sort=False)):
        marker = _MARKERS[engines.index(name) % len(_MARKERS)]
        ax.plot(rows["speed"], rows["restitution_effective"], ls="none", marker=marker, ms=10, mfc="none", mew=1.3,
                color=colours[name], alpha=0.8,
                label=f"{name}: {scene_name + ' ' if scene_name else ''}run's impacts 1..{len(rows)} (judged pairs, numbered)")
        labels += [(v, e, f"#{k}", colours[name]) for k, v, e in zip(rows["impact"], rows["speed"], rows["restitution_effective"])
                   if np.isfinite(e)]
    return labels


def _e_range(parts: list[pd.DataFrame], impacts: pd.DataFrame | None, R: float, tolerance: float | None) -> tuple[float, float]:
    """The e axis: the values, R and the tolerance band, with a margin (a drift of a few percent must show)."""
    values = pd.concat([f["restitution_effective"] for f in parts]
                       + ([] if impacts is None else [impacts["restitution_effective"]]))
    values = values[np.isfinite(values.to_numpy(dtype=float))]
    band = (tolerance or 0.0) * R
    lo = min(R - band, float(values.min()) if len(values) else R)
    hi = max(R + band, float(values.max()) if len(values) else R)
    pad = max(0.12 * (hi - lo), MIN_PAD)  # zoom onto the spread: a drift of a few percent must show; room for labels
    return lo - pad, hi + pad
