"""Effective restitution under the scene's own forces, at the speeds the scene reaches: one strike per reference impact.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.scene_restitution import scene_restitution, miss_summary
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> from chatterbench.engines.registry import make_settings
    >>> strikes = scene_restitution("pybullet", make_settings("pybullet", dt=1e-4), solve(load_scene("bouncing-ball")))
    >>> misses = miss_summary(strikes, 0.05)      # the ball's impacts 1..9, 4.43 m/s down to 0.0173 m/s
    >>> misses.held["impact"].tolist(), bool(abs(misses.value) < 0.01)   # where the judge holds it to R: Newton's law
    ([1, 2, 3, 4, 5, 6, 7], True)

``restitution_curve`` strikes the scene's bodies with no force at all (the contact law
alone) or under a constant gravity. The scene's own forces are what a user's model has:
under gravity a soft contact spends part of its rebound lifting the weight (MuJoCo's
spring-damper: e ~ R (1 - c g / (w0 v)), -12% at the ball's 0.11 m/s with dt = 3e-4 and
w0 dt = 0.1, where the force-free law gives R within 1%); a harmonic forcing presses with a
different force at each impact. ``scene_restitution`` measures e there:

- **the scene itself, restarted from the reference** (``strike_scene``): every force and
  body 1's prescribed motion as the scene has them, from the exact reference state
  (``reference.dense.sample``) a few steps before the reference's impact k (``APPROACH_STEPS``
  + 1/2 steps, the strike halfway through a step; at most ``APPROACH_SHARE`` of the flight
  before it, so that the body is on its way to the wall), so the engine strikes at the reference's speed, time and forces, with none of
  the run's drift;
- **at the impacts the judge resolves** (``struck_impacts``): the reference impacts whose
  flight after them lasts ``resolved_steps`` timesteps (``pipeline/impacts.py``: the ones
  the judge pairs, on every wall and visit), ``MOST`` at most, spread over their speeds;
- **measured as the curve is** (``restitution_curve.wall_rebound``: where the body crosses
  the wall's surface, both ways), from a strike placed halfway through a step: a run's
  impact falls anywhere in a step, carries the run's drift, and its samples leave e uncertain
  by u = (1 + R) |y''| dt / (R v) (``sampling_uncertainty``: 8% at 0.11 m/s, dt = 3e-4);
  the strikes with u within the tolerance are those the judge holds to R.

Columns (``restitution_curve.CURVE_COLUMNS``, ``forces`` = "scene"): impact (the reference
impact's number among the scene's impacts, 1 = first, in time order), t [s] (its time),
wall, speed (its incoming speed [m/s]), and the strike's measures.

``miss_summary`` says where a setting meets R: the slowest speed from which every faster
strike is within the tolerance, and the strikes that are not, with their numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from chatterbench.reference.dense import sample
from chatterbench.reference.scene import Scene, scene_from_dict

from ..pipeline.extract import free_relative_acceleration
from ..pipeline.impacts import restitution_error
from ..pipeline.solution import ReferenceSolution
from .restitution_curve import APPROACH_STEPS, CURVE_COLUMNS, calibration_speed, sampling_uncertainty, strike

APPROACH_SHARE = 0.4  # [-] of the flight before an impact, at most: a restart after its apex, moving towards the wall
MOST = 12  # [-] strikes per scene at most (each one short engine run), spread over the resolved impacts' speeds


def struck_impacts(solution: ReferenceSolution, dt: float, resolved_steps: float, most: int = MOST) -> pd.DataFrame:
    """The reference impacts to strike: those whose flight after them is at least ``resolved_steps`` x ``dt`` [s].

    Returns the exhaustive log's impact rows plus ``impact`` (1-based number among all of the
    scene's impacts, in time order), ``speed`` (|v_minus| [m/s]), ``pressing`` (|y''_free| at
    the impact [m/s^2]) and ``t_before`` (the time of the event before it [s], or the scene's
    start). At most ``most``: the first impact in each of ``most`` equal bins of log speed
    (the fastest and the slowest included; a scene's repeated visits strike at the same speeds).
    """
    scene = solution.scene
    log = solution.exhaustive.log
    log = log[log["kind"] != "plate_entry"].reset_index(drop=True)  # Feigin's plate entry is no event of the motion
    t = log["t"].to_numpy(dtype=float)
    imp = log[log["kind"] == "impact"].copy()
    imp["impact"] = np.arange(1, len(imp) + 1)
    imp["speed"] = imp["v_minus"].abs()
    i = imp.index.to_numpy()
    imp["t_before"] = np.where(i > 0, t[np.maximum(i - 1, 0)], scene.initial.t)
    flight = np.where(i + 1 < len(t), t[np.minimum(i + 1, len(t) - 1)], scene.t_end) - imp["t"].to_numpy(dtype=float)
    y_wall = np.array([scene.gap.position(w) for w in imp["wall"]])
    imp["pressing"] = np.abs(free_relative_acceleration(scene, imp["t"], imp["x1"], imp["v1"], y_wall, imp["v_plus"]))
    imp = imp[(flight >= resolved_steps * dt) & (imp["speed"] > 0.0)]
    if len(imp) > most:
        logv = np.log(imp["speed"].to_numpy(dtype=float))
        edges = np.linspace(logv.min(), logv.max(), most + 1)
        imp = imp.assign(bin=np.clip(np.searchsorted(edges, logv, side="right") - 1, 0, most - 1))
        imp = imp.groupby("bin", sort=False).head(1).drop(columns="bin")
    return imp.sort_values("t").reset_index(drop=True)


def strike_scene(solution: ReferenceSolution, t_impact: float, t_before: float, dt: float, after_steps: int,
                 name: str = "") -> Scene:
    """The scene restarted from the reference's state t_a before its impact at ``t_impact`` [s] (module docstring).

    t_a = (``APPROACH_STEPS`` + 1/2) dt, at most ``APPROACH_SHARE`` of the flight since the event before
    (``t_before`` [s]); the run lasts t_a + ``after_steps`` dt.
    """
    scene = solution.scene
    t_a = min((APPROACH_STEPS + 0.5) * dt, APPROACH_SHARE * (t_impact - t_before))
    t0 = t_impact - t_a
    state = sample(scene, solution.exhaustive.log, [t0]).iloc[0]
    data = scene.to_dict()
    data.update(name=name or f"{scene.name}-strike", duration=t_a + after_steps * dt,
                initial={"t": t0, "x1": float(state["x1"]), "v1": float(state["v1"]), "y": float(state["y"]),
                         "vy": float(state["vy"])})
    return scene_from_dict(data)


def scene_restitution(engine: str, settings: Any, solution: ReferenceSolution, resolved_steps: float = 10.0,
                      most: int = MOST) -> pd.DataFrame:
    """One strike per resolved reference impact, under the scene's own forces (module docstring).

    ``settings``: the engine's settings, pinned to the whole scene's run for an engine that
    makes its contact from the scene (``restitution_curve.pinned_settings``); ``resolved_steps``:
    the judge's (``Tolerances.resolved_steps``). Returns ``CURVE_COLUMNS``, one row per strike, by time.
    """
    scene, dt = solution.scene, float(settings.dt)
    rows = []
    for imp in struck_impacts(solution, dt, resolved_steps, most).itertuples():
        row = strike(engine, settings, lambda steps, imp=imp: strike_scene(solution, imp.t, imp.t_before, dt, steps,
                                                                           f"{scene.name}-impact-{imp.impact}"),
                     imp.wall, imp.speed)
        rows.append({"engine": engine, "forces": "scene", "impact": int(imp.impact), "t": float(imp.t), "wall": imp.wall,
                     "speed": float(imp.speed), "restitution": scene.restitution,
                     "restitution_error": float(restitution_error(np.float64(row["restitution_effective"]), scene.restitution)),
                     "restitution_uncertainty": sampling_uncertainty(scene.restitution, imp.pressing, dt, imp.speed),
                     "gravity": math.nan, "dt": dt, "calibration_speed": calibration_speed(settings), **row})
    return pd.DataFrame(rows, columns=CURVE_COLUMNS)


@dataclass(frozen=True)
class Misses:
    """Where a setting's strikes meet R within a tolerance (``miss_summary``); speeds [m/s], errors e / R - 1 [-]."""

    tolerance: float  # [-] the restitution tolerance (relative)
    strikes: pd.DataFrame  # the measured strikes (CURVE_COLUMNS), fastest first
    held: pd.DataFrame  # those the judge holds to R: sampling uncertainty u <= tolerance
    misses: pd.DataFrame  # the strikes beyond the tolerance, held or not, fastest first
    holds_from: float  # every strike at this speed or faster is within the tolerance (0: all are; inf: none)

    @property
    def worst(self) -> pd.Series | None:
        """The held strike of largest |e / R - 1| (None: no strike is held)."""
        return self.held.loc[self.held["restitution_error"].abs().idxmax()] if len(self.held) else None

    @property
    def value(self) -> float:
        """The signed error of ``worst``; NaN without one."""
        return math.nan if self.worst is None else float(self.worst["restitution_error"])

    @property
    def speed(self) -> float:
        """The speed of ``worst`` [m/s]; NaN without one."""
        return math.nan if self.worst is None else float(self.worst["speed"])

    @property
    def held_from(self) -> float:
        """The slowest held strike's speed [m/s] (inf: none is held)."""
        return float(self.held["speed"].min()) if len(self.held) else math.inf

    def describe(self, most: int = 4) -> str:
        """The misses in words, fastest first: "e = 0.455 (-9.1%) at 0.277 m/s (impact 5), ..."; "" when none."""
        parts = [strike_words(r) for _, r in self.misses.head(most).iterrows()]
        more = len(self.misses) - most
        return ", ".join(parts) + (f" and {more} more" if more > 0 else "")


def strike_words(row: pd.Series) -> str:
    """One strike as "e = 0.437 (-12.5%) at 0.138 m/s (impact 6)"."""
    where = f" (impact {int(row['impact'])})" if pd.notna(row.get("impact", math.nan)) else ""
    return f"e = {row['restitution_effective']:.3f} ({100 * row['restitution_error']:+.1f}%) at {row['speed']:.3g} m/s{where}"


def miss_summary(strikes: pd.DataFrame, tolerance: float) -> Misses:
    """The strikes of ``strikes`` (``CURVE_COLUMNS``) measured, held to R, beyond ``tolerance``, and where R holds."""
    measured = strikes[np.isfinite(strikes["restitution_error"].astype(float))].sort_values(
        "speed", ascending=False, kind="stable")
    bad = measured["restitution_error"].abs() > tolerance
    held = measured[measured["restitution_uncertainty"] <= tolerance]
    if not bad.any():
        holds = 0.0
    else:
        faster = measured[measured["speed"] > measured.loc[bad, "speed"].max()]
        holds = float(faster["speed"].min()) if len(faster) else math.inf
    return Misses(tolerance=tolerance, strikes=measured, held=held, misses=measured[bad], holds_from=holds)
