"""The time-series chart of a comparison: y(t) of the reference and every engine, sliding shaded.

    >>> from chatterbench.comparisons import compare
    >>> fig = timeseries_figure(compare(load_scene("bouncing-ball"), engines=("pybullet",), dt=1e-3))
    >>> len(fig.axes)                     # the run and a zoom on the first chatter sequence
    2

``timeseries_figure``: y(t) of the reference and every engine on one axis, with the
reference's sliding stretches shaded (plate entry to exit), impacts as ticks, the plate
entries and exits marked, and a zoom panel on the first chatter sequence.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from chatterbench.reference.dense import sample

from .style import ENGINE_COLORS, STICK_COLOR


def _thin(t: np.ndarray, y: np.ndarray, n: int = 20000) -> tuple[np.ndarray, np.ndarray]:
    """Keep at most ~n points, preserving each bin's min and max (so chatter stays visible)."""
    if len(t) <= n:
        return t, y
    bins = len(t) // (n // 2)
    m = (len(t) // bins) * bins
    tb, yb = t[:m].reshape(-1, bins), y[:m].reshape(-1, bins)
    lo, hi = yb.argmin(axis=1), yb.argmax(axis=1)
    rows = np.arange(len(tb))
    first = np.minimum(lo, hi)
    second = np.maximum(lo, hi)
    tt = np.column_stack((tb[rows, first], tb[rows, second])).ravel()
    yy = np.column_stack((yb[rows, first], yb[rows, second])).ravel()
    return tt, yy


def timeseries_figure(comparison, inset: bool = True) -> Figure:
    """y(t) for the reference and each engine, with sliding, impacts, plate entry and exit marked.

    Parameters
    ----------
    comparison : pipeline.compare.Comparison
    inset : bool
        Add a zoom panel on the first chatter sequence of the reference.
    """
    scene = comparison.scene
    ref = comparison.reference
    t0, t1 = scene.initial.t, scene.t_end
    tt = np.linspace(t0, t1, 8001)
    dense = sample(scene, comparison.exhaustive.log, tt)
    if inset and len(ref):
        fig = Figure(figsize=(13, 4.8), layout="constrained")
        ax, axin = fig.subplots(1, 2, width_ratios=[3, 1])
    else:
        fig = Figure(figsize=(11, 4.8), layout="constrained")
        ax = fig.subplots()
    for r in ref.itertuples():
        start = r.t_plate_entry if not math.isnan(r.t_plate_entry) else r.t_stick
        stop = r.t_exit if not math.isnan(r.t_exit) else t1
        ax.axvspan(start, stop, color=STICK_COLOR, alpha=0.12, lw=0)
    ax.plot(dense["t"], dense["y"], color=ENGINE_COLORS["reference"], lw=1.6, label="reference (Feigin, exact)")
    for name, run in comparison.runs.items():
        tr = run.trajectory
        if len(tr.t) < 2:
            continue
        t, y = _thin(tr.t, tr.y)
        ax.plot(t, y, color=ENGINE_COLORS.get(name, None), lw=0.9, alpha=0.85, label=f"{name} (dt={tr.dt:.0e} s, {run.status})")
        imp = run.log[run.log["kind"] == "impact"]
        wy = imp["wall"].map(scene.gap.position)
        ax.plot(imp["t"], wy, "|", color=ENGINE_COLORS.get(name, None), ms=7, alpha=0.6)
    plate = ref.dropna(subset=["t_plate_entry"])
    ax.plot(plate["t_plate_entry"], plate["wall"].map(scene.gap.position), "v", color=STICK_COLOR, ms=8,
            label="plate entry (Feigin)")
    ax.plot(ref["t_stick"], ref["wall"].map(scene.gap.position), "o", mfc="none", color=STICK_COLOR, ms=7,
            label="Zeno point (exhaustive)")
    ex = ref.dropna(subset=["t_exit"])
    ax.plot(ex["t_exit"], ex["wall"].map(scene.gap.position), "^", color="#9467bd", ms=8, label="exit")
    for w in scene.gap.walls:
        ax.axhline(scene.gap.position(w), color="0.4", lw=0.8, ls="--")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("y = x2 - x1 [m]")
    ax.set_title(f"{scene.name}: relative displacement, shaded = reference sliding (plate entry to exit)")
    ax.set_xlim(t0, t1)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", fontsize=8, ncol=4, frameon=False)
    if inset and len(ref):
        r = ref.iloc[0]
        a = r["t_first_impact"] if not math.isnan(r["t_first_impact"]) else r["t_stick"]
        b = r["t_stick"]
        span = max(b - a, 1e-3 * scene.time_scale)
        lo, hi = a - 0.1 * span, b + 0.3 * span
        wall = scene.gap.position(r["wall"])
        sel = (dense["t"] >= lo) & (dense["t"] <= hi)
        tz = np.linspace(lo, hi, 2001)
        dz = sample(scene, comparison.exhaustive.log, tz)
        axin.plot(dz["t"], dz["y"], color="black", lw=1.2)
        for name, run in comparison.runs.items():
            tr = run.trajectory
            if len(tr.t) < 2:
                continue
            m = (tr.t >= lo) & (tr.t <= hi)
            axin.plot(tr.t[m], tr.y[m], color=ENGINE_COLORS.get(name, None), lw=0.8)
        amp = float(np.nanmax(np.abs(dz["y"] - wall))) if sel.any() else 1.0
        if not amp > 0:  # the pair starts resting on the wall: no bounce to frame, show a thin band around it
            amp = 1e-3 * max(float(np.ptp(dense["y"])), 1e-9)
        axin.set_xlim(lo, hi)
        sgn = 1.0 if r["wall"] == "lower" else -1.0
        axin.set_ylim(wall - 0.15 * amp * sgn if sgn > 0 else wall - 1.1 * amp, wall + 1.1 * amp if sgn > 0 else wall + 0.15 * amp)
        axin.axhline(wall, color="0.4", lw=0.8, ls="--")
        axin.set_title("zoom: first chatter sequence", fontsize=9)
        axin.set_xlabel("t [s]")
        axin.tick_params(labelsize=7)
        ax.indicate_inset_zoom(axin, edgecolor="0.5")
    return fig
