"""The reference solution a judge needs: both chatter modes, the visits with their physical scales, and bounds.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> ref = solve(load_scene("feigin-pair"))
    >>> ref.episodes[["wall", "chatter_duration", "sliding_duration"]].iloc[:2].round(4).values.tolist()
    [['lower', 0.791, 1.4968], ['upper', 1.1467, 0.9112]]

``solve`` runs Feigin's model twice (``feigin``: plate entry and exit, the idealised
model; ``exhaustive``: every impact up to the Zeno point) and joins their episodes visit
by visit. Each visit gets its scales (``tolerances.py``): chatter duration (Zeno point -
first impact), sliding duration (exit - Zeno point), first impact speed, and the time scale
its sticking is judged against (``stick_scale``: the chatter duration, or the sliding
duration for a visit that starts in contact). Run-wide: the largest relative kinetic energy
(the divergence alarm), the fastest strike, and the length scale of penetration (the gap
width; for a one-sided gap the largest distance from the wall the reference reaches).

Promises: ``solve`` refuses (SceneError) a scene whose reference stops before its end (the
engines are never judged against an unfinished reference) or moves faster than light (``SPEED_OF_LIGHT``: the
impact law has no meaning there, and the energy's square would overflow); its exhaustive impacts are kept
(``impacts``) so that individual impacts can be judged.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from chatterbench.reference.dense import Motion, sample
from chatterbench.reference.push import fastest_push
from chatterbench.reference.errors import SPEED_OF_LIGHT
from chatterbench.reference.scene import Scene, SceneError
from chatterbench.reference.simulate import Result, simulate

EPISODE_COLUMNS = [
    "wall", "t_first_impact", "t_plate_entry", "t_stick", "t_stick_feigin", "t_exit", "n_impacts", "stick_rule",
    "chatter_duration", "sliding_duration", "v_first_impact", "stick_scale",
]
DENSE_PER_TIME_SCALE = 200  # samples per scene time scale for the energy and length maxima (smooth maxima: < 2e-4 low)


def overlaps(a0: float, a1: float, b0: float, b1: float) -> float:
    """Length of the overlap of [a0, a1] and [b0, b1] (NaN ends are open: +inf) [s]; < 0 when disjoint."""
    a1 = math.inf if math.isnan(a1) else a1
    b1 = math.inf if math.isnan(b1) else b1
    return min(a1, b1) - max(a0, b0)


@dataclass(frozen=True)
class ReferenceSolution:
    """Feigin's model on one scene, ready to judge engines against (module docstring)."""

    scene: Scene
    feigin: Result
    exhaustive: Result
    episodes: pd.DataFrame  # EPISODE_COLUMNS, one row per visit that ends stuck
    energy_max: float  # [J] largest relative kinetic energy along the run
    v_max: float  # [m/s] fastest strike
    length_scale: float  # [m] gap width, or the largest distance from a one-sided gap's wall
    wall_time: float  # [s] both runs
    feigin_wall_time: float  # [s] Feigin's model alone: the reference's own cost

    @functools.cached_property
    def motion(self) -> Motion:
        """The exhaustive run's exact motion, ready to sample at any times (``reference.dense.Motion``); made once."""
        return Motion(self.scene, self.exhaustive.log)

    @functools.cached_property
    def impacts(self) -> pd.DataFrame:
        """Every impact of the exhaustive run (log rows of kind ``impact``); found once (a judge asks per visit)."""
        log = self.exhaustive.log
        return log[log["kind"] == "impact"]

    def visit_impacts(self, episode) -> pd.DataFrame:
        """The exhaustive impacts of one visit (an ``episodes`` row): its wall, first impact to Zeno point. Found once
        per visit and kept (every judge of every run asks for them): read it, never change it."""
        key = (episode.wall, float(episode.t_first_impact), float(episode.t_stick))
        if key not in self._visits:
            imp = self.impacts
            self._visits[key] = imp[(imp["wall"] == episode.wall) & (imp["t"] >= episode.t_first_impact)
                                    & (imp["t"] <= episode.t_stick)]
        return self._visits[key]

    @functools.cached_property
    def _visits(self) -> dict[tuple, pd.DataFrame]:
        return {}

    @property
    def cost_per_sim_s(self) -> float:
        """Wall-clock seconds of Feigin's model per simulated second."""
        return self.feigin_wall_time / self.scene.duration

    def stick_tolerance(self, fraction: float) -> float:
        """The tightest sticking tolerance over the visits [s]: ``fraction`` x the smallest stick scale > 0
        (NaN when there is no visit)."""
        scales = self.episodes["stick_scale"].to_numpy(dtype=float)
        scales = scales[np.isfinite(scales) & (scales > 0)]
        return fraction * float(scales.min()) if len(scales) else math.nan


def _join(feigin: pd.DataFrame, exhaustive: pd.DataFrame, impacts: pd.DataFrame) -> pd.DataFrame:
    """Exhaustive visits with Feigin's plate entry and stick of the same visit (same wall, overlapping)."""
    rows = []
    for ep in exhaustive.itertuples():
        best, best_overlap = None, -math.inf
        for f in feigin.itertuples():
            if f.wall != ep.wall:
                continue
            o = overlaps(f.t_stick, f.t_exit, ep.t_first_impact, ep.t_exit)
            if o >= 0 and o > best_overlap:
                best, best_overlap = f, o
        plate = ep.t_plate_entry
        if best is not None and not math.isnan(best.t_plate_entry):
            plate = best.t_plate_entry
        first = impacts[(impacts["wall"] == ep.wall) & (impacts["t"] == ep.t_first_impact)]
        v1 = float(abs(first["v_minus"].iloc[0])) if len(first) else 0.0
        chatter = float(ep.t_stick - ep.t_first_impact) if not math.isnan(ep.t_first_impact) else 0.0
        sliding = float(ep.t_exit - ep.t_stick)
        stick_scale = chatter if chatter > 0 else sliding
        rows.append({
            "wall": ep.wall, "t_first_impact": ep.t_first_impact if not math.isnan(ep.t_first_impact) else ep.t_stick,
            "t_plate_entry": plate, "t_stick": ep.t_stick, "t_stick_feigin": math.nan if best is None else best.t_stick,
            "t_exit": ep.t_exit, "n_impacts": int(ep.n_impacts), "stick_rule": ep.stick_rule,
            "chatter_duration": chatter, "sliding_duration": sliding, "v_first_impact": v1, "stick_scale": stick_scale,
        })
    return pd.DataFrame(rows, columns=EPISODE_COLUMNS)


def reduced_mass(scene: Scene) -> float:
    """m1 m2 / (m1 + m2) [kg] (m2 when body 1 is infinitely heavy): the mass of the relative motion."""
    return scene.mass2 if scene.body1_infinite else scene.mass1 * scene.mass2 / (scene.mass1 + scene.mass2)


def _dense_maxima(scene: Scene, result: Result) -> tuple[float, float]:
    """(largest |vy| [m/s], largest distance from the lower wall [m]) over the impacts and dense samples."""
    n = max(1001, int(math.ceil(DENSE_PER_TIME_SCALE * scene.duration / scene.time_scale)) + 1)
    dense = sample(scene, result.log, np.linspace(scene.initial.t, scene.t_end, n))
    log = result.log
    v = np.concatenate(([scene.initial.vy], log["v_minus"].to_numpy(), log["v_plus"].to_numpy(), dense["vy"].to_numpy()))
    y = np.concatenate(([scene.initial.y], dense["y"].to_numpy()))
    return float(np.max(np.abs(v))), float(np.max(np.abs(y - scene.gap.lower)))


def solve(scene: Scene) -> ReferenceSolution:
    """Run the reference in both chatter modes and prepare it for judging (module docstring)."""
    start = time.perf_counter()
    feigin = simulate(scene, "feigin")
    feigin_time = time.perf_counter() - start
    exhaustive = simulate(scene, "exhaustive")
    wall = time.perf_counter() - start
    for run in (feigin, exhaustive):
        if run.status != "ok":
            raise SceneError(f"scene {scene.name!r}: the reference run stopped ({run.status}, "
                             f"{run.options.chatter} mode): {run.message}")
    impacts = exhaustive.log[exhaustive.log["kind"] == "impact"]
    episodes = _join(feigin.episodes, exhaustive.episodes, impacts)
    v_dense, reach = _dense_maxima(scene, exhaustive)
    if not v_dense < SPEED_OF_LIGHT:  # also keeps v_dense**2 below: a float's square overflows past 1.3e154
        push, acceleration = fastest_push(scene)
        raise SceneError(f"scene {scene.name!r}: the reference's |y'| reaches {v_dense:.3g} m/s, faster than light "
                         f"(speeds must stay below c = {SPEED_OF_LIGHT:.0f} m/s: Newton's impact law has no meaning past "
                         f"it); the hardest push is {push}, {acceleration:.3g} m/s^2 on y: make it smaller")
    strikes = impacts["v_minus"].abs()
    v_max = float(strikes.max()) if len(strikes) else abs(scene.initial.vy)
    gap = scene.gap
    length = (gap.upper - gap.lower) if gap.upper is not None else reach
    return ReferenceSolution(
        scene=scene, feigin=feigin, exhaustive=exhaustive, episodes=episodes,
        energy_max=0.5 * reduced_mass(scene) * v_dense**2, v_max=v_max,
        length_scale=length if length > 0 else math.nan, wall_time=wall, feigin_wall_time=feigin_time,
    )
