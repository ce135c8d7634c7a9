"""The per-episode error figure: each episode's sticking, exit and restitution error per engine, against its tolerance.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.episode_errors import episode_errors_figure
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> fig = episode_errors_figure(compare(load_scene("bouncing-ball"), settings=settings_for(("pybullet",), 1e-3)))
    >>> [ax.get_gid() for ax in fig.axes]
    ['stick_error_rel', 'exit_error_rel', 'restitution_error']

One panel per judged error, each as the judge computes it (``pipeline/judge.py``, engine
minus reference) and as a fraction of that episode's own scale, with the judge's tolerance
as a band around zero (``Comparison.tolerances``):

- ``stick_error_rel``: sticking start - Zeno point, over the visit's chatter duration (``stick``);
- ``exit_error_rel``: exit error over the sliding duration (``exit``);
- ``restitution_error``: e / R - 1 of the visit's worst resolved impact the step measures to the
  tolerance (``restitution``; its speeds where the body crosses the wall's surface). The band
  is the tolerance itself: the judge never widens it; an impact whose measurement uncertainty
  exceeds it is unmeasured, and a visit with only such impacts (verdict ``unmeasured``) has no
  value and sits in the "not measured" strip.

x is the reference's visit to a wall, numbered in time (an engine episode the reference does
not have, ``spurious``, sits between its neighbours). One marker per engine and episode, in
the engine's colour; a point past ``CLIP`` tolerances is drawn on the panel's edge with its
value written beside it; an episode the engine has but cannot measure (it missed the sliding,
diverged, ...) is a cross labelled with its verdict in a "not measured" strip above the
panel's values, outside the tolerance band (the strip's name is its tick label, left of the
axis, clear of the crosses). A panel with nothing to show says
why. Artists carry ids (``get_gid``): the axes by column, ``points:COLUMN:ENGINE`` (x, value),
``clipped:COLUMN:ENGINE``, ``unmeasured:COLUMN:ENGINE``, ``band:COLUMN``, ``unmeasured-strip:COLUMN``.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from chatterbench.comparisons.pipeline.vocabulary import PASSING

from .style import engine_colour

CLIP = 8.0  # a panel spans at most this many tolerances either side of zero; past it, points sit on the edge
SPREAD = 0.12  # horizontal offset between engines at one episode [episode numbers]
STRIP = 0.45  # height of the "not measured" strip above a panel's values [fractions of its half-range]
STRIP_COLOUR = "#f7e3e3"
# (column, tolerance field, what it is a fraction of, why a panel can be empty)
PANELS = (
    ("stick_error_rel", "stick", "sticking start - Zeno point\n/ chatter duration",
     "no sticking start measured: neither the reference nor an engine sticks in this run"),
    ("exit_error_rel", "exit", "exit error\n/ sliding duration",
     "no exit measured: no sliding stretch of the reference ends within the run (it stays on the wall to the end)"),
    ("restitution_error", "restitution", "worst resolved impact's\ne / R - 1",
     "no resolved impact paired: no engine flight after an impact lasted long enough to measure e"),
)


def _episode_x(table: pd.DataFrame, reference: pd.DataFrame) -> np.ndarray:
    """x of each engine row: its reference visit's number (1, 2, ...); an unpaired one between its neighbours."""
    zeno = reference["t_stick"].to_numpy(float)
    x = np.full(len(table), math.nan)
    for k, r in enumerate(table.itertuples()):
        if math.isfinite(r.ref_t_stick):
            x[k] = 1.0 + float(np.argmin(np.abs(zeno - r.ref_t_stick)))
        elif math.isfinite(r.t_stick):
            x[k] = 0.5 + float(np.searchsorted(zeno, r.t_stick))
    return x


def _panel(ax, comparison, column: str, field: str, label: str, why: str) -> bool:
    """Draw one error's panel; False when nothing was measured (the panel then says why)."""
    tol = float(getattr(comparison.tolerances, field))
    table = comparison.table[comparison.table["wall"] != ""]
    values = pd.to_numeric(table[column], errors="coerce").to_numpy(float)
    finite = values[np.isfinite(values)]
    biggest = float(np.abs(finite).max()) if len(finite) else 0.0
    limit = max(2.5 * tol, min(1.2 * biggest, CLIP * tol))
    engines = list(comparison.runs)
    unmeasured = []  # (engine, colour, x, verdicts) of episodes this error could not be measured for
    for k, name in enumerate(engines):
        color = engine_colour(name)
        mine = table[table["engine"] == name]
        x = _episode_x(mine, comparison.reference) + SPREAD * (k - (len(engines) - 1) / 2.0)
        v = pd.to_numeric(mine[column], errors="coerce").to_numpy(float)
        ok = np.isfinite(v) & np.isfinite(x)
        inside = ok & (np.abs(v) <= limit)
        ax.plot(x[inside], v[inside], ls="none", marker="o", ms=6, color=color, mec="white", mew=0.6, zorder=3,
                gid=f"points:{column}:{name}")
        out = ok & ~inside
        for sign, marker in ((1.0, "^"), (-1.0, "v")):
            sel = out & (np.sign(v) == sign)
            if sel.any():
                ax.plot(x[sel], np.full(sel.sum(), 0.97 * sign * limit), ls="none", marker=marker, ms=8, color=color,
                        zorder=3, gid=f"clipped:{column}:{name}")
        for xi, vi in zip(x[out], v[out]):
            ax.annotate(f"{vi:+.3g}", (xi, 0.97 * math.copysign(limit, vi)), xytext=(6, 0), textcoords="offset points",
                        fontsize=7, color=color, va="top" if vi > 0 else "bottom")
        # an episode the engine has but this error could not be measured for: it did not stick, exit or resolve
        # (where the reference has the quantity: a sliding stretch, an exit, a resolved impact; or a spurious sticking)
        has_ref = {"stick_error_rel": np.isfinite(mine["ref_t_stick"].astype(float)) | (mine["verdict"] == "spurious"),
                   "exit_error_rel": np.isfinite(mine["ref_t_exit"].astype(float)),
                   "restitution_error": mine["ref_resolved_impacts"] > 0}[column].to_numpy(bool)
        lost = ~np.isfinite(v) & np.isfinite(x) & has_ref & ~mine["verdict"].isin((*PASSING, "none")).to_numpy()
        if lost.any():
            unmeasured.append((name, color, x[lost], mine["verdict"].to_numpy()[lost]))
    ax.axhspan(-tol, tol, color="0.85", lw=0, zorder=0, gid=f"band:{column}")
    ax.axhline(0.0, color="0.5", lw=0.7, zorder=1)
    ax.set_ylim(-limit, limit)
    if unmeasured:  # in a strip of their own above the values: a cross at zero would sit in the band, like a pass
        ticks = [t for t in ax.get_yticks() if -limit <= t <= limit]
        top = limit * (1.0 + STRIP)
        ax.axhspan(limit, top, color=STRIP_COLOUR, lw=0, zorder=0, gid=f"unmeasured-strip:{column}")
        ax.axhline(limit, color="0.6", lw=0.6, zorder=1)
        y = limit * (1.0 + STRIP / 2)
        for name, color, xs, verdicts in unmeasured:
            ax.plot(xs, np.full(len(xs), y), ls="none", marker="x", ms=7, mew=1.6, color=color, zorder=3,
                    gid=f"unmeasured:{column}:{name}")
            for xi, verdict in zip(xs, verdicts):
                ax.annotate(verdict, (xi, y), xytext=(6, 0), textcoords="offset points", fontsize=7, color=color,
                            ha="left", va="center")
        ax.set_ylim(-limit, top)
        # the strip is named by a tick label left of the axis: inside it, the name would cover the first cross
        ax.set_yticks([*ticks, y], labels=[f"{t:.3g}" for t in ticks] + ["not\nmeasured"])
        ax.get_yticklabels()[-1].set(fontsize=7, color="0.35")
        ax.get_yticklines()[-2].set_visible(False)
    ax.set_ylabel(label, fontsize=8.5)
    ax.set_gid(column)
    ax.grid(True, axis="y", color="0.92", lw=0.6)
    if not len(finite):
        ax.text(0.5, 0.5, why, transform=ax.transAxes, ha="center", va="center", fontsize=8.5, color="0.3",
                bbox=dict(fc="white", ec="0.8", lw=0.6))
    return bool(len(finite))


def episode_errors_figure(comparison) -> Figure:
    """Each episode's sticking, exit and restitution error per engine, with the tolerance bands (module docstring)."""
    ref = comparison.reference
    n = max(len(ref), 1)
    fig = Figure(figsize=(max(8.0, min(13.0, 5.0 + 0.45 * n)), 7.2), layout="constrained")
    axes = fig.subplots(len(PANELS), 1, sharex=True)
    for ax, (column, field, label, why) in zip(axes, PANELS):
        _panel(ax, comparison, column, field, label, why)
    drawn = {str(ln.get_gid()).split(":")[0] for ax in axes for ln in ax.get_lines() if len(ln.get_xdata())}
    last = axes[-1]
    last.set_xlim(0.4, n + 0.6)
    step = max(1, int(math.ceil(n / 20)))
    ticks = np.arange(1, n + 1, step)
    last.set_xticks(ticks, labels=[f"{i}\n{ref['wall'].iloc[i - 1]}" if len(ref) else str(i) for i in ticks], fontsize=8)
    last.set_xlabel("reference visit to a wall, in time (an unpaired engine episode sits between two)")
    tol = comparison.tolerances
    handles = [Line2D([], [], ls="none", marker="o", ms=6, color=engine_colour(name), label=name)
               for name in comparison.runs]
    # the judge never widens a band: an impact the step cannot measure to it is unmeasured (the top strip)
    handles.append(Patch(color="0.85", label=f"tolerance, never widened: stick {tol.stick:g}, exit {tol.exit:g}, "
                                             f"restitution {tol.restitution:g}"))
    if "clipped" in drawn:
        handles.append(Line2D([], [], ls="none", marker="^", ms=7, color="0.4", label=f"past {CLIP:g} tolerances (value written)"))
    if "unmeasured" in drawn:
        handles.append(Line2D([], [], ls="none", marker="x", ms=7, mew=1.6, color="0.4",
                              label="not measured: in the top strip, with its verdict"))
    # two columns: the tolerance's label is long, three cut the legend at the figure's edge
    fig.legend(handles=handles, loc="outside lower center", ncol=min(2, len(handles)), fontsize=8, frameon=False)
    fig.suptitle(f"{comparison.scene.name}: each episode's errors, engine minus reference, as fractions of its scales",
                 fontsize=11)
    return fig
