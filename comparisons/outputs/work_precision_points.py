"""The points of the work-precision chart: one per engine, settings and value of its cost lever, the swept scene
parameters folded as the worst case, the panels' metrics and the best trade-off (Pareto front).

    >>> import pandas as pd
    >>> from chatterbench.comparisons.outputs.work_precision_points import pareto_front
    >>> points = pd.DataFrame({"cost_per_sim_s": [1.0, 2.0, 3.0], "exit_error_rel_max": [0.1, 0.01, 0.05],
    ...                        "verdict": ["match"] * 3})
    >>> pareto_front(points).tolist()         # the third is dearer and less accurate than the second
    [True, True, False]

What they are drawn as is ``work_precision``'s module docstring.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import pandas as pd

from chatterbench.comparisons.pipeline.vocabulary import combine, rank
from chatterbench.reference.errors import InputError

from .sweep_data import COST, METRIC_LABELS, PASSING, check_columns, fmt, varying

RELATIVE = ("exit_error_rel_max", "stick_error_rel_max")  # the default panels: the judge's own measures
# what a panel falls back to when the rows measured nothing of its metric, in order
FALLBACK = {"rel": ("exit_error_rel_max", "stick_error_rel_max", "restitution_error_max"),
            "s": ("exit_error_max", "stick_error_max", "first_impact_error_max")}


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


def why_empty(rows: pd.DataFrame, metrics: str | Sequence[str]) -> str:
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
    unit = "s" if in_seconds(error) else "rel"
    asked = list(dict.fromkeys([error, "stick_error_rel_max" if unit == "rel" else "stick_error_max"]))
    has = {m: m in rows and np.isfinite(pd.to_numeric(rows[m], errors="coerce")).any() for m in {*asked, *FALLBACK[unit]}}
    chosen, missing = [m for m in asked if has[m]], [m for m in asked if not has[m]]
    reasons: dict[str, list[str]] = {}  # metrics that share a reason get one sentence
    for m in missing:
        reasons.setdefault(_reason(rows, m), []).append(m)
    notes = [why_empty(rows, ms) for ms in reasons.values()]
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


def in_seconds(metric: str) -> bool:
    """Whether ``metric`` is a time error [s] (else dimensionless: relative, restitution)."""
    return metric in FALLBACK["s"] or metric == "stick_error_plate_max"


def measured_reference_cost(rows: pd.DataFrame) -> float | None:
    """Median of the rows' ``reference_cost_per_sim_s`` [s per simulated s]; None when not measured."""
    if "reference_cost_per_sim_s" not in rows:
        return None
    cost = pd.to_numeric(rows["reference_cost_per_sim_s"], errors="coerce")
    cost = cost[np.isfinite(cost) & (cost > 0)]
    return float(cost.median()) if len(cost) else None
