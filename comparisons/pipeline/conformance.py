"""Conformance of two engines that run the same model: where their chatter verdicts and times part, and by how much.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.conformance import conformance
    >>> from chatterbench.comparisons import compare, reference_trajectory
    >>> scene = load_scene("bouncing-ball")
    >>> exact = reference_trajectory(scene, dt=1e-3)
    >>> result = compare(scene, engines=("mujoco", "pybullet"), trajectories={"mujoco": exact, "pybullet": exact})
    >>> table = conformance(result, "mujoco", "pybullet")
    >>> table[["wall", "verdict", "other_verdict", "stick_difference", "disagree"]].values.tolist()
    [['lower', 'match', 'match', 0.0, False]]

Two engines run the same model when one's adapter says so (``EngineAdapter.same_model_as``):
MuJoCo C (float64) and MuJoCo Warp (float32) step the same ``MjSpec`` model, so any
difference between them is the executor's, not the model's (``same_model_pairs``). ``conformance`` pairs the two
engines' judged episodes of one ``compare`` (the rows of ``compare.Comparison.table`` for the
same reference visit: same wall, same reference first impact) and reports, episode by
episode, the second engine (``other``) against the first (``engine``): both verdicts, the
differences of sticking start, exit and first impact (other - engine, in seconds, as a
fraction of the visit's chatter or sliding duration, and in timesteps), and of the impact
counts. An episode only one engine has (a spurious sticking) is a row with the other
engine's values missing. ``parting`` says where the two trajectories part (the first
sample where the gap coordinates differ by more than a fraction of the scene's length scale).

Columns (``CONFORMANCE_COLUMNS``): ``engine``, ``other``, ``wall``, ``ref_t_first_impact``
[s] (the visit; NaN for an engine-only episode), ``verdict``, ``other_verdict``, ``t_stick``,
``other_t_stick``, ``stick_difference`` [s], ``stick_difference_rel`` [-],
``stick_difference_steps`` [-], ``t_exit``, ``other_t_exit``, ``exit_difference`` [s],
``exit_difference_rel`` [-], ``first_impact_difference`` [s], ``n_impacts``,
``other_n_impacts``, ``impact_count_difference``, ``resolved_impacts``,
``other_resolved_impacts``, ``disagree``.

Promise: ``disagree`` is True where the judge would tell the two apart: the verdicts differ,
the sticking starts or the exits differ by more than the judge's own tolerance for that
visit (``Tolerances.stick`` of the chatter duration, ``Tolerances.exit`` of the sliding
duration), or the resolved impacts differ by more than ``Tolerances.impact_count``; two
identical runs never disagree, and nothing here says two runs agree where their numbers differ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from chatterbench.engines.registry import ENGINE_NAMES, adapter, unavailable_reason

from .tolerances import Tolerances

CONFORMANCE_COLUMNS = [
    "engine", "other", "wall", "ref_t_first_impact", "verdict", "other_verdict", "t_stick", "other_t_stick",
    "stick_difference", "stick_difference_rel", "stick_difference_steps", "t_exit", "other_t_exit", "exit_difference",
    "exit_difference_rel", "first_impact_difference", "n_impacts", "other_n_impacts", "impact_count_difference",
    "resolved_impacts", "other_resolved_impacts", "disagree",
]
PARTING_FRACTION = 0.01  # [-] trajectories part where |y - y_other| passes 1% of the length scale


def _keyed(table: pd.DataFrame) -> dict[tuple, pd.Series]:
    """Rows by visit: (wall, reference first impact), or (wall, "only", engine first impact) for engine-only rows."""
    out = {}
    for _, row in table.iterrows():
        ref = row["ref_t_first_impact"]
        key = (row["wall"], float(ref)) if pd.notna(ref) else (row["wall"], "only", float(row["t_first_impact"]))
        out[key] = row
    return out


def _num(row: pd.Series | None, col: str) -> float:
    return float(row[col]) if row is not None and pd.notna(row[col]) else math.nan


def _row(engine: str, other: str, key: tuple, a: pd.Series | None, b: pd.Series | None, dt: float,
         tol: Tolerances) -> dict:
    """One paired episode (``a``: engine, ``b``: other; either may be None)."""
    both = a if a is not None else b
    chatter, sliding = _num(both, "chatter_duration"), _num(both, "sliding_duration")
    d_stick = _num(b, "t_stick") - _num(a, "t_stick")
    d_exit = _num(b, "t_exit") - _num(a, "t_exit")
    d_resolved = _num(b, "resolved_impacts") - _num(a, "resolved_impacts")
    verdict = a["verdict"] if a is not None else ""
    other_verdict = b["verdict"] if b is not None else ""
    stuck = [pd.notna(r["t_stick"]) if r is not None else False for r in (a, b)]
    exited = [pd.notna(r["t_exit"]) if r is not None else False for r in (a, b)]
    disagree = (verdict != other_verdict or stuck[0] != stuck[1] or exited[0] != exited[1]
                or abs(d_stick) > tol.stick * chatter or abs(d_exit) > tol.exit * sliding
                or abs(d_resolved) > tol.impact_count)
    return {
        "engine": engine, "other": other, "wall": key[0], "ref_t_first_impact": _num(both, "ref_t_first_impact"),
        "verdict": verdict, "other_verdict": other_verdict,
        "t_stick": _num(a, "t_stick"), "other_t_stick": _num(b, "t_stick"), "stick_difference": d_stick,
        "stick_difference_rel": d_stick / chatter if chatter > 0 else math.nan, "stick_difference_steps": d_stick / dt,
        "t_exit": _num(a, "t_exit"), "other_t_exit": _num(b, "t_exit"), "exit_difference": d_exit,
        "exit_difference_rel": d_exit / sliding if sliding > 0 else math.nan,
        "first_impact_difference": _num(b, "t_first_impact") - _num(a, "t_first_impact"),
        "n_impacts": _num(a, "n_impacts"), "other_n_impacts": _num(b, "n_impacts"),
        "impact_count_difference": _num(b, "n_impacts") - _num(a, "n_impacts"),
        "resolved_impacts": _num(a, "resolved_impacts"), "other_resolved_impacts": _num(b, "resolved_impacts"),
        "disagree": bool(disagree),
    }


def _pair(comparison, engine: str | None, other: str | None) -> tuple[str, str]:
    """The two engines named, or by default the comparison's first pair that runs one model (``same_model_pairs``)."""
    if engine is not None and other is not None:
        return engine, other
    pairs = same_model_pairs(comparison.runs)
    if not pairs:
        raise KeyError(f"no two engines of this comparison ({', '.join(comparison.runs)}) run one model; name the two")
    return pairs[0]


def conformance(comparison, engine: str | None = None, other: str | None = None) -> pd.DataFrame:
    """``other`` against ``engine``, episode by episode, in one ``compare.Comparison`` (``CONFORMANCE_COLUMNS``).

    Default pair: the comparison's engines that run one model (``same_model_pairs``: MuJoCo, MuJoCo Warp).
    Rows follow the reference's visits in time, then the episodes only one engine has.
    Raises KeyError when either engine is not in the comparison.
    """
    engine, other = _pair(comparison, engine, other)
    tables = {name: comparison.table[comparison.table["engine"] == name] for name in (engine, other)}
    for name in (engine, other):
        if name not in comparison.runs:
            raise KeyError(f"engine {name!r} is not in this comparison ({', '.join(comparison.runs)})")
    dt = comparison.runs[other].trajectory.dt
    a, b = _keyed(tables[engine]), _keyed(tables[other])
    keys = sorted(set(a) | set(b), key=lambda k: (len(k), k[-1], k[0]))
    rows = [_row(engine, other, k, a.get(k), b.get(k), dt, comparison.tolerances) for k in keys]
    return pd.DataFrame(rows, columns=CONFORMANCE_COLUMNS)


@dataclass(frozen=True)
class Parting:
    """Where two trajectories of one scene part: first time past the threshold, and the largest difference."""

    t_part: float  # [s] first common sample with |y - y_other| > threshold; NaN if never
    threshold: float  # [m]
    y_difference_max: float  # [m] max |y - y_other| over the common samples
    vy_difference_max: float  # [m/s] max |vy - vy_other|


def parting(comparison, engine: str | None = None, other: str | None = None, fraction: float = PARTING_FRACTION) -> Parting:
    """Where the gap coordinates of ``engine`` and ``other`` (default: as ``conformance``) first differ by more
    than ``fraction`` of the scene's length scale (both sampled at the same times: same dt; else NaN throughout)."""
    engine, other = _pair(comparison, engine, other)
    ta, tb = comparison.runs[engine].trajectory, comparison.runs[other].trajectory
    threshold = fraction * comparison.solution.length_scale
    n = min(len(ta.t), len(tb.t))
    if n == 0 or not np.allclose(ta.t[:n], tb.t[:n], rtol=0.0, atol=1e-9 * max(1.0, abs(float(ta.t[n - 1])))):
        return Parting(math.nan, threshold, math.nan, math.nan)
    dy = np.abs(ta.y[:n] - tb.y[:n])
    dv = np.abs(ta.vy[:n] - tb.vy[:n])
    beyond = dy > threshold
    return Parting(float(ta.t[np.argmax(beyond)]) if beyond.any() else math.nan, threshold,
                   float(np.nanmax(dy)), float(np.nanmax(dv)))


def same_model_pairs(engines) -> list[tuple[str, str]]:
    """(engine, other) for each of ``engines`` whose adapter runs the model of another of them
    (``EngineAdapter.same_model_as``: MuJoCo Warp runs MuJoCo's): compare reports their conformance."""
    return [(first, other) for other in engines if (first := _same_model_as(other)) and first in engines]


def _same_model_as(name: str) -> str:
    """The engine whose model ``name``'s adapter runs ("" when none, or when ``name`` cannot be loaded here)."""
    if name not in ENGINE_NAMES or unavailable_reason(name):
        return ""
    return adapter(name).same_model_as


def describe(comparison, engine: str | None = None, other: str | None = None) -> str:
    """One paragraph: how many episodes the two disagree on, the largest differences, where the trajectories part."""
    engine, other = _pair(comparison, engine, other)
    table = conformance(comparison, engine, other)
    part = parting(comparison, engine, other)
    n, bad = len(table), int(table["disagree"].sum())
    changed = table[table["verdict"] != table["other_verdict"]]
    verdicts = "; ".join(f"{r.wall} visit at {r.ref_t_first_impact:.4g} s: {r.verdict or '-'} -> {r.other_verdict or '-'}"
                         for r in changed.itertuples())

    def worst(col: str) -> float:
        vals = table[col].abs().dropna()
        return float(vals.max()) if len(vals) else math.nan

    one_sticks = int((table["t_stick"].isna() != table["other_t_stick"].isna()).sum())
    where = (f"their gap coordinates part (differ by > {part.threshold:.3g} m) at t = {part.t_part:.6g} s"
             if not math.isnan(part.t_part) else f"their gap coordinates never differ by > {part.threshold:.3g} m")
    return (f"{other} against {engine}: {bad} of {n} episodes disagree"
            + (f" (verdicts: {verdicts})" if verdicts else "")
            + (f"; {one_sticks} sticking in one engine only" if one_sticks else "")
            + f"; largest |sticking difference| {_g(worst('stick_difference'), 's', 'no episode sticks in both')}"
            + (f" ({_g(worst('stick_difference_rel'))} of the chatter)" if not math.isnan(worst('stick_difference_rel')) else "")
            + f", |exit difference| {_g(worst('exit_difference'), 's', 'no episode exits in both')}, |impact count "
            f"difference| {_g(worst('impact_count_difference'))}; {where}; max |y difference| "
            f"{_g(part.y_difference_max, 'm')}, max |vy difference| {_g(part.vy_difference_max, 'm/s')}.")


def _g(x: float, unit: str = "", none: str = "") -> str:
    """A quantity for a sentence: 3 significant digits and its unit; NaN (nothing to compare) is "none", with
    ``none`` saying why, and no unit."""
    if math.isnan(x):
        return f"none ({none})" if none else "none"
    return f"{x:.3g}" + (f" {unit}" if unit else "")
