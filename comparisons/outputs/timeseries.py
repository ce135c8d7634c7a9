"""The time-series chart of a comparison: y(t) of the reference and every engine, where each sticks and exits.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.timeseries import timeseries_figure
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> fig = timeseries_figure(compare(load_scene("bouncing-ball"), settings=settings_for(("pybullet",), 1e-3)))
    >>> [ax.get_gid() for ax in fig.axes]   # the run and a zoom on the end of the first chatter sequence
    ['run', 'zoom']

``timeseries_figure`` draws, on the main panel:

- the reference's y(t) (exact, a wide grey band) and each engine's samples over it (thin, in
  the engine's colour, never grey: ``run_colour``), the reference's sliding shaded from its
  Zeno point to its exit;
- the reference's events on the wall: Zeno point (open circle), exit (triangle up), Feigin's
  plate entry (triangle down) where the scene has one;
- each engine's events in its colour, one lane per engine just outside the wall: where the
  extraction says it starts sticking (filled circle) and exits (triangle up), so an early or
  late engine shows beside the reference's marker.

The main panel shows the first ``MAX_VISITS`` reference visits to a wall (all of them when
there are no more); the title says how many of how many, and the per-episode error figure
(``episode_errors.py``) has every one. Its y-axis is set by the reference: its range and the
walls, plus the judge's penetration allowance (``penetration`` x the length scale) on each
side. An engine that leaves it (diverged, or through a wall past the allowance) is clipped
there, and a note on the panel says where it left and how far it went.

The zoom panel frames the end of the first real chatter sequence (a visit with more than one
impact, as the ladder's), from a quarter of its chatter duration before the Zeno point to past
the latest engine's sticking start, with a vertical line and its error in ms for each engine.
Legends list only what is drawn. Artists carry ids (``get_gid``) for tests: axes ``run`` and
``zoom``; ``stick:ENGINE``, ``exit:ENGINE`` (the engine's markers on the main panel),
``zoom-stick:ENGINE``, ``reference-zeno``, ``reference-exit``, ``plate-entry``; the main panel's legend
``clipped`` lists the engines that leave its axis.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from chatterbench.reference.dense import sample

from .style import EXIT_COLOUR, PALETTE, REFERENCE_COLOUR, STICK_COLOUR, engine_colour

MAX_VISITS = 4  # reference visits drawn on the main panel; every one is in the episode error figure
LANE = 0.22  # of the axis margin (the penetration allowance): the spacing of the engines' marker lanes
ZOOM_BEFORE = 0.25  # of the chatter duration, shown before the Zeno point in the zoom
ZOOM_AFTER = 0.12  # of the chatter duration, shown after the latest sticking start in the zoom


def _thin(t: np.ndarray, y: np.ndarray, n: int = 20000) -> tuple[np.ndarray, np.ndarray]:
    """Keep at most ~n points, preserving each bin's min and max (so chatter stays visible)."""
    if len(t) <= n:
        return t, y
    bins = len(t) // (n // 2)
    m = (len(t) // bins) * bins
    tb, yb = t[:m].reshape(-1, bins), y[:m].reshape(-1, bins)
    finite = np.isfinite(yb)  # a diverged run's inf and NaN samples are no bin's extreme
    lo, hi = np.where(finite, yb, np.inf).argmin(axis=1), np.where(finite, yb, -np.inf).argmax(axis=1)
    rows = np.arange(len(tb))
    first = np.minimum(lo, hi)
    second = np.maximum(lo, hi)
    tt = np.column_stack((tb[rows, first], tb[rows, second])).ravel()
    yy = np.column_stack((yb[rows, first], yb[rows, second])).ravel()
    return tt, yy


def shown_until(reference: pd.DataFrame, t_end: float) -> float:
    """End of the main panel [s]: the start of visit ``MAX_VISITS + 1``, or the run's end."""
    if len(reference) <= MAX_VISITS:
        return t_end
    nxt = reference.iloc[MAX_VISITS]
    start = nxt.t_first_impact if math.isfinite(nxt.t_first_impact) else nxt.t_stick
    return float(min(t_end, start))


def engine_episodes(comparison, name: str) -> pd.DataFrame:
    """The judged episode rows of engine ``name`` (the run row of a failure, wall "", left out)."""
    table = comparison.table
    return table[(table["engine"] == name) & (table["wall"] != "")]


def _wall_side(scene, wall: str) -> float:
    """+1 where the gap lies above the wall (lower wall), -1 below it: the side the body flies on."""
    return 1.0 if wall == "lower" else -1.0


def _lane(scene, wall: str, k: int, pad: float) -> float:
    """y of engine ``k``'s marker lane beside ``wall`` (outside the gap) [m]."""
    return scene.gap.position(wall) - _wall_side(scene, wall) * (k + 1) * LANE * pad


def _leaves(t: np.ndarray, y: np.ndarray, lo: float, hi: float) -> tuple[float, float] | None:
    """First time an engine's y is past [lo, hi] or not finite, and its most extreme finite y; None if never."""
    with np.errstate(invalid="ignore"):
        out = ~np.isfinite(y) | (y < lo) | (y > hi)
    if not out.any():
        return None
    finite = y[np.isfinite(y)]
    far = float(finite[np.argmax(np.abs(finite - 0.5 * (lo + hi)))]) if len(finite) else math.nan
    return float(t[np.argmax(out)]), far


def _grey(colour: str) -> bool:
    """An achromatic ``#rrggbb`` (its channels within 0x20): it would vanish on the reference's grey band."""
    r, g, b = (int(colour[i:i + 2], 16) for i in (1, 3, 5))
    return max(r, g, b) - min(r, g, b) < 0x20


def run_colour(comparison, name: str) -> str:
    """``engine_colour(name)``, unless it is grey like the reference's band (a trajectory file's name can hash to
    the palette's grey): then the first palette colour that is neither grey nor another run's here."""
    colour = engine_colour(name)
    if not _grey(colour):
        return colour
    taken = {engine_colour(other) for other in comparison.runs if other != name}
    return next((c for c in PALETTE if not _grey(c) and c not in taken), "#1f77b4")


def first_chatter(reference: pd.DataFrame):
    """The first reference visit with real chatter (more than one impact), or None."""
    real = reference[(reference["n_impacts"] > 1) & (reference["chatter_duration"] > 0)]
    return real.iloc[0] if len(real) else None


def _draw_run(ax, comparison, t_hi: float) -> list:
    """The main panel; returns its legend handles."""
    scene, ref = comparison.scene, comparison.reference
    t0 = scene.initial.t
    dense = sample(scene, comparison.exhaustive.log, np.linspace(t0, t_hi, 8001))
    walls = [scene.gap.position(w) for w in scene.gap.walls]
    lo, hi = min(dense["y"].min(), *walls), max(dense["y"].max(), *walls)
    # the judge's penetration allowance: an engine past it is ``penetrated`` (or worse), so clipping hides no pass
    pad = comparison.tolerances.penetration * comparison.solution.length_scale
    ylo, yhi = lo - pad, hi + pad
    handles = [Line2D([], [], color=REFERENCE_COLOUR, lw=3.5, alpha=0.3, label="reference (Feigin, exact)")]
    shown = ref[ref["t_stick"] < t_hi]
    for r in shown.itertuples():
        ax.axvspan(r.t_stick, min(t_hi, r.t_exit) if math.isfinite(r.t_exit) else t_hi, color=STICK_COLOUR, alpha=0.12, lw=0)
    if len(shown):
        ends = "to exit" if np.isfinite(shown["t_exit"]).any() else "on: it never exits"
        handles.append(Patch(color=STICK_COLOUR, alpha=0.25, label=f"reference sliding (Zeno point {ends})"))
    ax.plot(dense["t"], dense["y"], color=REFERENCE_COLOUR, lw=3.5, alpha=0.3, zorder=2, solid_capstyle="butt")
    notes, marked = [], set()
    for k, (name, run) in enumerate(comparison.runs.items()):
        tr, color = run.trajectory, run_colour(comparison, name)
        sel = tr.t <= t_hi
        if sel.sum() >= 2:
            t, y = _thin(tr.t[sel], tr.y[sel])
            ax.plot(t, np.clip(y, ylo - 10 * pad, yhi + 10 * pad), color=color, lw=0.9, zorder=3)
        extra = f", {run.status}" + (f" at {run.t_diverged:.3g} s" if math.isfinite(run.t_diverged) else "")
        handles.append(Line2D([], [], color=color, lw=1.2, label=f"{name} (dt={tr.dt:.0e} s{extra})"))
        left = _leaves(tr.t[sel], tr.y[sel], ylo, yhi) if sel.any() else None
        if left is not None:
            at, far = left
            notes.append(Line2D([], [], color=color, lw=1.2, gid=f"clipped:{name}",
                                label=f"{name} clipped: leaves the axis at t = {at:.3g} s (reaches y = {far:.3g} m)"))
        eps = engine_episodes(comparison, name)
        for col, marker, gid in (("t_stick", "o", "stick"), ("t_exit", "^", "exit")):
            ev = eps[np.isfinite(eps[col].astype(float)) & (eps[col] <= t_hi)]
            if ev.empty:  # an empty unclipped line would count as an artist at the origin in the layout
                continue
            marked.add(gid)
            ax.plot(ev[col], [_lane(scene, w, k, pad) for w in ev["wall"]], ls="none", marker=marker, ms=5.5,
                    color=color, mec="white", mew=0.5, zorder=5, clip_on=False, gid=f"{gid}:{name}")
    ax.plot(shown["t_stick"], shown["wall"].map(scene.gap.position), "o", mfc="white", mec=STICK_COLOUR, mew=1.6, ms=8,
            zorder=4, gid="reference-zeno")
    if len(shown):
        handles.append(Line2D([], [], ls="none", marker="o", mfc="white", mec=STICK_COLOUR, mew=1.6, ms=8,
                              label="reference Zeno point (starts sticking)"))
    exits = shown[np.isfinite(shown["t_exit"].astype(float)) & (shown["t_exit"].astype(float) <= t_hi)]
    ax.plot(exits["t_exit"], exits["wall"].map(scene.gap.position), "^", color=EXIT_COLOUR, ms=8, zorder=4,
            gid="reference-exit")
    if len(exits):
        handles.append(Line2D([], [], ls="none", marker="^", color=EXIT_COLOUR, ms=8, label="reference exit"))
    plate = shown[np.isfinite(shown["t_plate_entry"].astype(float))]
    if len(plate):
        ax.plot(plate["t_plate_entry"], plate["wall"].map(scene.gap.position), "v", color=STICK_COLOUR, ms=7, zorder=4,
                gid="plate-entry")
        handles.append(Line2D([], [], ls="none", marker="v", color=STICK_COLOUR, ms=7, label="plate entry (Feigin)"))
    if "stick" in marked:
        handles.append(Line2D([], [], ls="none", marker="o", color="0.45", ms=5.5,
                              label="engine starts sticking (its colour, beside the wall)"))
    if "exit" in marked:
        handles.append(Line2D([], [], ls="none", marker="^", color="0.45", ms=5.5, label="engine exits"))
    for w in walls:
        ax.axhline(w, color="0.4", lw=0.8, ls="--", zorder=1)
    if notes:  # where the curves leave room ("best"): the axis is the reference's, say who left it
        ax.legend(handles=notes, loc="best", fontsize=8, framealpha=0.95).set_gid("clipped")
    ax.set_xlim(t0, t_hi)
    ax.set_ylim(ylo, yhi)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("y = x2 - x1 [m]")
    return handles


def _draw_zoom(ax, comparison, r) -> tuple[float, float, float, float]:
    """The zoom on the end of reference visit ``r``'s chatter: Zeno point and each engine's sticking start.

    Its y is the distance from the wall into the gap [mm] (negative: penetration). Returns
    the window in the main panel's data, (t0, y0, width, height) [s, m].
    """
    scene = comparison.scene
    chatter = float(r["chatter_duration"])
    starts, verdicts = {}, {}
    for name in comparison.runs:
        eps = engine_episodes(comparison, name)
        mine = eps[np.isclose(eps["ref_t_stick"].astype(float), r["t_stick"], rtol=0, atol=1e-9)]
        if len(mine) and math.isfinite(mine["t_stick"].iloc[0]):
            starts[name] = float(mine["t_stick"].iloc[0])
        verdicts[name] = str(mine["verdict"].iloc[0]) if len(mine) else "not judged"
    late = max([0.0, *(t - r["t_stick"] for t in starts.values())])
    early = max([0.0, *(r["t_stick"] - t for t in starts.values())])
    lo = r["t_stick"] - min(chatter, max(ZOOM_BEFORE * chatter, 1.5 * early))
    hi = r["t_stick"] + min(chatter, max(ZOOM_AFTER * chatter, 1.4 * late))
    wall = scene.gap.position(r["wall"])
    side = _wall_side(scene, r["wall"])
    dz = sample(scene, comparison.exhaustive.log, np.linspace(lo, hi, 2001))
    ref_mm = 1e3 * side * (dz["y"].to_numpy() - wall)
    amp = float(np.nanmax(np.abs(ref_mm)))
    amp = amp if amp > 0 else 1e-3  # no bounce left in the window: a thin band around the wall
    ax.plot(dz["t"], ref_mm, color=REFERENCE_COLOUR, lw=3.5, alpha=0.3, solid_capstyle="butt")
    ax.axvline(r["t_stick"], color=STICK_COLOUR, ls="--", lw=1.4, zorder=4, gid="reference-zeno")  # over a close engine
    ax.text(r["t_stick"], 0.02, "Zeno point ", transform=ax.get_xaxis_transform(), ha="right", va="bottom", fontsize=7.5,
            color=STICK_COLOUR)
    box = dict(fc="white", ec="none", alpha=0.85, pad=1.0)
    for k, (name, run) in enumerate(comparison.runs.items()):
        tr, color = run.trajectory, run_colour(comparison, name)
        m = (tr.t >= lo) & (tr.t <= hi)
        ax.plot(tr.t[m], 1e3 * side * (tr.y[m] - wall), color=color, lw=1.0)
        if name in starts:
            ax.axvline(starts[name], color=color, lw=1.3, gid=f"zoom-stick:{name}")
        note = (f"{name} sticks {1e3 * (starts[name] - r['t_stick']):+.3g} ms" if name in starts
                else f"{name} does not stick here ({verdicts[name]})")
        ax.text(0.98, 0.97 - 0.075 * k, note, transform=ax.transAxes, fontsize=8, color=color, ha="right", va="top",
                bbox=box, zorder=6)
    ax.axhline(0.0, color="0.4", lw=0.8, ls="--")
    ax.set_xlim(lo, hi)
    ax.set_ylim(-0.3 * amp, 1.2 * amp)
    ax.set_title(f"zoom: end of the first chatter (visit {int(r.name) + 1}, {r['wall']} wall)", fontsize=9)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("distance from the wall [mm]", fontsize=8)
    ax.tick_params(labelsize=7)
    below, above = (0.3e-3 * amp, 1.2e-3 * amp) if side > 0 else (1.2e-3 * amp, 0.3e-3 * amp)
    return lo, wall - below, hi - lo, below + above


def timeseries_figure(comparison, inset: bool = True) -> Figure:
    """y(t) for the reference and each engine with the sticking starts and exits of both (module docstring).

    Parameters
    ----------
    comparison : pipeline.compare.Comparison
    inset : bool
        Add the zoom panel on the end of the first chatter sequence (when there is one).
    """
    scene = comparison.scene
    ref = comparison.reference.reset_index(drop=True)
    r = first_chatter(ref) if inset else None
    fig = Figure(figsize=(13, 5.0), layout="constrained")
    if r is not None:
        ax, axz = fig.subplots(1, 2, width_ratios=[2.6, 1])
    else:
        ax, axz = fig.subplots(), None
    ax.set_gid("run")
    t_hi = shown_until(ref, scene.t_end)
    handles = _draw_run(ax, comparison, t_hi)
    part = (f"first {MAX_VISITS} of {len(ref)} visits to a wall (every one: episode errors)" if t_hi < scene.t_end
            else f"{len(ref)} visit{'s' if len(ref) != 1 else ''} to a wall")
    ax.set_title(f"{scene.name}: relative displacement, {part}", fontsize=10)
    if axz is not None:
        axz.set_gid("zoom")
        ax.indicate_inset(_draw_zoom(axz, comparison, r), inset_ax=axz, edgecolor="0.5")
    fig.legend(handles=handles, loc="outside lower center", fontsize=8, ncol=min(4, len(handles)), frameon=False)
    return fig
