"""The calibration chart: each engine's effective restitution against impact speed, all engines in one picture.

    >>> from chatterbench.comparisons.studies.restitution_curve import restitution_curve
    >>> from chatterbench.engines.registry import make_settings
    >>> fig = restitution_curve_figure(restitution_curve("pybullet", make_settings("pybullet", dt=1e-4), 0.5, [0.1, 1.0]))
    >>> fig.axes[0].get_xscale(), fig.axes[0].get_ylabel()
    ('log', "effective restitution e = -y'+ / y'- [-]")

One line per engine (``studies/restitution_curve.py``: one strike per speed), the nominal
R as a black horizontal line, an engine's calibration speed (where its settings name one)
as a star on that line and a thin vertical line in its colour, and, when given, the resolved impacts of a whole
scene (``impact_restitutions``: the bouncing ball's k-th impact at its own incoming speed)
as large open markers of the same colour and shape, numbered 1, 2, ... from the first. Speeds without a
rebound sit at e = 0; failed runs (NaN) leave a gap. The e axis spans the values and R with
a margin (at least ``MIN_PAD``), so a drift of a few percent is visible.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from .style import ENGINE_COLORS

MIN_PAD = 0.02  # [-] the e axis reaches at least this far beyond the values and R
# engines that agree would hide one another: each gets its own line style and marker as well as its colour
_LINES = ("-", "--", ":", "-.")
_MARKERS = ("o", "^", "s", "D", "v")
_MORE_COLORS = ("#9467bd", "#ff7f0e", "#8c564b", "#17becf", "#e377c2")  # engines without a colour in style.py


def _colors(names) -> dict[str, str]:
    spare = iter(_MORE_COLORS)
    return {n: ENGINE_COLORS.get(n) or next(spare, "gray") for n in names}


def restitution_curve_figure(curve: pd.DataFrame, impacts: pd.DataFrame | None = None, scene_name: str = "") -> Figure:
    """e against log impact speed, per engine (module docstring).

    Parameters
    ----------
    curve : DataFrame
        ``CURVE_COLUMNS`` of ``restitution_curve``, any number of engines (concatenated).
    impacts : DataFrame, optional
        ``IMPACT_COLUMNS`` of ``impact_restitutions`` for the same engines.
    scene_name : str
        The scene the impacts come from, for the legend.
    """
    engines = list(dict.fromkeys([*curve["engine"], *([] if impacts is None else impacts["engine"])]))
    colors = _colors(engines)
    fig = Figure(figsize=(9, 6.5), layout="constrained")
    ax = fig.subplots()
    R = float(curve["restitution"].iloc[0]) if len(curve) else math.nan
    ax.axhline(R, color="black", lw=1.2, label=f"nominal R = {R:g}")
    for name, rows in curve.groupby("engine", sort=False):
        rows = rows.sort_values("speed")
        dt = rows["dt"].iloc[0]
        i = engines.index(name)
        ax.plot(rows["speed"], rows["restitution_effective"], ls=_LINES[i % len(_LINES)], marker=_MARKERS[i % len(_MARKERS)],
                ms=4, lw=1.6, color=colors[name], label=f"{name} (dt = {dt:g} s): one strike per speed")
        v_cal = rows["calibration_speed"].dropna()
        if len(v_cal):  # where the engine's law was tuned to give R: a star on the R line, and its speed
            v = float(v_cal.iloc[0])
            ax.axvline(v, color=colors[name], lw=0.8, alpha=0.6)
            ax.plot([v], [R], ls="none", marker="*", ms=15, color=colors[name], mec="black",
                    label=f"{name}: calibrated to R at {v:.3g} m/s")
    if impacts is not None and len(impacts):
        for name, rows in impacts.groupby("engine", sort=False):
            marker = _MARKERS[engines.index(name) % len(_MARKERS)]
            ax.plot(rows["speed"], rows["restitution_effective"], ls="none", marker=marker, ms=9, mfc="none", mew=1.4,
                    color=colors[name],
                    label=f"{name}: {scene_name + ' ' if scene_name else ''}impacts 1..{len(rows)} (judged pairs)")
            for k, v, e in zip(rows["impact"], rows["speed"], rows["restitution_effective"]):
                if k <= 5 and np.isfinite(e):  # the first few, where the ladder's speeds are far apart
                    ax.annotate(str(k), (v, e), textcoords="offset points", xytext=(5, 5), fontsize=7, color=colors[name])
    gravity = float(curve["gravity"].iloc[0]) if len(curve) else 0.0
    forces = f"under gravity g = {gravity:g} m/s^2" if gravity > 0 else "no other forces: the contact law alone"
    ax.set_xscale("log")
    ax.set_xlabel("impact speed |y'-| [m/s]")
    ax.set_ylabel("effective restitution e = -y'+ / y'- [-]")
    values = pd.concat([curve["restitution_effective"], *([] if impacts is None else [impacts["restitution_effective"]])])
    values = values[np.isfinite(values.to_numpy(dtype=float))]
    lo, hi = min(R, float(values.min()) if len(values) else R), max(R, float(values.max()) if len(values) else R)
    pad = max(0.1 * (hi - lo), MIN_PAD)  # zoom onto the spread: a drift of a few percent must show
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_title(f"Effective restitution against impact speed ({forces})")
    ax.grid(True, which="both", alpha=0.3)
    fig.legend(loc="outside lower center", ncols=2, fontsize=8, frameon=False)  # below the axes: no curve hidden
    return fig
