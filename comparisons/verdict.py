"""Pair engine episodes with the reference's and judge each pair: the suite's verdicts.

    >>> ref = reference_episodes(simulate(scene, "feigin"), simulate(scene, "exhaustive"), scene)
    >>> table = judge(scene, ref, engine_episodes, engine_log, tol=Tolerances())
    >>> table[["wall", "verdict", "exit_error"]]

Pairing: an engine episode belongs to the reference episode on the same wall whose
sticking start is nearest, within half a forcing period (the "same wall and forcing
period"). Per pair, errors are engine minus reference [s]:

- ``first_impact_error``: first impact of the visit;
- ``stick_error_plate``: sticking start against Feigin's plate entry (the idealised model);
- ``stick_error_zeno``: sticking start against the true accumulation (Zeno) point;
- ``exit_error``: separation time;
- ``impact_count_error``: impacts of the visit (engine minus exhaustive reference).

Verdicts, first that applies:

=============  ===============================================================================
diverged       the engine state went non-finite, the engine failed, or the energy grew beyond
               ``energy_gain`` (relative) during the run; pairs from that time on
penetrated     |y| left the gap by more than the engine's allowed penetration during the pair
missed         the reference slides, the engine has no sticking there and few impacts
endless        the reference slides, the engine keeps chattering through the sliding stretch
               (at least ``endless_impacts`` impacts there) and never sticks
spurious       the engine sticks where the reference has no sliding
early / late   the engine's sticking starts before Feigin's entry - tolerance, or after the
               Zeno point + tolerance; or its exit is off by more than the tolerance (sign
               of the exit error decides when the start is within tolerance)
match          every error within tolerance
error/timeout  the engine raised, or ran past its time limit, before this episode's end (the
               run's status); episodes finished before that keep their verdicts
crashed        the engine process died (segfault, abort): the sweep's isolation reports it
=============  ===============================================================================

Tolerances are in units of the scene's time scale (the forcing period, see
``Scene.time_scale``) so that one set of defaults serves every scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from chatterbench.reference.scene import Scene, SceneError

VERDICTS = ("match", "early", "late", "missed", "spurious", "endless", "penetrated", "diverged", "error", "timeout", "crashed")
TABLE_COLUMNS = [
    "wall", "ref_t_first_impact", "ref_t_plate_entry", "ref_t_stick", "ref_t_exit",
    "t_first_impact", "t_stick", "t_exit", "n_impacts", "ref_n_impacts",
    "first_impact_error", "stick_error_plate", "stick_error_zeno", "exit_error", "impact_count_error", "verdict",
]


REFERENCE_COLUMNS = ["wall", "t_first_impact", "t_plate_entry", "t_stick", "t_stick_feigin", "t_exit", "n_impacts", "stick_rule"]


@dataclass(frozen=True)
class Tolerances:
    """Verdict tolerances, in units of the scene time scale (forcing period) unless noted."""

    stick: float = 0.02  # sticking start outside [plate entry - tol, Zeno + tol] is early/late
    exit: float = 0.01  # |exit error| above this is early/late
    first_impact: float = 0.01  # |first impact error| above this is early/late
    # relative growth of the relative kinetic energy past the reference's largest that means
    # diverged. Not 5%: a forced scene's engine run that follows another, bounded trajectory
    # (a spurious stick, then the forcing pumps) can exceed the reference's maximum by tens
    # of percent without any numerical trouble (measured 21%: PyBullet, feigin-pair R = 0.8,
    # velocity threshold 0.1); a blow-up passes a doubling within a few steps.
    energy_gain: float = 1.0
    endless_impacts: int = 10  # impacts inside a reference sliding stretch that make it endless

    def __post_init__(self) -> None:
        for name in ("stick", "exit", "first_impact", "energy_gain"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise SceneError(f"tolerance {name} = {v!r}: must be a finite number > 0")
        if not (isinstance(self.endless_impacts, int) and self.endless_impacts > 0):
            raise SceneError(f"tolerance endless_impacts = {self.endless_impacts!r}: must be an integer > 0")


def reference_episodes(feigin, exhaustive, scene: Scene) -> pd.DataFrame:
    """The reference's episodes with both predictions of the sliding start.

    Parameters
    ----------
    feigin, exhaustive : Result
        ``simulate(scene, "feigin")`` (plate entry, exit) and ``simulate(scene,
        "exhaustive")`` (Zeno point, impact count).

    Returns
    -------
    DataFrame with columns wall, t_first_impact, t_plate_entry, t_stick (the Zeno point),
    t_stick_feigin, t_exit, n_impacts (exhaustive), stick_rule.
    """
    fe, ex = feigin.episodes, exhaustive.episodes
    rows = []
    half = 0.5 * scene.time_scale
    for ep in ex.itertuples():
        same = fe[(fe["wall"] == ep.wall) & ((fe["t_stick"] - ep.t_stick).abs() <= half)]
        f = same.iloc[int(np.argmin(np.abs(same["t_stick"].to_numpy() - ep.t_stick)))] if len(same) else None
        plate = ep.t_plate_entry
        if f is not None and not math.isnan(f["t_plate_entry"]):
            plate = f["t_plate_entry"]
        rows.append({
            "wall": ep.wall,
            "t_first_impact": ep.t_first_impact,
            "t_plate_entry": plate,
            "t_stick": ep.t_stick,
            "t_stick_feigin": math.nan if f is None else f["t_stick"],
            "t_exit": ep.t_exit,
            "n_impacts": ep.n_impacts,
            "stick_rule": ep.stick_rule,
        })
    return pd.DataFrame(rows, columns=REFERENCE_COLUMNS)


def _energy(scene: Scene, traj) -> np.ndarray:
    """Kinetic energy of the relative motion plus work-free potential where it is defined [J].

    Used only as a divergence alarm: for a scene with time forcing the energy is not
    conserved, so the alarm compares against the largest energy the reference reaches.
    """
    m2 = scene.mass2
    if math.isinf(scene.mass1):
        return 0.5 * m2 * traj.vy**2
    m_red = scene.mass1 * m2 / (scene.mass1 + m2)
    return 0.5 * m_red * traj.vy**2


def run_failures(scene: Scene, traj, ref_energy_max: float, tol: Tolerances, penetration: float) -> tuple[float, float]:
    """(time of divergence, time of first penetration) of an engine trajectory; NaN where none.

    ``penetration`` [m] is the engine's allowed overshoot of a wall; ``ref_energy_max`` [J]
    the largest relative kinetic energy of the reference run.
    """
    t = traj.t
    y, vy = traj.y, traj.vy
    t_div = math.nan
    bad = ~(np.isfinite(y) & np.isfinite(vy))
    if traj.status == "diverged":
        t_div = float(t[-1]) if len(t) else 0.0
    if bad.any():
        t_div = float(t[np.argmax(bad)])
    with np.errstate(invalid="ignore", over="ignore"):
        e = _energy(scene, traj)
        limit = ref_energy_max * (1.0 + tol.energy_gain) + 1e-12
        grown = e > limit
    if grown.any():
        tg = float(t[np.argmax(grown)])
        t_div = tg if math.isnan(t_div) else min(t_div, tg)
    lo, hi = scene.gap.lower, scene.gap.upper
    with np.errstate(invalid="ignore"):
        out = y < lo - penetration
        if hi is not None:
            out |= y > hi + penetration
    t_pen = float(t[np.argmax(out)]) if out.any() else math.nan
    return t_div, t_pen


def judge(
    scene: Scene,
    ref: pd.DataFrame,
    eng: pd.DataFrame,
    eng_log: pd.DataFrame,
    t_diverged: float = math.nan,
    t_penetrated: float = math.nan,
    tol: Tolerances | None = None,
    t_end: float | None = None,
) -> pd.DataFrame:
    """Pair engine episodes with reference episodes and give each pair a verdict.

    Parameters
    ----------
    ref : DataFrame
        ``reference_episodes(scene)``.
    eng, eng_log : DataFrame
        The engine's episodes and event log (reference formats, from the extraction).
    t_diverged, t_penetrated : float
        From ``run_failures`` [s]; NaN when the run had no such failure.
    t_end : float, optional
        Time the engine run reached [s] (reference episodes after it are not judged).

    Returns
    -------
    DataFrame with ``TABLE_COLUMNS``, one row per reference episode and per unpaired
    engine episode, in time order.
    """
    tol = tol or Tolerances()
    T = scene.time_scale
    half = 0.5 * T
    used = set()
    rows = []
    eng_impacts = eng_log[eng_log["kind"] == "impact"]
    for r in ref.itertuples():
        if t_end is not None and r.t_first_impact > t_end:
            continue
        cands = [(abs(e.t_stick - r.t_stick), i) for i, e in enumerate(eng.itertuples()) if e.wall == r.wall and i not in used and abs(e.t_stick - r.t_stick) <= half]
        row = {
            "wall": r.wall, "ref_t_first_impact": r.t_first_impact, "ref_t_plate_entry": r.t_plate_entry,
            "ref_t_stick": r.t_stick, "ref_t_exit": r.t_exit, "ref_n_impacts": r.n_impacts,
            "t_first_impact": math.nan, "t_stick": math.nan, "t_exit": math.nan, "n_impacts": 0,
        }
        if cands:
            _, i = min(cands)
            used.add(i)
            e = eng.iloc[i]
            row.update(t_first_impact=e["t_first_impact"], t_stick=e["t_stick"], t_exit=e["t_exit"], n_impacts=int(e["n_impacts"]))
        rows.append(row)
    for i, e in enumerate(eng.itertuples()):
        if i not in used:
            rows.append({
                "wall": e.wall, "ref_t_first_impact": math.nan, "ref_t_plate_entry": math.nan, "ref_t_stick": math.nan,
                "ref_t_exit": math.nan, "ref_n_impacts": 0, "t_first_impact": e.t_first_impact, "t_stick": e.t_stick,
                "t_exit": e.t_exit, "n_impacts": int(e.n_impacts),
            })
    table = pd.DataFrame(rows, columns=[c for c in TABLE_COLUMNS if c not in (
        "first_impact_error", "stick_error_plate", "stick_error_zeno", "exit_error", "impact_count_error", "verdict")])
    table["first_impact_error"] = table["t_first_impact"] - table["ref_t_first_impact"]
    table["stick_error_plate"] = table["t_stick"] - table["ref_t_plate_entry"]
    table["stick_error_zeno"] = table["t_stick"] - table["ref_t_stick"]
    table["exit_error"] = table["t_exit"] - table["ref_t_exit"]
    table["impact_count_error"] = table["n_impacts"] - table["ref_n_impacts"]
    verdicts = []
    for r in table.itertuples():
        verdicts.append(_verdict(r, tol, T, t_diverged, t_penetrated, eng_impacts, t_end))
    table["verdict"] = verdicts
    start = table["ref_t_stick"].fillna(table["t_stick"])
    return table.assign(_order=start).sort_values("_order", kind="stable").drop(columns="_order").reset_index(drop=True)


def _verdict(r, tol: Tolerances, T: float, t_div: float, t_pen: float, eng_impacts: pd.DataFrame, t_end) -> str:
    has_ref = not math.isnan(r.ref_t_stick)
    has_eng = not math.isnan(r.t_stick)
    start = r.ref_t_first_impact if has_ref else r.t_first_impact
    if math.isnan(start):
        start = r.ref_t_stick if has_ref else r.t_stick
    stop = r.ref_t_exit if has_ref else r.t_exit
    if math.isnan(stop):
        stop = math.inf
    if not math.isnan(t_div) and t_div <= stop:
        return "diverged"
    if not math.isnan(t_pen) and t_pen <= stop:
        return "penetrated"
    if has_ref and not has_eng:
        seg_end = r.ref_t_exit if not math.isnan(r.ref_t_exit) else math.inf
        inside = eng_impacts[(eng_impacts["wall"] == r.wall) & (eng_impacts["t"] >= r.ref_t_stick) & (eng_impacts["t"] <= seg_end)]
        return "endless" if len(inside) >= tol.endless_impacts else "missed"
    if has_eng and not has_ref:
        return "spurious"
    entry = r.ref_t_plate_entry if not math.isnan(r.ref_t_plate_entry) else r.ref_t_stick
    if r.t_stick < entry - tol.stick * T:
        return "early"
    if r.t_stick > r.ref_t_stick + tol.stick * T:
        return "late"
    if not math.isnan(r.first_impact_error) and abs(r.first_impact_error) > tol.first_impact * T:
        return "early" if r.first_impact_error < 0 else "late"
    ref_exit, exit_ = r.ref_t_exit, r.t_exit
    if math.isnan(ref_exit) != math.isnan(exit_):
        # one of them is still stuck at the end of the run
        return "late" if math.isnan(exit_) else "early"
    if not math.isnan(r.exit_error) and abs(r.exit_error) > tol.exit * T:
        return "early" if r.exit_error < 0 else "late"
    return "match"
