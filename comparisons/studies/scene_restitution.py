"""Effective restitution under the scene's own forces, at the speeds the scene reaches: strikes at each reference impact.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.scene_restitution import scene_restitution, miss_summary
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> from chatterbench.engines.registry import make_settings
    >>> strikes = scene_restitution("pybullet", make_settings("pybullet", dt=1e-4), solve(load_scene("bouncing-ball")))
    >>> misses = miss_summary(strikes, 0.05)      # the ball's impacts 1..9, 4.43 m/s down to 0.0173 m/s, 10 strikes each
    >>> sorted(set(misses.held["impact"])), round(misses.value, 3)   # where the judge holds it to R: Newton's law, and
    ([1, 2, 3, 4, 5, 6, 7], 0.021)
    >>> # gravity over the part of the impulse's step after the contact: R (1 +- g dt / v), 2.1% at 0.069 m/s

``restitution_curve`` strikes the scene's bodies with no force at all (the contact law
alone) or under a constant gravity. The scene's own forces are what a user's model has:
under gravity a soft contact spends part of its rebound lifting the weight (MuJoCo's
spring-damper: e ~ R (1 - c g / (w0 v)), 0.415 to 0.447 at the ball's 0.138 m/s with dt = 3e-4 and
w0 dt = 0.1, where the force-free law gives 0.484 to 0.510); a harmonic forcing presses with a
different force at each impact. ``scene_restitution`` measures e there:

- **the scene itself, restarted from the reference** (``strike_scene``): every force and
  body 1's prescribed motion as the scene has them, from the exact reference state
  (``ReferenceSolution.motion``, exact) a few steps before the reference's impact k (``APPROACH_STEPS``
  steps and a fraction of a step, the strike that fraction of a step after a sample; at most
  ``APPROACH_SHARE`` of the flight before it, so that the body is on its way to the wall), so
  the engine strikes at the reference's speed, time and forces, with none of the run's drift;
- **at every place in a step** (``restitution_curve.strike_all``: ``STRIKES`` strikes per impact,
  aimed at (i + 1/2) / ``PHASES`` of a step after a sample and at the step's two ends, where e
  jumps): a run's impact falls anywhere in a step, and where it falls moves e; the strikes of
  every impact go to the engine together (one batch per try: MuJoCo's share one compiled model);
- **at the impacts the judge resolves** (``struck_impacts``): the reference impacts whose
  flight after them lasts ``resolved_steps`` timesteps (``pipeline/impacts.py``: the ones
  the judge pairs, on every wall and visit), ``MOST`` at most, spread over their speeds
  (``most_uncertain``: only those the judge holds to R, for a check);
- **measured as the curve is** (``restitution_curve.wall_rebound``: the judge's rule, where
  the body crosses the wall's surface, both ways); a run's impact also carries the run's
  drift, and its samples leave e uncertain by u = (1 + R) |y''| dt / (R v)
  (``sampling_uncertainty``: 8% at 0.11 m/s, dt = 3e-4); the strikes with u within the
  tolerance are those the judge holds to R.

Columns (``restitution_curve.CURVE_COLUMNS``, ``forces`` = "scene"): impact (the reference
impact's number among the scene's impacts, 1 = first, in time order), t [s] (its time),
wall, speed (its incoming speed [m/s]), phase, and the strike's measures.

``miss_summary`` says where a setting meets R at every place in a step: the slowest speed
from which every faster strike is within the tolerance, and the impacts where some are not,
with their bands (``restitution_curve.restitution_band``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import pandas as pd

from chatterbench.reference.scene import Scene, scene_from_dict

from ..pipeline.extract import free_relative_acceleration
from ..pipeline.impacts import restitution_error
from ..pipeline.solution import ReferenceSolution
from .restitution_curve import (CURVE_COLUMNS, PHASES, Target, approach_time, calibration_speed, restitution_band,
                                sampling_uncertainty, strike_all, strike_phases)

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
                 name: str = "", phase: float = 0.5) -> Scene:
    """The scene restarted from the reference's state t_a before its impact at ``t_impact`` [s] (module docstring).

    t_a = (``APPROACH_STEPS`` + ``phase``) dt (``approach_time``: the impact ``phase`` of a step after a sample), with
    fewer whole steps where that is more than ``APPROACH_SHARE`` of the flight since the event before (``t_before``
    [s]); the run lasts t_a + ``after_steps`` dt.
    """
    return strike_starts(solution, t_impact, t_before, dt, [phase], name)[phase](after_steps)


def strike_starts(solution: ReferenceSolution, t_impact: float, t_before: float, dt: float, phases: list[float],
                  name: str = "") -> dict[float, Callable[[int], Scene]]:
    """Per phase, the strike's scene as a function of its steps after the strike (``strike_scene``), the reference's
    states sampled once for all phases."""
    scene = solution.scene
    t_a = {phase: approach_time(dt, phase, APPROACH_SHARE * (t_impact - t_before)) for phase in phases}
    states = solution.motion.at([t_impact - t_a[phase] for phase in phases])  # (x1, v1, y, vy) per phase

    def start(phase: float, state: np.ndarray) -> Callable[[int], Scene]:
        x1, v1, y, vy = (float(v) for v in state)

        def make(after_steps: int) -> Scene:
            data = scene.to_dict()
            data.update(name=name or f"{scene.name}-strike", duration=t_a[phase] + after_steps * dt,
                        initial={"t": t_impact - t_a[phase], "x1": x1, "v1": v1, "y": y, "vy": vy})
            return scene_from_dict(data)
        return make

    return {phase: start(phase, states[i]) for i, phase in enumerate(phases)}


def scene_restitution(engine: str, settings: Any, solution: ReferenceSolution, resolved_steps: float = 10.0,
                      most: int = MOST, phases: int = PHASES, most_uncertain: float = math.inf) -> pd.DataFrame:
    """Strikes at ``phases`` places in a step per resolved reference impact, under the scene's own forces (module
    docstring).

    ``settings``: the engine's settings, pinned to the whole scene's run for an engine that
    makes its contact from the scene (``restitution_curve.pinned_settings``); ``resolved_steps``:
    the judge's (``Tolerances.resolved_steps``); ``most_uncertain``: strike only the impacts whose sampling
    uncertainty u is at most this (the restitution tolerance: those the judge holds to R; inf: all). Returns
    ``CURVE_COLUMNS``, one row per strike (impact and phase), by time (``restitution_band``: per impact).
    """
    scene, dt = solution.scene, float(settings.dt)
    at = strike_phases(phases)
    impacts = [imp for imp in struck_impacts(solution, dt, resolved_steps, most).itertuples()
               if sampling_uncertainty(scene.restitution, imp.pressing, dt, imp.speed) <= most_uncertain]
    targets = []
    for imp in impacts:
        name = f"{scene.name}-impact-{imp.impact}"
        starts = strike_starts(solution, imp.t, imp.t_before, dt, at, name)  # the reference sampled once for these

        def make(steps: int, phase: float, starts=starts, imp=imp, name=name) -> Scene:
            if phase not in starts:  # the ends of the step, aimed after the others
                starts.update(strike_starts(solution, imp.t, imp.t_before, dt, [phase], name))
            return starts[phase](steps)

        targets.append(Target(make, imp.wall, imp.speed))
    rows = []
    for imp, struck in zip(impacts, strike_all(engine, settings, targets, at, ends=True)):  # every impact in one batch
        for row in struck:
            rows.append({"engine": engine, "forces": "scene", "impact": int(imp.impact), "t": float(imp.t),
                         "wall": imp.wall, "speed": float(imp.speed), "restitution": scene.restitution,
                         "restitution_error": float(restitution_error(np.float64(row["restitution_effective"]),
                                                                      scene.restitution)),
                         "restitution_uncertainty": sampling_uncertainty(scene.restitution, imp.pressing, dt, imp.speed),
                         "gravity": math.nan, "dt": dt, "calibration_speed": calibration_speed(settings), **row})
    return pd.DataFrame(rows, columns=CURVE_COLUMNS)


@dataclass(frozen=True)
class Misses:
    """Where a setting's strikes meet R within a tolerance at every phase of a step (``miss_summary``); speeds [m/s],
    errors e / R - 1 [-]."""

    tolerance: float  # [-] the restitution tolerance (relative)
    strikes: pd.DataFrame  # the measured strikes (CURVE_COLUMNS, one per impact and phase), fastest first
    held: pd.DataFrame  # those the judge holds to R: sampling uncertainty u <= tolerance
    misses: pd.DataFrame  # per speed with a strike beyond the tolerance at some phase: its band (BAND_COLUMNS)
    holds_from: float  # every strike at this speed or faster, at every phase, is within the tolerance (0: all; inf: none)

    @property
    def worst(self) -> pd.Series | None:
        """The held strike (an impact at one phase) of largest |e / R - 1| (None: no strike is held)."""
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
        """The misses in words, fastest first, each over the phases of a step: "e = 0.437-0.468 (-12.6%..-6.4%) at
        0.138 m/s (impact 6), ..."; "" when none."""
        parts = [band_words(r) for _, r in self.misses.head(most).iterrows()]
        more = len(self.misses) - most
        return ", ".join(parts) + (f" and {more} more" if more > 0 else "")


def band_words(row: pd.Series) -> str:
    """One speed's strikes over the phases of a step (a ``BAND_COLUMNS`` row) as "e = 0.437-0.468 (-12.6%..-6.4%)
    at 0.138 m/s (impact 6)"; one value when they agree to the digits shown."""
    where = f" (impact {int(row['impact'])})" if pd.notna(row.get("impact", math.nan)) else ""
    R = float(row["restitution"])
    lo, hi = float(row["e_min"]), float(row["e_max"])
    e = f"{lo:.3f}" if f"{lo:.3f}" == f"{hi:.3f}" else f"{lo:.3f}-{hi:.3f}"
    err = [100 * (v / R - 1) for v in (lo, hi)]
    pct = f"{err[0]:+.1f}%" if f"{err[0]:+.1f}" == f"{err[1]:+.1f}" else f"{err[0]:+.1f}%..{err[1]:+.1f}%"
    return f"e = {e} ({pct}) at {row['speed']:.3g} m/s{where}"


def miss_summary(strikes: pd.DataFrame, tolerance: float) -> Misses:
    """The strikes of ``strikes`` (``CURVE_COLUMNS``, any number of phases per speed) measured, held to R, beyond
    ``tolerance`` at some phase, and the speed from which R holds at every phase."""
    measured = strikes[np.isfinite(strikes["restitution_error"].astype(float))].sort_values(
        "speed", ascending=False, kind="stable")
    bad = measured["restitution_error"].abs() > tolerance
    held = measured[measured["restitution_uncertainty"] <= tolerance]
    if not bad.any():
        holds = 0.0
    else:
        faster = measured[measured["speed"] > measured.loc[bad, "speed"].max()]
        holds = float(faster["speed"].min()) if len(faster) else math.inf
    band = restitution_band(measured)
    missed = band["speed"].isin(measured.loc[bad, "speed"])
    return Misses(tolerance=tolerance, strikes=measured, held=held, misses=band[missed].reset_index(drop=True),
                  holds_from=holds)
