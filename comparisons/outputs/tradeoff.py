"""The tuning trade-off: every candidate's cost against its worst error over its tolerance, marked by verdict and failed check.

    >>> from chatterbench.comparisons.studies.tune import tune
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space={"dt": (1e-3, 3e-4)}, workers=1, refine_steps=0)
    >>> ax = tradeoff_figure(result).axes[0]
    >>> ax.get_xscale(), ax.get_ylabel()
    ('log', 'worst error / its tolerance (over every check)')

x: engine steps per simulated second (1 / dt, or the steps an engine reports), the search's
cost (wall time where an engine reports no steps); y: ``worst_ratio``, the
largest of the judge's checks (sticking, first impact, exit, restitution beyond its
uncertainty, resolved-impact count, penetration) each over its tolerance
(``studies.tune_checks``), so the dashed line at 1 is the tolerance of every check at once
and a candidate above it failed the check its marker names. Colour: the verdict
(``pipeline.vocabulary``). A candidate with an episode that has no error to measure
(``missed``, ``endless``, ``spurious``, a failure) or whose settings were refused sits on the
top band, labelled. Candidates at one dt are spread sideways a little so none hides another;
the chosen one is circled and named.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from chatterbench.comparisons.pipeline.vocabulary import COLOURS, rank

from chatterbench.comparisons.studies.tune import cost_key, short_label
from chatterbench.comparisons.studies.tune_checks import CHECKS

REFUSED_COLOUR = "#bdbdbd"  # a candidate whose settings the scene cannot run (not a verdict)
MARKERS = {"pass": "o", "stick": "s", "first_impact": "^", "exit": "D", "restitution": "v", "impact_count": "P",
           "penetration": "X", "unmeasured": "*"}
SPREAD = 0.06  # [-] relative sideways offset between candidates at one dt (log axis)


def worst_check(row) -> str:
    """The marker key of a candidate: the check with the largest ratio above 1, "unmeasured", or "pass"."""
    if math.isinf(row["worst_ratio"]) or math.isnan(row["worst_ratio"]):
        return "unmeasured"
    ratios = {name: row.get(f"{name}_ratio", math.nan) for name in CHECKS}
    failed = {k: v for k, v in ratios.items() if not math.isnan(v) and v > 1.0}
    return max(failed, key=failed.get) if failed else "pass"


def tradeoff_figure(result) -> Figure:
    """Steps per simulated second against the worst error over its tolerance, every candidate (module docstring)."""
    table = result.table.copy()
    fig = Figure(figsize=(9, 5.5), layout="constrained")
    ax = fig.subplots()
    finite = table["worst_ratio"].replace([np.inf, -np.inf], np.nan)
    low = float(np.nanmin(finite)) if finite.notna().any() else 0.1
    top = max(float(np.nanmax(finite)) if finite.notna().any() else 1.0, 1.0) * 3.0
    table["y"] = finite.fillna(top).clip(lower=min(low, 0.5) / 2 if low > 0 else 1e-3)
    key = cost_key(table[table["verdict"] != "refused"]) if (table["verdict"] != "refused").any() else "steps_per_sim_s"
    table["x"] = table[key]
    for _, grp in table.groupby("dt"):  # spread the candidates of one dt sideways
        n = len(grp)
        table.loc[grp.index, "x"] = grp["x"] * (1.0 + SPREAD) ** (np.arange(n) - (n - 1) / 2)
    table["check"] = [worst_check(r) for _, r in table.iterrows()]
    for verdict, grp in sorted(table.groupby("verdict"), key=lambda g: rank(g[0])):
        for check, sub in grp.groupby("check"):
            ax.scatter(sub["x"], sub["y"], s=40, marker=MARKERS[check], color=COLOURS.get(verdict, REFUSED_COLOUR),
                       edgecolors="black", linewidths=0.4, zorder=3)
    ax.axhline(1.0, color="0.3", ls="--", lw=1)
    ax.text(1.0, 1.0, "tolerance ", transform=ax.get_yaxis_transform(), va="bottom", ha="right", fontsize=8, color="0.3")
    if (table["check"] == "unmeasured").any():
        ax.axhspan(top / 1.6, top * 1.6, color="0.93", zorder=0)
        ax.text(0.01, top * 1.25, "no error to measure: missed, endless, spurious, failed or refused",
                transform=ax.get_yaxis_transform(), va="bottom", fontsize=8, color="0.3")
    chosen = result.chosen
    if chosen is not None:
        row = table[table["settings"] == chosen["settings"]].iloc[0]
        ax.scatter([row["x"]], [row["y"]], s=260, facecolors="none", edgecolors="black", linewidths=2, zorder=4)
        word = "recommended" if result.best is not None else "best reachable"
        ax.annotate(f"{word}: {short_label(chosen, result.extra.get('defaults', {}))}", (row["x"], row["y"]),
                    xytext=(0.5, 0.04), textcoords="axes fraction", ha="center", fontsize=8,
                    bbox={"boxstyle": "round", "fc": "white", "ec": "0.6"}, arrowprops={"arrowstyle": "-", "color": "0.4"})
    # one legend below: colour = verdict, shape = the check that failed worst
    verdicts = sorted(table["verdict"].unique(), key=rank)
    handles = [ax.scatter([], [], s=40, marker="o", color=COLOURS.get(v, REFUSED_COLOUR), edgecolors="black",
                          linewidths=0.4, label=f"verdict {v}") for v in verdicts]
    names = {"pass": "passes every check", "unmeasured": "no error to measure",
             **{k: f"fails: {short}" for k, (*_, short) in CHECKS.items()}}
    handles += [ax.scatter([], [], s=40, marker=MARKERS[c], color="white", edgecolors="black", label=names[c])
                for c in MARKERS if c in set(table["check"])]
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(min(float(table["y"].min()), 0.5) / 1.5, top * 2)  # the tolerance line always in view
    ax.set_xlabel("cost: engine steps per simulated second" if key == "steps_per_sim_s"
                  else "cost: wall-clock s per simulated s (the engine reports no step count)")
    ax.set_ylabel("worst error / its tolerance (over every check)")
    tol = result.tolerance
    ax.set_title(f"tune {result.engine} on {result.scene.name}: {len(table)} candidates (stick {tol.stick:g}, exit "
                 f"{tol.exit:g}, first impact {tol.first_impact:g}, restitution {tol.restitution:g})", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    return fig
