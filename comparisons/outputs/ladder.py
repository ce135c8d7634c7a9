"""The chatter ladder: each impact's incoming speed against time, per wall visit, reference and engines.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.ladder import ladder_figure
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> c = compare(load_scene("bouncing-ball", ["duration=1.6"]), settings=settings_for(("pybullet",), 1e-3))
    >>> fig = ladder_figure(c)
    >>> [ax.get_title().split(":")[0] for ax in fig.axes]
    ['visit 1 (lower wall)']

Between impacts of one visit the reference's incoming speeds fall by R at each impact: a
geometric ladder, straight on the log axis, down to its Zeno point (dashed), where Feigin's
model sticks. Over it, per engine: the impacts the judge paired with the reference's
(``Comparison.impacts``, filled: the ones whose restitution is judged), the engine's other
impacts in the visit (hollow: micro-bounces a time-stepper cannot resolve), and where the
engine starts sticking (a vertical line in its colour). So the figure shows where a velocity
threshold cuts the ladder, where a soft contact's rebound drifts off R, and how late or early
sticking starts. One panel per visit, the first ``MAX_VISITS`` of the run with chatter (a
visit that starts at rest on the wall has one impact at speed 0 and no ladder); the title
says how many of how many ("the first 3 of 13 visits with chatter").

Signs and units: speeds are |y'| just before impact [m/s]; time [s].
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from .style import REFERENCE_COLOUR, STICK_COLOUR, engine_colour

MAX_VISITS = 3
MARGIN = 0.15  # of the visit's chatter duration, drawn after its Zeno point (late sticking shows)


def _window(row) -> tuple[float, float]:
    span = row.chatter_duration if math.isfinite(row.chatter_duration) and row.chatter_duration > 0 else 1.0
    return row.t_first_impact - 0.03 * span, row.t_stick + MARGIN * span


def ladder_figure(comparison) -> Figure:
    """The ladder of the first ``MAX_VISITS`` reference visits (module docstring); an empty note when none."""
    ref = comparison.reference.reset_index(drop=True)
    # real chatter only: a visit that starts at rest on the wall (one impact at speed 0) has no ladder
    chatter = ref[(ref.n_impacts > 1) & (ref.chatter_duration > 0)]
    visits = chatter.head(MAX_VISITS)
    fig = Figure(figsize=(max(9.0, 4.6 * len(visits) + 0.6), 4.4 if len(visits) > 1 else 5.2), layout="constrained")
    if visits.empty:
        ax = fig.subplots()
        ax.axis("off")
        ax.text(0.5, 0.5, "no chatter in this run: the reference never sticks, so there is no ladder to draw",
                ha="center", va="center", transform=ax.transAxes)
        return fig
    axes = np.atleast_1d(fig.subplots(1, len(visits), squeeze=False)[0])
    log = comparison.exhaustive.log
    strikes = log[log.kind == "impact"]
    for ax, row in zip(axes, visits.itertuples()):
        i = row.Index  # the episode's index in the judge's tables
        lo, hi = _window(row)
        mine = strikes[(strikes.wall == row.wall) & (strikes.t >= lo) & (strikes.t <= row.t_stick)]
        speed = mine.v_minus.abs()
        ax.plot(mine.t, speed, "-o", color=REFERENCE_COLOUR, ms=3, lw=1, gid="reference",
                label=f"reference (R = {comparison.scene.restitution:g})")
        ax.axvline(row.t_stick, color=STICK_COLOUR, ls="--", lw=1.2, label="reference Zeno point (sticks)")
        for name, run in comparison.runs.items():
            color = engine_colour(name)
            paired = comparison.impacts[(comparison.impacts.engine == name) & (comparison.impacts.episode == i)]
            found = run.found.impacts
            # the touches of a body already resting on the wall (``stuck``) are not impacts of the ladder
            own = found[(found.wall == row.wall) & (found.t >= lo) & (found.t <= hi) & ~found.stuck.astype(bool)]
            unpaired = own[~np.isin(own.t.to_numpy(), paired.t.to_numpy())]
            ax.scatter(unpaired.t, unpaired.v_minus.abs(), s=22, facecolors="none", edgecolors=color, lw=0.9,
                       gid=f"other-{name}", label=f"{name}: other impacts" if len(unpaired) else "_nolegend_")
            ax.scatter(paired.t, paired.v_minus.abs(), s=26, color=color, gid=f"resolved-{name}", zorder=3,
                       label=f"{name}: resolved impacts (restitution judged)")
            stick = comparison.table[(comparison.table.engine == name)].t_stick.to_numpy()
            if i < len(stick) and math.isfinite(stick[i]):
                ax.axvline(stick[i], color=color, lw=1.2, label=f"{name} starts sticking")
        ax.set_yscale("log")
        ax.set_xlim(lo, hi)
        ax.set_xlabel("t [s]")
        ax.set_title(f"visit {i + 1} ({row.wall} wall): {int(row.n_impacts)} reference impacts", fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    axes[0].set_ylabel("incoming speed |y'| before impact [m/s]")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3 if len(visits) > 1 else 2, fontsize=8, frameon=False)
    shown = ("its one visit with chatter" if len(chatter) == 1 else f"all {len(chatter)} visits with chatter"
             if len(visits) == len(chatter)
             else f"the first {len(visits)} of {len(chatter)} visits with chatter")
    fig.suptitle(f"{comparison.scene.name}: chatter ladder, each impact's incoming speed per wall visit; {shown}",
                 fontsize=11)
    return fig
