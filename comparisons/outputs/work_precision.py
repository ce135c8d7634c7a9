"""The work-precision chart of a sweep: error against cost, per engine and setting, the Pareto front marked.

    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.comparisons.pipeline.summary import summarize
    >>> rows = pd.DataFrame([summarize(compare(load_scene("bouncing-ball", [f"restitution={r}"]), engines=("pybullet",),
    ...                                        dt=dt), "pybullet", {"dt": dt, "restitution": r})
    ...                      for dt in (1e-3, 3e-4) for r in (0.3, 0.5)])          # a small sweep's rows
    >>> fig = work_precision_figure(rows)       # a matplotlib Figure; the CLI saves it
    >>> fig.axes[0].get_xlabel()
    'cost: wall-clock s per simulated s'

``work_precision_figure``: worst |exit error| and worst |sticking start error| [s] against
wall-clock cost per simulated second, log-log, one curve per engine (and per value of that
engine's swept settings, e.g. ``mujoco.w0_dt``) through its timesteps, each point labelled
with its dt. Swept scene parameters (``restitution``, ``mass2``, ...) are folded into each
point as the worst case: largest error, worst verdict, median cost. Points whose verdict is
a failure (not match/early/late) are hollow, one marker per class; failures with no
measured error sit on a strip at the top of the panel. The best trade-off (Pareto front:
no other point both cheaper and more accurate) is ringed and joined. Artists carry ids
(``Line2D.get_gid``): ``curve:LABEL``, ``pareto-front``, ``failed:VERDICT``,
``failed-no-error:VERDICT``, ``reference``.

"""

from __future__ import annotations

import math
from typing import Sequence

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.transforms import blended_transform_factory

from chatterbench.comparisons.pipeline.vocabulary import combine, rank

from .style import ENGINE_COLORS
from .sweep_data import (COST, FAIL_MARKERS, METRIC_LABELS, PASSING, VERDICT_COLORS, VERDICT_MEANING, VERDICT_ORDER,
                         ChartError, check_columns, fmt, folded_parameters, parameter_columns, suptitle, varying)

ROOT_PRECISION = 1e-12  # [s] the reference's event times: its root finder's tolerance
OFF_SCALE = 1e3  # a reference error this many times below the engines' smallest is drawn on the panel's foot


def work_precision_points(rows: pd.DataFrame, errors: Sequence[str] = ("exit_error_max", "stick_error_max")) -> pd.DataFrame:
    """The points of the work-precision chart: one per (engine, engine settings, dt).

    Rows that differ only in swept scene parameters (``restitution``, ``mass2``, ...) fold
    into one point: worst error of each metric [s] (NaN-skipping), median cost [s per
    simulated s], worst verdict.

    Returns
    -------
    DataFrame with columns ``engine``, ``curve`` (legend label), ``settings`` (dict of the
    engine's swept settings), ``dt`` [s], the ``errors`` columns [s], ``cost_per_sim_s``,
    ``verdict``, ``n_rows``, ``verdicts`` (each verdict with its count, "match 2, late 1").
    """
    check_columns(rows, ["engine", "dt", "verdict", COST, *errors])
    out = []
    for engine in sorted(rows["engine"].astype(str).unique()):
        sub = rows[rows["engine"] == engine]
        settings = varying(sub, [c for c in rows.columns if c.startswith(engine + ".")])
        keys = settings + ["dt"]
        sub = sub.assign(**{c: sub[c].fillna("-") if sub[c].dtype == object else sub[c] for c in settings})
        for key, grp in sub.groupby(keys, sort=True, dropna=False):
            key = key if isinstance(key, tuple) else (key,)
            sett = dict(zip(settings, key[:-1]))
            label = engine + (" (" + ", ".join(f"{k.split('.', 1)[1]}={fmt(v)}" for k, v in sett.items()) + ")" if sett else "")
            counts = grp["verdict"].astype(str).value_counts()
            point = {"engine": engine, "curve": label, "settings": sett, "dt": float(key[-1])}
            for e in errors:
                vals = pd.to_numeric(grp[e], errors="coerce").abs().dropna()
                point[e] = float(vals.max()) if len(vals) else math.nan
            cost = pd.to_numeric(grp[COST], errors="coerce").dropna()
            point[COST] = float(cost.median()) if len(cost) else math.nan
            point["verdict"] = combine(grp["verdict"].astype(str))
            point["n_rows"] = len(grp)
            point["verdicts"] = ", ".join(f"{v} {counts[v]}" for v in sorted(counts.index, key=rank))
            out.append(point)
    return pd.DataFrame(out, columns=["engine", "curve", "settings", "dt", *errors, COST, "verdict", "n_rows", "verdicts"])


def pareto_front(points: pd.DataFrame, error: str = "exit_error_max", cost: str = COST,
                 eligible: pd.Series | None = None) -> pd.Series:
    """Which points are on the best-trade-off front (no other point both cheaper and more accurate).

    A point is dominated when another eligible point has cost <= and error <= with at least
    one strictly smaller; the front is the eligible points with finite, positive cost and
    error that no other point dominates.

    Parameters
    ----------
    points : DataFrame with the ``error`` [s] and ``cost`` [s per simulated s] columns.
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
            styles[curve] = {"color": ENGINE_COLORS.get(engine, f"C{len(styles)}"),
                             "ls": ("-", "--", ":", "-.")[k % 4], "marker": ("o", "s", "D", "^")[k % 4]}
    return styles


def _folded_note(rows: pd.DataFrame) -> str:
    engines = set(rows["engine"].astype(str)) | {"mujoco", "pybullet"}
    scene_params = [c for c in parameter_columns(rows) if c.split(".")[0] not in engines]
    varied = folded_parameters(rows, ["dt"], scene_params)
    if not varied:
        return ""
    return "worst case over " + ", ".join(f"{c} ({rows[c].dropna().nunique()} values)" for c in varied)


def measured_reference_cost(rows: pd.DataFrame) -> float | None:
    """Median of the rows' ``reference_cost_per_sim_s`` [s per simulated s]; None when not measured."""
    if "reference_cost_per_sim_s" not in rows:
        return None
    cost = pd.to_numeric(rows["reference_cost_per_sim_s"], errors="coerce")
    cost = cost[np.isfinite(cost) & (cost > 0)]
    return float(cost.median()) if len(cost) else None


def work_precision_figure(rows: pd.DataFrame, error: str = "exit_error_max", reference_cost: float | None = None,
                          reference_error: float | None = None) -> Figure:
    """Error against cost per engine, log-log: the exit time panel and the sticking start panel.

    Parameters
    ----------
    rows : sweep dataset (``summary.ROW_COLUMNS`` plus one column per parameter).
    error : str
        Metric of the first panel (``exit_error_max`` default); the second is
        ``stick_error_max`` (a single panel when ``error`` is that).
    reference_cost : float, optional
        The reference's own wall-clock seconds per simulated second: drawn as a star at
        (``reference_cost``, ``reference_error`` or ``ROOT_PRECISION``). Default: the median
        of the rows' ``reference_cost_per_sim_s`` (measured in each run); where the rows
        have none, a band at the foot of each panel stands for the reference (exact).
    reference_error : float, optional
        The reference's error [s], its root precision (~1e-12 s).
    """
    metrics = list(dict.fromkeys([error, "stick_error_max"]))
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
        front = pareto_front(points, metric)
        has = np.isfinite(points[metric]) & np.isfinite(points[COST])
        passing = points["verdict"].isin(PASSING)
        strip = blended_transform_factory(ax.transData, ax.transAxes)
        for curve, grp in points.groupby("curve", sort=False):
            st = styles[curve]
            g = grp[has.loc[grp.index]].sort_values(COST)
            ax.plot(g[COST], g[metric], color=st["color"], ls=st["ls"], lw=1.4, label=curve, zorder=2, gid=f"curve:{curve}")
            ok = g[passing.loc[g.index]]
            ax.plot(ok[COST], ok[metric], ls="none", marker=st["marker"], color=st["color"], ms=6, zorder=3)
            for v, gv in ok[ok["verdict"] != "match"].groupby("verdict"):  # timing or impacts outside tolerance: a rim
                ax.plot(gv[COST], gv[metric], ls="none", marker=st["marker"], color=st["color"], mec=VERDICT_COLORS[v],
                        mew=2.2, ms=8, zorder=3)
            for v, gv in g[~passing.loc[g.index]].groupby("verdict"):
                classes_seen.add(v)
                ax.plot(gv[COST], gv[metric], ls="none", marker=FAIL_MARKERS.get(v, "x"), mfc="white",
                        mec=st["color"], mew=1.6, ms=8, zorder=3, gid=f"failed:{v}")
            for r in g.itertuples():
                ax.annotate(f"{r.dt:g}", (getattr(r, COST), getattr(r, metric)), xytext=(4, -9),
                            textcoords="offset points", fontsize=6.5, color=st["color"])
            # failures without a measured error: a strip along the top, at their cost
            lost = grp[~has.loc[grp.index] & np.isfinite(grp[COST]) & ~grp["verdict"].isin(PASSING + ("none",))]
            for v, gv in lost.groupby("verdict"):
                classes_seen.add(v)
                ax.plot(gv[COST], np.full(len(gv), 0.965), transform=strip, ls="none", marker=FAIL_MARKERS.get(v, "x"),
                        mfc="white", mec=st["color"], mew=1.6, ms=8, zorder=3, clip_on=False, gid=f"failed-no-error:{v}")
                for r in gv.itertuples():
                    ax.annotate(f"{r.dt:g}", (getattr(r, COST), 0.965), xycoords=strip, xytext=(6, -3),
                                textcoords="offset points", fontsize=6.5, color=st["color"])
        fr = points[front].sort_values(COST)
        if len(fr):
            ax.plot(fr[COST], fr[metric], color="#ffc107", lw=7, alpha=0.35, solid_capstyle="round", zorder=1)
            ax.plot(fr[COST], fr[metric], ls="none", marker="o", ms=14, mfc="none", mec="black", mew=1.2, zorder=4,
                    gid="pareto-front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        # a cost range of about a decade gets labels on minor ticks: keep 2 and 5 only, so they do not overlap
        ax.xaxis.set_minor_locator(matplotlib.ticker.LogLocator(subs=(2.0, 5.0)))
        if has.any():
            if reference_cost is not None:
                ref_err = reference_error if reference_error is not None else ROOT_PRECISION
                data_min = float(points.loc[has, metric][points.loc[has, metric] > 0].min())
                lo, hi = ax.get_xlim()
                ax.set_xlim(min(lo, reference_cost / 2.0), max(hi, reference_cost * 2.0))
                if ref_err < data_min / OFF_SCALE:
                    # many decades below the engines: drawn on the panel's foot so their curves stay readable
                    foot = blended_transform_factory(ax.transData, ax.transAxes)
                    ax.plot([reference_cost], [0.04], transform=foot, ls="none", marker="*", ms=16,
                            color=ENGINE_COLORS["reference"], zorder=5, clip_on=False, gid="reference")
                    ax.annotate(f"reference: error {ref_err:.0e} s (off scale)", (reference_cost, 0.04), xycoords=foot,
                                xytext=(9, 0), textcoords="offset points", fontsize=8, va="center")
                else:
                    ax.plot([reference_cost], [ref_err], ls="none", marker="*", ms=16, color=ENGINE_COLORS["reference"], zorder=5,
                            gid="reference")
                    ax.annotate("reference", (reference_cost, ref_err), xytext=(9, 0), textcoords="offset points",
                                fontsize=8, va="center")
            else:
                if reference_error is not None:
                    ax.axhline(reference_error, color="black", lw=0.8, ls="--")
                ax.add_patch(Rectangle((0, 0), 1, 0.04, transform=ax.transAxes, color="0.85", lw=0, zorder=0))
                ax.text(0.01, 0.02, "reference (exact): root precision ~1e-12 s, far below this axis", transform=ax.transAxes,
                        fontsize=7, va="center", color="0.25")
            lo, hi = ax.get_ylim()
            ax.set_ylim(lo / 2.5, hi * 2.5)  # room for the dt labels, the reference band and the failure strip
        else:
            costs = points[COST][np.isfinite(points[COST]) & (points[COST] > 0)]
            ax.set_xlim(*((costs.min() / 2.0, costs.max() * 2.0) if len(costs) else (1e-3, 1.0)))
            ax.set_ylim(1e-6, 1.0)  # any decades: nothing to scale to, and a log axis needs positive limits
            ax.text(0.5, 0.5, f"no {METRIC_LABELS.get(metric, metric)} measured\n(no episode of this kind in the scene?)",
                    transform=ax.transAxes, ha="center", va="center", color="0.4")
        if (~has & ~points["verdict"].isin(PASSING + ("none",))).any():
            ax.plot([0, 1], [0.93, 0.93], transform=ax.transAxes, color="0.6", lw=0.6, ls=":")
            ax.text(0.99, 0.965, "failed, no error measured", transform=ax.transAxes, fontsize=7, va="center", ha="right",
                    color="0.3")
        ax.grid(True, which="major", color="0.9", lw=0.6)
        ax.set_xlabel("cost: wall-clock s per simulated s")
        ax.set_ylabel(f"worst |error| in {METRIC_LABELS.get(metric, metric)} [s]")
        ax.set_title(f"error in {METRIC_LABELS.get(metric, metric)}", fontsize=10)
    handles = [Line2D([], [], color=styles[c]["color"], ls=styles[c]["ls"], marker=styles[c]["marker"], label=c)
               for c in styles]
    handles.append(Line2D([], [], ls="none", marker="o", ms=12, mfc="none", mec="black",
                          label="best trade-off (Pareto front)"))
    if reference_cost is not None:
        handles.append(Line2D([], [], ls="none", marker="*", ms=12, color="black", label="reference (exact)"))
    for v in sorted(classes_seen, key=VERDICT_ORDER.index):
        handles.append(Line2D([], [], ls="none", marker=FAIL_MARKERS.get(v, "x"), mfc="white", mec="0.3", mew=1.5,
                              label=f"{v}: {VERDICT_MEANING.get(v, '')}"))
    for v in (p for p in PASSING if p != "match"):  # rims: the run reproduced the episodes, not within tolerance
        if points["verdict"].eq(v).any():
            handles.append(Line2D([], [], ls="none", marker="o", color="0.5", mec=VERDICT_COLORS[v], mew=2.2, ms=8,
                                  label=f"{v}: {VERDICT_MEANING[v]}"))
    handles.append(Line2D([], [], ls="none", label="labels: dt [s]; hollow: the run failed"))
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    scene = ", ".join(sorted(rows["scene"].astype(str).unique())) if "scene" in rows else ""
    notes = [_folded_note(rows)]
    uncosted = rows[~np.isfinite(pd.to_numeric(rows[COST], errors="coerce"))]
    if len(uncosted):  # crashed, timed out or refused before any step: nothing to place on a cost axis
        counts = uncosted["verdict"].astype(str).value_counts()
        notes.append("not drawn (no cost measured): " + ", ".join(f"{counts[v]} {v}" for v in sorted(counts.index, key=rank)))
    suptitle(fig, "; ".join([f"{scene}: work-precision, {len(rows)} runs", *filter(None, notes)]))
    return fig
