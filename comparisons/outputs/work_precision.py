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
the rows have (``FALLBACK``: sticking start, then restitution), and the title says why in a
sentence (metrics that share a reason share it); with nothing measured at all, the one panel
says why, once. Swept scene parameters
(``restitution``, ``mass2``, ...) are folded into each point as the worst case: largest
error, worst verdict, median cost. Points whose verdict is a failure (not match/early/late)
are hollow, one marker per class; failures with no measured error sit on a strip at the top
of the panel. The best trade-off (Pareto front: no other point both cheaper and more
accurate) is ringed and joined. Artists carry ids (``Line2D.get_gid``): ``curve:LABEL``,
``pareto-front``, ``failed:VERDICT``, ``failed-no-error:VERDICT``, ``reference``,
``tolerance``; the axes carry their metric (``Axes.get_gid``).

"""

from __future__ import annotations

import math
import textwrap
from typing import Any, Sequence

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.transforms import blended_transform_factory

from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.pipeline.vocabulary import combine, rank
from chatterbench.engines.registry import ENGINE_NAMES
from chatterbench.reference.errors import InputError

from .point_labels import ROW_HEIGHT, STRIP_EDGE, STRIP_Y, StripLabel, write_point_labels, write_strip_labels
from .style import REFERENCE_COLOUR, engine_colour
from .sweep_data import (COST, FAIL_MARKERS, METRIC_LABELS, PASSING, VERDICT_COLOURS, VERDICT_MEANING, VERDICT_ORDER,
                         ChartError, check_columns, fmt, folded_parameters, parameter_columns, suptitle, varying)

ROOT_PRECISION = 1e-12  # [s] the reference's event times: its root finder's tolerance
OFF_SCALE = 1e3  # a reference error this many times below the engines' smallest is drawn on the panel's foot
RELATIVE = ("exit_error_rel_max", "stick_error_rel_max")  # the default panels: the judge's own measures
# what a panel falls back to when the rows measured nothing of its metric, in order
FALLBACK = {"rel": ("exit_error_rel_max", "stick_error_rel_max", "restitution_error_max"),
            "s": ("exit_error_max", "stick_error_max", "first_impact_error_max")}
# the tolerance (``Tolerances`` field) each relative metric is judged against
TOLERANCE_OF = {"exit_error_rel_max": "exit", "stick_error_rel_max": "stick", "restitution_error_max": "restitution"}
LEGEND_CHARS = 44  # a legend entry's line, in characters: two columns of them fit a 6.4 in panel at 8 pt
YLABEL_CHARS = 46  # a y label's line, in characters: the height of a 5.6 in panel at 10 pt, with room to spare


def cost_lever(engine: str, settings: dict | None = None) -> str:
    """The settings field engine ``engine`` trades accuracy for cost with (``EngineAdapter.cost_lever``).

    ``settings`` are the engine's own fields (``{"accuracy": 1e-3}``). ``"dt"`` when the engine
    cannot be asked here (not installed, unknown to this version, settings it refuses).
    """
    from chatterbench.engines.registry import adapter, make_settings

    try:
        return str(adapter(engine).cost_lever(make_settings(engine, overrides={f"{engine}.{k}": v
                                                                              for k, v in (settings or {}).items()})))
    except (InputError, ImportError, TypeError, ValueError):
        return "dt"


def _engine_settings(row: pd.Series, engine: str) -> dict:
    """The engine's settings in one dataset row: its dotted columns with a value, without the prefix."""
    return {k.split(".", 1)[1]: v for k, v in row.items() if k.startswith(engine + ".") and not pd.isna(v)}


def work_precision_points(rows: pd.DataFrame, errors: Sequence[str] = RELATIVE) -> pd.DataFrame:
    """The points of the work-precision chart: one per (engine, engine settings, value of its cost lever).

    Rows that differ only in swept scene parameters (``restitution``, ``mass2``, ...) fold
    into one point: worst |error| of each metric (NaN-skipping), median cost [s per simulated
    s], worst verdict. The lever is ``cost_lever`` of the engine's first row: ``dt``, or a
    setting read from the dotted column ``ENGINE.FIELD`` (``drake.accuracy``).

    Returns
    -------
    DataFrame with columns ``engine``, ``curve`` (legend label), ``settings`` (dict of the
    engine's swept settings but the lever), ``lever`` (its field name), ``lever_value``,
    ``dt`` [s] (the lever's value when it is dt, else the group's median dt), the ``errors``
    columns, ``cost_per_sim_s``, ``verdict``, ``n_rows``, ``verdicts`` ("match 2, late 1").
    """
    check_columns(rows, ["engine", "dt", "verdict", COST, *errors])
    out = []
    for engine in sorted(rows["engine"].astype(str).unique()):
        every = rows[rows["engine"] == engine]
        levers = _row_levers(every, engine)
        columns = {lev: "dt" if lev == "dt" or f"{engine}.{lev}" not in every else f"{engine}.{lev}" for lev in levers.unique()}
        # the settings that tell curves apart: an engine with two levers (drake's modes) gets both curves labelled
        settings = varying(every, [c for c in rows.columns if c.startswith(engine + ".") and c not in columns.values()])
        for lever, column in sorted(columns.items()):
            sub = every[levers == lever]
            lever = "dt" if column == "dt" else lever
            keys = settings + [column]
            sub = sub.assign(**{c: sub[c].fillna("-") if sub[c].dtype == object else sub[c] for c in settings})
            for key, grp in sub.groupby(keys, sort=True, dropna=False):
                out.append(_point(engine, lever, column, dict(zip(settings, key[:-1])), key[-1], grp, errors))
    return pd.DataFrame(out, columns=["engine", "curve", "settings", "lever", "lever_value", "dt", *errors, COST, "verdict",
                                      "n_rows", "verdicts"])


def _row_levers(rows: pd.DataFrame, engine: str) -> pd.Series:
    """``cost_lever`` of each row of ``engine`` (asked once per distinct set of its settings)."""
    asked: dict[tuple, str] = {}
    levers = []
    for _, row in rows.iterrows():
        sett = _engine_settings(row, engine)
        key = tuple(sorted((k, repr(v)) for k, v in sett.items()))
        if key not in asked:
            asked[key] = cost_lever(engine, sett)
        levers.append(asked[key])
    return pd.Series(levers, index=rows.index, dtype=object)


def _point(engine: str, lever: str, column: str, sett: dict, value: Any, grp: pd.DataFrame,
           errors: Sequence[str]) -> dict[str, Any]:
    """One chart point: the rows ``grp`` of one curve at one value of its lever, folded."""
    label = engine + (" (" + ", ".join(f"{k.split('.', 1)[1]}={fmt(v)}" for k, v in sett.items()) + ")" if sett else "")
    dts = pd.to_numeric(grp["dt"], errors="coerce").dropna()
    point = {"engine": engine, "curve": label, "settings": sett, "lever": lever, "lever_value": value,
             "dt": float(value) if column == "dt" else (float(dts.median()) if len(dts) else math.nan)}
    for e in errors:
        vals = pd.to_numeric(grp[e], errors="coerce").abs().dropna()
        point[e] = float(vals.max()) if len(vals) else math.nan
    cost = pd.to_numeric(grp[COST], errors="coerce").dropna()
    point[COST] = float(cost.median()) if len(cost) else math.nan
    counts = grp["verdict"].astype(str).value_counts()
    point["verdict"] = combine(grp["verdict"].astype(str))
    point["n_rows"] = len(grp)
    point["verdicts"] = ", ".join(f"{v} {counts[v]}" for v in sorted(counts.index, key=rank))
    return point


def _why_empty(rows: pd.DataFrame, metrics: str | Sequence[str]) -> str:
    """One sentence: why no row measured ``metrics`` (one metric, or several that share the reason)."""
    metrics = [metrics] if isinstance(metrics, str) else list(metrics)
    label = " or ".join(METRIC_LABELS.get(m, m).split(" (")[0] for m in metrics)
    return f"no {label} measured: {_reason(rows, metrics[0])}"


def _reason(rows: pd.DataFrame, metric: str) -> str:
    verdicts = rows["verdict"].astype(str)
    counts = verdicts.value_counts()
    listed = ", ".join(f"{counts[v]} {v}" for v in sorted(counts.index, key=rank))
    if verdicts.eq("none").all():
        return "neither the reference nor the engines slide in these runs"
    if not verdicts.isin(PASSING).any():
        if verdicts.eq("none").any():  # "none" is no failure: there was no episode to reproduce
            return (f"no episode to judge ({listed}; none: neither the reference nor the engine sticks within the "
                    "run's duration)")
        return f"no run reproduced the episodes ({listed})"
    if metric.startswith("exit"):
        return "the reference never leaves the wall in these runs"
    if metric.startswith("restitution"):
        return "no engine flight lasted long enough after an impact to measure its rebound"
    return "none in these runs"


def default_error(rows: pd.DataFrame) -> str:
    """The first panel's metric when none is asked for: the relative exit error, or the exit error in
    seconds for a dataset written before the relative errors existed (it has no such column)."""
    return RELATIVE[0] if RELATIVE[0] in rows else "exit_error_max"


def panel_metrics(rows: pd.DataFrame, error: str | None = None) -> tuple[list[str], list[str]]:
    """The metrics the chart draws and a sentence for each one asked for that no row measured.

    Asked for: ``error`` (None: ``default_error``) and the sticking start in the same unit
    (relative or seconds). A metric with no finite value gives its panel to the next of
    ``FALLBACK`` that has one (the ball never exits: sticking start and restitution instead);
    with nothing measured, the one panel of ``error`` (it says why).
    """
    error = error or default_error(rows)
    unit = "s" if _in_seconds(error) else "rel"
    asked = list(dict.fromkeys([error, "stick_error_rel_max" if unit == "rel" else "stick_error_max"]))
    has = {m: m in rows and np.isfinite(pd.to_numeric(rows[m], errors="coerce")).any() for m in {*asked, *FALLBACK[unit]}}
    chosen, missing = [m for m in asked if has[m]], [m for m in asked if not has[m]]
    reasons: dict[str, list[str]] = {}  # metrics that share a reason get one sentence
    for m in missing:
        reasons.setdefault(_reason(rows, m), []).append(m)
    notes = [_why_empty(rows, ms) for ms in reasons.values()]
    for m in FALLBACK[unit]:
        if len(chosen) < len(asked) and m not in chosen and has[m]:
            chosen.append(m)
    return (chosen or [error]), notes


def pareto_front(points: pd.DataFrame, error: str = RELATIVE[0], cost: str = COST,
                 eligible: pd.Series | None = None) -> pd.Series:
    """Which points are on the best-trade-off front (no other point both cheaper and more accurate).

    A point is dominated when another eligible point has cost <= and error <= with at least
    one strictly smaller; the front is the eligible points with finite, positive cost and
    error that no other point dominates.

    Parameters
    ----------
    points : DataFrame with the ``error`` column (any error metric) and ``cost`` [s per simulated s].
    eligible : bool Series aligned with ``points``; default: verdict in ``PASSING`` when
        there is a ``verdict`` column (a failing point's error does not describe a
        working method), else all.

    Returns
    -------
    bool Series aligned with ``points``.
    """
    c = pd.to_numeric(points[cost], errors="coerce").to_numpy(float)
    e = pd.to_numeric(points[error], errors="coerce").to_numpy(float)
    if eligible is None:
        eligible = points["verdict"].isin(PASSING) if "verdict" in points else pd.Series(True, index=points.index)
    ok = eligible.to_numpy(bool) & np.isfinite(c) & np.isfinite(e) & (c > 0) & (e > 0)
    idx = np.flatnonzero(ok)
    front = np.zeros(len(points), bool)
    for i in idx:
        no_worse = (c[idx] <= c[i]) & (e[idx] <= e[i])
        better = (c[idx] < c[i]) | (e[idx] < e[i])
        front[i] = not np.any(no_worse & better)
    return pd.Series(front, index=points.index, name="pareto")


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


def _in_seconds(metric: str) -> bool:
    """Whether ``metric`` is a time error [s] (else dimensionless: relative, restitution)."""
    return metric in FALLBACK["s"] or metric == "stick_error_plate_max"


def _reference_error(metric: str, error: float) -> str:
    """The reference's error on ``metric``'s panel in the metric's unit: seconds for a time metric; "exact" for a
    dimensionless one (relative, restitution: Newton's R holds exactly; ``error`` [s] is a time)."""
    return f"error {error:.0e} s" if _in_seconds(metric) else "exact"


def measured_reference_cost(rows: pd.DataFrame) -> float | None:
    """Median of the rows' ``reference_cost_per_sim_s`` [s per simulated s]; None when not measured."""
    if "reference_cost_per_sim_s" not in rows:
        return None
    cost = pd.to_numeric(rows["reference_cost_per_sim_s"], errors="coerce")
    cost = cost[np.isfinite(cost) & (cost > 0)]
    return float(cost.median()) if len(cost) else None


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
            ax.text(0.5, 0.5, textwrap.fill(empty[0] if empty else _why_empty(rows, metric), 48), transform=ax.transAxes,
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
    unit = " [s]" if _in_seconds(metric) else ""
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
