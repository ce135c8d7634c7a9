"""The work-precision chart of a sweep: error against cost, per engine and setting, the Pareto front marked.

    >>> from chatterbench.reference.scene import load_scene
    >>> import pandas as pd
    >>> from chatterbench.comparisons.outputs.work_precision import work_precision_figure
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> from chatterbench.comparisons.pipeline.summary import summarize
    >>> rows = pd.DataFrame([summarize(compare(load_scene("bouncing-ball", [f"restitution={r}"]),
    ...                                        settings=settings_for(("pybullet",), dt=dt)), "pybullet", {"dt": dt, "restitution": r})
    ...                      for dt in (1e-3, 3e-4) for r in (0.3, 0.5)])          # a small sweep's rows
    >>> fig = work_precision_figure(rows)       # a matplotlib Figure; the CLI saves it
    >>> fig.axes[0].get_xlabel()
    'cost: wall-clock s per simulated s'

``work_precision_figure``: the judge's worst relative errors (``exit_error_rel_max``: exit
error / sliding duration; ``stick_error_rel_max``: sticking start error / chatter duration;
``pipeline/summary.py``) against wall-clock cost per simulated second, log-log, each panel
with its tolerance as a dashed line. One curve per engine (and per value of that engine's
other swept settings, e.g. ``mujoco.w0_dt``) through the values of its cost lever
(``EngineAdapter.cost_lever``: ``dt`` for a fixed-step engine, ``accuracy`` for an
error-controlled one, a dotted column such as ``drake.accuracy``), each point labelled with
it (``dt=0.001``); where labels of coinciding points would pile up, one is written. A metric
no row measured (the ball never leaves its floor: no exit) gives its panel to the next one
the rows have (``work_precision_points.FALLBACK``: sticking start, then restitution), and the title says why in a
sentence (metrics that share a reason share it); with nothing measured at all, the one panel
says why, once. Swept scene parameters
(``restitution``, ``mass2``, ...) are folded into each point as the worst case: largest
error, worst verdict, median cost. Points whose verdict is a failure (not match/early/late)
are hollow, one marker per class; failures with no measured error sit on a strip at the top
of the panel. The best trade-off (Pareto front: no other point both cheaper and more
accurate) is ringed and joined. Artists carry ids (``Line2D.get_gid``): ``curve:LABEL``,
``pareto-front``, ``failed:VERDICT``, ``failed-no-error:VERDICT``, ``reference``,
``tolerance``; the axes carry their metric (``Axes.get_gid``).
The points (the folding, each engine's cost lever, the front, each panel's metric) are
``work_precision_points``'s.

"""

from __future__ import annotations

import textwrap
from typing import Sequence

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.transforms import blended_transform_factory

from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.pipeline.vocabulary import rank
from chatterbench.engines.registry import ENGINE_NAMES

from .point_labels import ROW_HEIGHT, STRIP_EDGE, STRIP_Y, StripLabel, write_point_labels, write_strip_labels
from .style import REFERENCE_COLOUR, engine_colour
from .sweep_data import (COST, FAIL_MARKERS, METRIC_LABELS, PASSING, VERDICT_COLOURS, VERDICT_MEANING, VERDICT_ORDER,
                         ChartError, fmt, folded_parameters, parameter_columns, suptitle)
from .work_precision_points import (default_error, in_seconds, measured_reference_cost, panel_metrics, pareto_front,
                                    why_empty, work_precision_points)

ROOT_PRECISION = 1e-12  # [s] the reference's event times: its root finder's tolerance
OFF_SCALE = 1e3  # a reference error this many times below the engines' smallest is drawn on the panel's foot
# the tolerance (``Tolerances`` field) each relative metric is judged against
TOLERANCE_OF = {"exit_error_rel_max": "exit", "stick_error_rel_max": "stick", "restitution_error_max": "restitution"}
LEGEND_CHARS = 44  # a legend entry's line, in characters: two columns of them fit a 6.4 in panel at 8 pt
YLABEL_CHARS = 46  # a y label's line, in characters: the height of a 5.6 in panel at 10 pt, with room to spare


def _curve_styles(points: pd.DataFrame) -> dict[str, dict]:
    """Colour by engine, line style by the engine's settings value."""
    styles = {}
    for engine, grp in points.groupby("engine", sort=True):
        for k, curve in enumerate(dict.fromkeys(grp["curve"])):
            styles[curve] = {"color": engine_colour(engine),
                             "ls": ("-", "--", ":", "-.")[k % 4], "marker": ("o", "s", "D", "^")[k % 4]}
    return styles


def _folded_note(rows: pd.DataFrame) -> str:
    engines = set(rows["engine"].astype(str)) | set(ENGINE_NAMES)
    scene_params = [c for c in parameter_columns(rows) if c.split(".")[0] not in engines]
    varied = folded_parameters(rows, ["dt"], scene_params)
    if not varied:
        return ""
    return "worst case over " + ", ".join(f"{c} ({rows[c].dropna().nunique()} values)" for c in varied)


def _reference_error(metric: str, error: float) -> str:
    """The reference's error on ``metric``'s panel in the metric's unit: seconds for a time metric; "exact" for a
    dimensionless one (relative, restitution: Newton's R holds exactly; ``error`` [s] is a time)."""
    return f"error {error:.0e} s" if in_seconds(metric) else "exact"


def work_precision_figure(rows: pd.DataFrame, error: str | None = None, reference_cost: float | None = None,
                          reference_error: float | None = None, tolerances: Tolerances | None = None) -> Figure:
    """Error against cost per engine, log-log: the exit time panel and the sticking start panel (module docstring).

    Parameters
    ----------
    rows : sweep dataset (``summary.ROW_COLUMNS`` plus one column per parameter).
    error : str, optional
        Metric of the first panel (default ``default_error``: ``exit_error_rel_max``); the second is the
        sticking start in the same unit (``stick_error_rel_max``, or ``stick_error_max`` [s]
        for a metric in seconds). ``panel_metrics`` says what replaces a metric no row measured.
    reference_cost : float, optional
        The reference's own wall-clock seconds per simulated second: drawn as a star at
        (``reference_cost``, ``reference_error`` or ``ROOT_PRECISION``). Default: the median
        of the rows' ``reference_cost_per_sim_s`` (measured in each run); where the rows
        have none, a band at the foot of each panel stands for the reference (exact).
    reference_error : float, optional
        The reference's error [s], its root precision (~1e-12 s).
    tolerances : Tolerances, optional
        Drawn as a dashed line on each relative panel; default ``Tolerances()``.
    """
    error = error or default_error(rows)
    metrics, empty = panel_metrics(rows, error)
    tolerances = tolerances or Tolerances()
    points = work_precision_points(rows, metrics)
    if points.empty:
        raise ChartError("no rows to draw")
    if reference_cost is None:
        reference_cost = measured_reference_cost(rows)
    styles = _curve_styles(points)
    fig = Figure(figsize=(6.4 * len(metrics), 5.6), layout="constrained")
    axes = fig.subplots(1, len(metrics), squeeze=False)
    classes_seen: set[str] = set()
    for ax, metric in zip(axes[0], metrics):
        ax.set_gid(metric)
        has = np.isfinite(points[metric]) & np.isfinite(points[COST])
        labels, on_strip = _draw_curves(ax, points, metric, styles, has, classes_seen)
        _draw_front(ax, points[pareto_front(points, metric)].sort_values(COST), metric)
        ax.set_xscale("log")
        ax.set_yscale("log")
        # a cost range of about a decade gets labels on minor ticks: keep 2 and 5 only, so they do not overlap
        ax.xaxis.set_minor_locator(matplotlib.ticker.LogLocator(subs=(2.0, 5.0)))
        if has.any():
            _draw_reference(ax, metric, float(points.loc[has, metric][points.loc[has, metric] > 0].min()),
                            reference_cost, reference_error)
            lo, hi = ax.get_ylim()
            ax.set_ylim(lo / 2.5, hi * 2.5)  # room for the dt labels, the reference band and the failure strip
        else:
            costs = points[COST][np.isfinite(points[COST]) & (points[COST] > 0)]
            ax.set_xlim(*((costs.min() / 2.0, costs.max() * 2.0) if len(costs) else (1e-3, 1.0)))
            ax.set_ylim(1e-6, 1.0)  # any decades: nothing to scale to, and a log axis needs positive limits
            ax.text(0.5, 0.5, textwrap.fill(empty[0] if empty else why_empty(rows, metric), 48), transform=ax.transAxes,
                    ha="center", va="center", color="0.3", gid="why-empty")
        if metric in TOLERANCE_OF and has.any():
            _draw_tolerance(ax, getattr(tolerances, TOLERANCE_OF[metric]))
        write_point_labels(ax, labels)
        if (~has & ~points["verdict"].isin(PASSING + ("none",))).any():
            _draw_strip(ax, on_strip)
        _label_axes(ax, metric)
    handles = _legend_handles(points, styles, classes_seen, reference_cost is not None)
    fig.legend(handles=handles, loc="outside lower center", ncol=2 if len(metrics) == 1 else 3, fontsize=8, frameon=False)
    suptitle(fig, _title(rows, points, metrics, empty))
    return fig


def _draw_strip(ax, on_strip: list[StripLabel]) -> None:
    """The strip's caption, its points' labels (``point_labels``: one per cluster, in rows) and its lower edge."""
    caption = "failed, no error measured"
    ax.text(0.99, STRIP_Y, caption, transform=ax.transAxes, fontsize=7, va="center", ha="right", color="0.3")
    width = 0.0125 * len(caption)  # [axes fraction] at 7 pt, as LABEL_BOX measures 6.5 pt
    rows = {round(t.xyann[1]) for t in write_strip_labels(ax, on_strip, taken=[(0.99 - width, 1.0)])}
    edge = STRIP_EDGE - ROW_HEIGHT * max(len(rows) - 1, 0)  # below the last row of labels
    ax.plot([0, 1], [edge, edge], transform=ax.transAxes, color="0.6", lw=0.6, ls=":", gid="strip-edge")


def _draw_curves(ax, points: pd.DataFrame, metric: str, styles: dict[str, dict], has: pd.Series,
                 classes_seen: set[str]) -> tuple[list[tuple[float, float, str, str]], list[StripLabel]]:
    """Each curve's line and points (filled: passing, a rim: not within tolerance, hollow: failed; failures with
    no measured error on a strip at the top); adds the failure classes drawn to ``classes_seen``; returns the labels
    of the points and those of the strip."""
    labels: list[tuple[float, float, str, str]] = []
    on_strip: list[StripLabel] = []
    passing = points["verdict"].isin(PASSING)
    strip = blended_transform_factory(ax.transData, ax.transAxes)
    for curve, grp in points.groupby("curve", sort=False):
        st = styles[curve]
        g = grp[has.loc[grp.index]].sort_values(COST)
        ax.plot(g[COST], g[metric], color=st["color"], ls=st["ls"], lw=1.4, label=curve, zorder=2, gid=f"curve:{curve}")
        ok = g[passing.loc[g.index]]
        ax.plot(ok[COST], ok[metric], ls="none", marker=st["marker"], color=st["color"], ms=6, zorder=3)
        for v, gv in ok[ok["verdict"] != "match"].groupby("verdict"):  # timing or impacts outside tolerance: a rim
            ax.plot(gv[COST], gv[metric], ls="none", marker=st["marker"], color=st["color"], mec=VERDICT_COLOURS[v],
                    mew=2.2, ms=8, zorder=3)
        for v, gv in g[~passing.loc[g.index]].groupby("verdict"):
            classes_seen.add(v)
            ax.plot(gv[COST], gv[metric], ls="none", marker=FAIL_MARKERS.get(v, "x"), mfc="white",
                    mec=st["color"], mew=1.6, ms=8, zorder=3, gid=f"failed:{v}")
        labels += [(getattr(r, COST), getattr(r, metric), f"{r.lever}={fmt(r.lever_value)}", st["color"])
                   for r in g.itertuples()]
        # failures without a measured error: a strip along the top, at their cost
        lost = grp[~has.loc[grp.index] & np.isfinite(grp[COST]) & ~grp["verdict"].isin(PASSING + ("none",))]
        for v, gv in lost.groupby("verdict"):
            classes_seen.add(v)
            ax.plot(gv[COST], np.full(len(gv), STRIP_Y), transform=strip, ls="none", marker=FAIL_MARKERS.get(v, "x"),
                    mfc="white", mec=st["color"], mew=1.6, ms=8, zorder=3, clip_on=False, gid=f"failed-no-error:{v}")
            on_strip += [StripLabel(getattr(r, COST), r.lever, fmt(r.lever_value), st["color"]) for r in gv.itertuples()]
    return labels, on_strip


def _draw_front(ax, front: pd.DataFrame, metric: str) -> None:
    """The Pareto front's points ringed and joined (``front`` in order of cost)."""
    if len(front):
        ax.plot(front[COST], front[metric], color="#ffc107", lw=7, alpha=0.35, solid_capstyle="round", zorder=1)
        ax.plot(front[COST], front[metric], ls="none", marker="o", ms=14, mfc="none", mec="black", mew=1.2, zorder=4,
                gid="pareto-front")


def _draw_reference(ax, metric: str, data_min: float, reference_cost: float | None, reference_error: float | None) -> None:
    """The reference: a star at its cost (on the panel's foot when many decades below ``data_min``), or, its cost
    not measured, a band at the foot of the panel."""
    if reference_cost is None:
        if reference_error is not None:
            ax.axhline(reference_error, color="black", lw=0.8, ls="--")
        ax.add_patch(Rectangle((0, 0), 1, 0.04, transform=ax.transAxes, color="0.85", lw=0, zorder=0))
        note = "reference (exact): " + _reference_error(metric, ROOT_PRECISION).replace("exact", "no error")
        ax.text(0.01, 0.02, f"{note}, far below this axis", transform=ax.transAxes, fontsize=7, va="center", color="0.25")
        return
    ref_err = reference_error if reference_error is not None else ROOT_PRECISION
    lo, hi = ax.get_xlim()
    ax.set_xlim(min(lo, reference_cost / 2.0), max(hi, reference_cost * 2.0))
    if ref_err < data_min / OFF_SCALE:
        # many decades below the engines: drawn on the panel's foot so their curves stay readable
        foot = blended_transform_factory(ax.transData, ax.transAxes)
        ax.plot([reference_cost], [0.04], transform=foot, ls="none", marker="*", ms=16,
                color=REFERENCE_COLOUR, zorder=5, clip_on=False, gid="reference")
        ax.annotate(f"reference: {_reference_error(metric, ref_err)} (off scale)", (reference_cost, 0.04), xycoords=foot,
                    xytext=(9, 0), textcoords="offset points", fontsize=8, va="center")
    else:
        ax.plot([reference_cost], [ref_err], ls="none", marker="*", ms=16, color=REFERENCE_COLOUR, zorder=5,
                gid="reference")
        name = "reference (exact)" if reference_error is None else f"reference (error {ref_err:.0e})"
        ax.annotate(name, (reference_cost, ref_err), xytext=(9, 0), textcoords="offset points", fontsize=8, va="center")


def _draw_tolerance(ax, tol: float) -> None:
    """The panel's tolerance as a dashed line, inside the y range."""
    ax.axhline(tol, color="0.35", lw=1.0, ls="--", zorder=1, gid="tolerance")
    ax.annotate(f"tolerance {tol:g}", (0.01, tol), xycoords=("axes fraction", "data"), xytext=(0, 3),
                textcoords="offset points", fontsize=7.5, color="0.3")
    lo, hi = ax.get_ylim()
    ax.set_ylim(min(lo, tol / 3.0), max(hi, tol * 3.0))


def _label_axes(ax, metric: str) -> None:
    ax.grid(True, which="major", color="0.9", lw=0.6)
    ax.set_xlabel("cost: wall-clock s per simulated s")
    unit = " [s]" if in_seconds(metric) else ""
    # wrapped to the panel's height: a longer line is cut by the figure's edge ("(relative" before)
    ax.set_ylabel(textwrap.fill(f"worst |error|: {METRIC_LABELS.get(metric, metric)}{unit}", YLABEL_CHARS))
    ax.set_title(f"error in {METRIC_LABELS.get(metric, metric).split(' (')[0]}", fontsize=10)


def _legend_handles(points: pd.DataFrame, styles: dict[str, dict], classes_seen: set[str], reference: bool) -> list[Line2D]:
    """The legend: curves, the front, the reference, the failure classes drawn, the rims, what the labels are."""
    handles = [Line2D([], [], color=styles[c]["color"], ls=styles[c]["ls"], marker=styles[c]["marker"], label=c)
               for c in styles]
    handles.append(Line2D([], [], ls="none", marker="o", ms=12, mfc="none", mec="black",
                          label="best trade-off (Pareto front)"))
    if reference:
        handles.append(Line2D([], [], ls="none", marker="*", ms=12, color="black", label="reference (exact)"))
    for v in sorted(classes_seen, key=VERDICT_ORDER.index):
        handles.append(Line2D([], [], ls="none", marker=FAIL_MARKERS.get(v, "x"), mfc="white", mec="0.3", mew=1.5,
                              label=f"{v}: {VERDICT_MEANING.get(v, '')}"))
    for v in (p for p in PASSING if p != "match"):  # rims: the run reproduced the episodes, not within tolerance
        if points["verdict"].eq(v).any():
            handles.append(Line2D([], [], ls="none", marker="o", color="0.5", mec=VERDICT_COLOURS[v], mew=2.2, ms=8,
                                  label=f"{v}: {VERDICT_MEANING[v]}"))
    levers = ", ".join(f"{lv} [s]" if lv == "dt" else lv for lv in dict.fromkeys(points["lever"]))
    handles.append(Line2D([], [], ls="none", label=f"labels: {levers}; hollow: the run failed"))
    for h in handles:  # long meanings wrapped, and as many columns as the figure's width holds: none is cut
        h.set_label(textwrap.fill(h.get_label(), LEGEND_CHARS))
    return handles


def _title(rows: pd.DataFrame, points: pd.DataFrame, metrics: Sequence[str], empty: Sequence[str]) -> str:
    """The figure's title: scene, runs, what was folded, why a panel is empty, what could not be placed."""
    scene = ", ".join(sorted(rows["scene"].astype(str).unique())) if "scene" in rows else ""
    measured = any(np.isfinite(points[m]).any() for m in metrics)
    notes = [_folded_note(rows), *(empty if measured else [])]  # nothing measured: the panel says why, once
    uncosted = rows[~np.isfinite(pd.to_numeric(rows[COST], errors="coerce"))]
    if len(uncosted):  # crashed, timed out or refused before any step: nothing to place on a cost axis
        counts = uncosted["verdict"].astype(str).value_counts()
        notes.append("not drawn (no cost measured): " + ", ".join(f"{counts[v]} {v}" for v in sorted(counts.index, key=rank)))
    return "; ".join([f"{scene}: work-precision, {len(rows)} runs", *filter(None, notes)])
