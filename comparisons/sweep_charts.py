"""Sweep charts, one function per chart, each returning a matplotlib Figure (the CLI saves it).

    >>> rows = pd.read_parquet("out/fp/rows.parquet")            # rows.ROW_COLUMNS + parameters
    >>> fig = work_precision_figure(rows)                        # error against cost, per engine
    >>> fig = stability_map_figure(rows, "dt", "restitution")    # verdict over two parameters

Both charts read only a sweep dataset (``pipeline/summary.py`` documents its columns); nothing is rerun.

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

``stability_map_figure``: the verdict of every grid cell over two parameters, one panel per
engine, one colour per verdict class (``VERDICT_COLORS``), worst verdict where other
parameters vary within a cell.

Promises: the figures depend only on the rows given (same rows, same figure); a column or
engine that is not in the rows is a ``ChartError`` naming the nearest valid name.
"""

from __future__ import annotations

import math
import textwrap
from typing import Any, Iterable, Sequence

import matplotlib

matplotlib.use("Agg")  # files only: no display is needed or wanted
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch, Rectangle  # noqa: E402
from matplotlib.transforms import blended_transform_factory  # noqa: E402

from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import SceneError, did_you_mean  # noqa: E402

from .charts import ENGINE_COLORS  # noqa: E402
from .pipeline.summary import DERIVED_PARAMETERS, ROW_COLUMNS  # noqa: E402
from .pipeline.vocabulary import ABBREVIATIONS, COLOURS, MEANINGS, NAMES, combine, rank, text_colour  # noqa: E402
from .pipeline.vocabulary import PASSING as PASSING_VERDICTS  # noqa: E402

# verdict names, colours, abbreviations and meanings: the one vocabulary (pipeline/vocabulary.py)
VERDICT_ORDER = NAMES  # best first, "none" first of all: nothing to judge
PASSING = PASSING_VERDICTS  # the run reproduced the episodes; only their timing or impacts may be off
VERDICT_COLORS = COLOURS
VERDICT_ABBREV = ABBREVIATIONS
VERDICT_MEANING = MEANINGS
# hollow markers of the failure classes on the work-precision chart
FAIL_MARKERS = {"missed": "v", "spurious": "^", "endless": "D", "penetrated": "s",
                "diverged": "X", "error": "P", "timeout": "*", "crashed": "X"}
METRIC_LABELS = {
    "exit_error_rel_max": "exit time (fraction of the sliding duration)",
    "stick_error_rel_max": "sticking start (fraction of the chatter duration)",
    "restitution_error_max": "restitution of the resolved impacts (relative)",
    "exit_error_max": "exit time",
    "stick_error_max": "sticking start (vs the Zeno point)",
    "stick_error_plate_max": "sticking start (vs Feigin's plate entry)",
    "first_impact_error_max": "first impact",
}
ROOT_PRECISION = 1e-12  # [s] the reference's event times: its root finder's tolerance
OFF_SCALE = 1e3  # a reference error this many times below the engines' smallest is drawn on the panel's foot
COST = "cost_per_sim_s"
LOG_SPAN = 10.0  # stability map: an axis whose values span this ratio (a decade) or more is log-scaled
IRREGULAR = 2.0  # stability map: a linear axis whose steps differ by more than this factor gets equal cells
ANNOTATE_MAX_CELLS = 150  # stability map: write the verdict in the cells up to this many per panel


class ChartError(InputError):
    """Chart input that cannot be drawn (unknown column or engine, no rows); exit code 2 in the CLI."""


# -- dataset helpers -----------------------------------------------------------------------

def parameter_columns(rows: pd.DataFrame) -> list[str]:
    """The parameters of a dataset: ``dt``, ``mass_ratio`` (when present) and every column not in ``summary.ROW_COLUMNS``."""
    derived = [c for c in DERIVED_PARAMETERS if c == "dt" or c in rows.columns]
    return derived + [c for c in rows.columns if c not in ROW_COLUMNS]


def folded_parameters(frame: pd.DataFrame, shown: Sequence[str], candidates: Iterable[str]) -> list[str]:
    """The ``candidates`` that vary in ``frame`` and are not drawn (``shown``): what a chart folds.

    ``mass_ratio`` is derived from ``mass1`` and ``mass2``: it is named only when it is not
    drawn and neither mass varies, and the masses are not named when it is drawn.
    """
    skip = set(shown)
    if "mass_ratio" in skip:
        skip |= {"mass1", "mass2"}
    varying = _varying(frame, [c for c in candidates if c not in skip])
    if {"mass1", "mass2"} & set(varying):
        varying = [c for c in varying if c != "mass_ratio"]
    return varying


def _flat(value: Any, prefix: str = "") -> dict[str, Any]:
    """Nested tables and lists as dotted keys, the way sweeps name them (``gap.lower``, ``forces.0.omega``)."""
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, (list, tuple)):
        items = ((str(i), v) for i, v in enumerate(value))
    else:
        return {prefix.rstrip("."): value}
    out: dict[str, Any] = {}
    for k, v in items:
        out.update(_flat(v, f"{prefix}{k}."))
    return out


def default_values(rows: pd.DataFrame, engine: str) -> dict[str, Any]:
    """The default of each parameter a sweep of ``engine`` may vary, as dotted keys.

    The engine's settings (``mujoco.w0_dt`` = 0.03, ``pybullet.restitution_velocity_threshold``
    = 0, ...) and, when the rows are of one built-in scene, that scene's fields
    (``restitution``, ``mass2``, ``gap.lower``, ``initial.t`` ...) and its ``mass_ratio``.
    """
    from chatterbench.engines.registry import ENGINE_NAMES, make_settings, settings_dict
    from chatterbench.reference.catalogue import CATALOGUE
    from chatterbench.reference.scene import load_scene

    from .pipeline.summary import mass_ratio

    out: dict[str, Any] = {}
    if engine in ENGINE_NAMES:
        out.update({f"{engine}.{k}": v for k, v in settings_dict(make_settings(engine)).items() if k != "dt"})
    scenes = rows["scene"].astype(str).unique() if "scene" in rows else []
    if len(scenes) == 1 and scenes[0] in CATALOGUE:
        scene = load_scene(scenes[0], {})
        fields = _flat(scene.to_dict())
        fields["mass1"] = scene.mass1
        out.update({k: v for k, v in fields.items() if k not in ("name", "description")})
        out["mass_ratio"] = mass_ratio(scene)
    return out


def equals(column: pd.Series, value: Any) -> pd.Series:
    """Where ``column`` holds ``value`` (numbers to 1e-9 relative, infinities exactly)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        num = pd.to_numeric(column, errors="coerce").astype(float)
        if math.isinf(value):
            return num == value
        return (num - value).abs() <= 1e-9 * max(abs(value), 1e-300)
    return column.astype(str) == str(value)


def at_defaults(rows: pd.DataFrame, engine: str, shown: Sequence[str], candidates: Iterable[str] | None = None
                ) -> tuple[pd.DataFrame, dict[str, Any]]:
    """``engine``'s rows with the parameters not ``shown`` held at their defaults, where the sweep ran them.

    A report cannot ask which slice a reader wants; the defaults are the settings a user
    starts from. A parameter whose default the sweep did not run stays folded (worst case).

    Parameters
    ----------
    shown : the parameters the chart draws (its axes, or the curves' settings).
    candidates : the parameters that may be held; default every parameter column.

    Returns
    -------
    (rows, held): the slice, and each held parameter with its value.
    """
    sub = rows[rows["engine"] == engine]
    defaults = default_values(rows, engine)
    held: dict[str, Any] = {}
    for col in folded_parameters(sub, shown, parameter_columns(rows) if candidates is None else candidates):
        if col in defaults:
            keep = equals(sub[col], defaults[col])
            if keep.any():
                sub, held[col] = sub[keep], defaults[col]
    return sub, held


def check_columns(rows: pd.DataFrame, names: Iterable[str], allowed: Sequence[str] | None = None, what: str = "column") -> None:
    """Raise ``ChartError`` for the first name not in ``allowed`` (default: the rows' columns)."""
    allowed = list(rows.columns) if allowed is None else list(allowed)
    for name in names:
        if name not in allowed:
            raise ChartError(f"{what} {name!r} is not in the dataset{did_you_mean(name, allowed)}; "
                             f"available: {', '.join(allowed)}")


_rank = rank  # severity rank, 0 = worst (vocabulary.SEVERITY)
worst_verdict = combine  # the worst of several verdicts; "none" if empty


def _engines(rows: pd.DataFrame, engine: str | None) -> list[str]:
    present = sorted(rows["engine"].astype(str).unique())
    if engine is None:
        return present
    check_columns(rows, [engine], present, what="engine")
    return [engine]


def _varying(frame: pd.DataFrame, columns: Iterable[str]) -> list[str]:
    """The columns that take more than one value (NaN aside) in ``frame``."""
    return [c for c in columns if c in frame and frame[c].dropna().nunique() > 1]


def _fmt(v) -> str:
    return f"{v:g}" if isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) else str(v)


def _suptitle(fig: Figure, text: str, size: float = 11.0) -> None:
    """The figure's title, wrapped to its width (a one-panel map is narrower than its longest title)."""
    chars = max(30, int(fig.get_figwidth() * 72.0 / (0.6 * size)))
    fig.suptitle(textwrap.fill(text, chars), fontsize=size)


# -- work-precision --------------------------------------------------------------------------

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
        settings = _varying(sub, [c for c in rows.columns if c.startswith(engine + ".")])
        keys = settings + ["dt"]
        sub = sub.assign(**{c: sub[c].fillna("-") if sub[c].dtype == object else sub[c] for c in settings})
        for key, grp in sub.groupby(keys, sort=True, dropna=False):
            key = key if isinstance(key, tuple) else (key,)
            sett = dict(zip(settings, key[:-1]))
            label = engine + (" (" + ", ".join(f"{k.split('.', 1)[1]}={_fmt(v)}" for k, v in sett.items()) + ")" if sett else "")
            counts = grp["verdict"].astype(str).value_counts()
            point = {"engine": engine, "curve": label, "settings": sett, "dt": float(key[-1])}
            for e in errors:
                vals = pd.to_numeric(grp[e], errors="coerce").abs().dropna()
                point[e] = float(vals.max()) if len(vals) else math.nan
            cost = pd.to_numeric(grp[COST], errors="coerce").dropna()
            point[COST] = float(cost.median()) if len(cost) else math.nan
            point["verdict"] = worst_verdict(grp["verdict"].astype(str))
            point["n_rows"] = len(grp)
            point["verdicts"] = ", ".join(f"{v} {counts[v]}" for v in sorted(counts.index, key=_rank))
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
    fig, axes = plt.subplots(1, len(metrics), figsize=(6.4 * len(metrics), 5.6), layout="constrained", squeeze=False)
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
        notes.append("not drawn (no cost measured): " + ", ".join(f"{counts[v]} {v}" for v in sorted(counts.index, key=_rank)))
    _suptitle(fig, "; ".join([f"{scene}: work-precision, {len(rows)} runs", *filter(None, notes)]))
    return fig


# -- stability map ---------------------------------------------------------------------------

def verdict_grid(rows: pd.DataFrame, x: str, y: str, engine: str) -> pd.DataFrame:
    """The worst verdict per (``y``, ``x``) cell of one engine's rows.

    Returns a DataFrame indexed by the sorted values of ``y`` with the sorted values of
    ``x`` as columns; a cell with no row is NaN.
    """
    check_columns(rows, [x, y])
    sub = rows[(rows["engine"] == engine)].dropna(subset=[x, y])
    if sub.empty:
        return pd.DataFrame()
    cells = sub.groupby([y, x])["verdict"].agg(lambda s: worst_verdict(s.astype(str)))
    grid = cells.unstack(x)
    return grid.sort_index().sort_index(axis=1)


def _axis(values: Sequence) -> tuple[np.ndarray, np.ndarray, str]:
    """Cell centres, cell edges and scale (``log``, ``linear`` or ``category``) of one map axis.

    Positive numbers spanning a decade or more: log. Other numbers: linear when evenly
    enough spaced (largest step at most ``IRREGULAR`` times the smallest), else equal
    cells in value order, like strings (0, 0.1, 0.5 or 0, 0.1, 1, 10 would otherwise
    squeeze the small values into slivers).
    """
    vals = list(values)
    numeric = all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) for v in vals)
    v = np.asarray(vals, float) if numeric else np.empty(0)
    log = numeric and v.min() > 0 and v.max() / v.min() >= LOG_SPAN
    if numeric and not log and len(v) > 2:
        steps = np.diff(v)
        numeric = steps.max() <= IRREGULAR * steps.min()
    if not numeric:
        pos = np.arange(len(vals), dtype=float)
        return pos, np.arange(len(vals) + 1) - 0.5, "category"
    scale = "log" if log else "linear"
    u = np.log10(v) if scale == "log" else v
    if len(u) == 1:
        half = 0.5 if scale == "log" else (0.5 * abs(u[0]) or 0.5)
        edges = np.array([u[0] - half, u[0] + half])
    else:
        mid = 0.5 * (u[:-1] + u[1:])
        edges = np.concatenate(([u[0] - (mid[0] - u[0])], mid, [u[-1] + (u[-1] - mid[-1])]))
    return v, (10.0 ** edges if scale == "log" else edges), scale


def _set_axis(ax, which: str, values: Sequence, centres: np.ndarray, edges: np.ndarray, scale: str) -> None:
    setter = ax.set_xscale if which == "x" else ax.set_yscale
    setter("log" if scale == "log" else "linear")
    (ax.set_xlim if which == "x" else ax.set_ylim)(edges[0], edges[-1])
    (ax.set_xticks if which == "x" else ax.set_yticks)(centres, labels=[_fmt(v) for v in values])
    (ax.xaxis if which == "x" else ax.yaxis).set_minor_locator(matplotlib.ticker.NullLocator())


def stability_map_figure(rows: pd.DataFrame, x: str, y: str, engine: str | None = None) -> Figure:
    """Verdict of each grid cell over the parameters ``x`` and ``y``, one panel per engine.

    Parameters
    ----------
    rows : sweep dataset.
    x, y : str
        Parameter columns (dotted keys: ``dt``, ``restitution``, ``mujoco.w0_dt``, ...).
        An axis whose values span more than a decade is log-scaled.
    engine : str, optional
        Draw only this engine; default: every engine that has values of both ``x`` and ``y``.

    A cell takes the worst verdict of its rows (other swept parameters folded in); a cell
    with no row is left blank.
    """
    if x == y:
        raise ChartError(f"x and y are both {x!r}: choose two different parameters")
    check_columns(rows, [x, y], parameter_columns(rows), what="parameter")
    grids = {e: verdict_grid(rows, x, y, e) for e in _engines(rows, engine)}
    grids = {e: g for e, g in grids.items() if not g.empty}
    if not grids:
        raise ChartError(f"no rows{' of ' + engine if engine else ''} have values of both {x!r} and {y!r}"
                         " (an engine's settings apply to that engine only)")
    codes = {v: i for i, v in enumerate(VERDICT_ORDER)}
    cmap = ListedColormap([VERDICT_COLORS[v] for v in VERDICT_ORDER]).with_extremes(bad="white")  # no run: blank
    norm = BoundaryNorm(np.arange(len(VERDICT_ORDER) + 1) - 0.5, len(VERDICT_ORDER))
    n = len(grids)
    fig, axes = plt.subplots(1, n, figsize=(max(5.0, 0.45 * max(g.shape[1] for g in grids.values()) + 3.0) * n, 5.4),
                             layout="constrained", squeeze=False)
    seen: set[str] = set()
    for ax, (eng, grid) in zip(axes[0], grids.items()):
        xc, xe, xs = _axis(grid.columns)
        yc, ye, ys = _axis(grid.index)
        c = np.ma.masked_invalid(np.array([[codes.get(v, codes["error"]) if isinstance(v, str) else np.nan
                                            for v in row] for row in grid.to_numpy()], float))
        ax.pcolormesh(xe, ye, c, cmap=cmap, norm=norm, edgecolors="white", linewidth=0.8)
        _set_axis(ax, "x", grid.columns, xc, xe, xs)
        _set_axis(ax, "y", grid.index, yc, ye, ys)
        present = {v for v in grid.to_numpy().ravel() if isinstance(v, str)}
        seen |= present
        if grid.size <= ANNOTATE_MAX_CELLS:
            for i, yv in enumerate(yc):
                for j, xv in enumerate(xc):
                    v = grid.iat[i, j]
                    if isinstance(v, str):
                        ax.text(xv, yv, VERDICT_ABBREV.get(v, v), ha="center", va="center", fontsize=8,
                                color=text_colour(v))
        ax.set_xlabel(x + (" [s]" if x == "dt" else ""))
        ax.set_ylabel(y + (" [s]" if y == "dt" else ""))
        sub = rows[rows["engine"] == eng].dropna(subset=[x, y])
        folded = folded_parameters(sub, (x, y), parameter_columns(rows))
        note = ("\nworst over " + ", ".join(f"{c} ({sub[c].nunique()})" for c in folded)) if folded else ""
        ax.set_title(f"{eng}: {len(sub)} runs{note}", fontsize=10)
    handles = [Patch(facecolor=VERDICT_COLORS[v], edgecolor="0.5", label=f"{VERDICT_ABBREV[v]}  {v}: {VERDICT_MEANING[v]}")
               for v in VERDICT_ORDER if v in seen]
    ncol = max(1, min(3, len(handles), int(fig.get_figwidth() // 3.6)))
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8, frameon=False)
    scene = ", ".join(sorted(rows["scene"].astype(str).unique())) if "scene" in rows else ""
    _suptitle(fig, f"{scene}: verdict over {x} and {y}")
    return fig
