"""Synthetic engine trajectories built from the exact reference: the reference's flights between
impacts whose rebound a chosen law sets, sampled like an engine (known answers for the judge).

    >>> from chatterbench.reference.scene import load_scene
    >>> from synthetic import SCENES, run_law
    >>> scene = load_scene(SCENES / "ball-07.toml")
    >>> run = run_law(scene, lambda c: scene.restitution * c.v_minus)   # Newton's law: the exact reference
    >>> bool(abs(run.log.loc[run.log.kind == "stick", "t"].iloc[0] - 1.809227) < 1e-5)
    True

Every flight is the reference's own (``simulate`` from the state after the impact, its first
event), so only the rebounds differ from the exact answer; a ladder whose flights fall below
``ACCUMULATE`` is summed to its accumulation point geometrically (exact for a constant y''),
where the bodies stick until the reference's own exit.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from chatterbench.comparisons.pipeline.extract import free_relative_acceleration
from chatterbench.comparisons.pipeline.sampling import reference_trajectory
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.log import episodes, log_frame
from chatterbench.reference.scene import Scene
from chatterbench.reference.scene_parts import Initial
from chatterbench.reference.simulate import Options, Result, simulate

SCENES = Path(__file__).parent / "scenes"
ACCUMULATE = 1e-7  # [s] a rebound whose flight is shorter ends the ladder at its accumulation point


class Strike(NamedTuple):
    """What a law sees at an impact: time [s], wall, incoming normal speed [m/s] (> 0), the free
    motion's pressing |y''| [m/s^2] (> 0 into the wall), the impact's index in its visit, the flight before it [s]."""

    t: float
    wall: str
    v_minus: float
    pressing: float
    k: int
    flight_before: float


def _first_event(scene: Scene, t, x1, v1, y, vy):
    """The exact reference's first event from this state (a log row), or None when the run ends first."""
    s = dataclasses.replace(scene, initial=Initial(t=t, x1=x1, v1=v1, y=y, vy=vy), duration=scene.t_end - t)
    log = simulate(s, options=Options(chatter="exhaustive", max_events=3)).log
    return log.iloc[0] if len(log) else None, log


def run_law(scene: Scene, law: Callable[[Strike], float], after_stick: Callable[[Strike], float] | None = None) -> Result:
    """The exact reference of ``scene`` with every rebound's normal speed [m/s] from ``law`` (0: no rebound).

    ``after_stick``, given, is asked at each accumulation point instead of sticking: a rebound
    speed > 0 starts a bounce there (the engine's micro-bounces), 0 sticks.
    """
    share = 0.0 if math.isinf(scene.mass1) else scene.mass2 / (scene.mass1 + scene.mass2)
    rows = []
    t, x1, v1, y, vy = (scene.initial.t, scene.initial.x1, scene.initial.v1, scene.initial.y, scene.initial.vy)
    k, wall_prev, t_prev = 0, "", math.nan
    while True:
        ev, log = _first_event(scene, t, x1, v1, y, vy)
        if ev is None:
            break
        wall = ev["wall"]
        n = 1.0 if wall == "lower" else -1.0
        y_wall = scene.gap.position(wall)
        if ev["kind"] != "impact" or ev["v_minus"] == 0.0:  # resting on the wall: the reference's stick and exit
            rest = log[log["kind"].isin(["stick", "exit"])]
            exits = rest.index[rest["kind"] == "exit"]
            if not len(rest) or not len(exits):
                break
            ex = rest.loc[exits[0]]
            rows.append(tuple(ex[c] for c in ("t", "kind", "wall", "v_minus", "v_plus", "x1", "v1", "rule")))
            t, x1, v1, y, vy = float(ex["t"]), float(ex["x1"]), float(ex["v1"]), y_wall, 0.0
            k, wall_prev = 0, ""
            continue
        t_i, vy_in = float(ev["t"]), float(ev["v_minus"])
        v1_in = float(ev["v1"]) - share * (1.0 + scene.restitution) * vy_in  # undo the reference's own impact law
        x1_i = float(ev["x1"])
        k = k + 1 if wall == wall_prev else 0
        a = float(free_relative_acceleration(scene, np.array([t_i]), np.array([x1_i]), np.array([v1_in]),
                                             np.array([y_wall]), np.array([vy_in]))[0])
        pressing = -n * a
        strike = Strike(t_i, wall, abs(vy_in), pressing, k, t_i - t_prev if wall == wall_prev else math.inf)
        v_out = float(law(strike))
        flight = 2.0 * v_out / pressing if pressing > 0 else math.inf
        if pressing > 0 and flight < ACCUMULATE:  # the ladder's tail, summed: v_out / v_in is its ratio
            ratio = v_out / abs(vy_in) if abs(vy_in) > 0 else 0.0
            t_z = t_i + (flight / (1.0 - ratio) if ratio < 1 else 0.0)
            v1_z = v1_in - share * vy_in  # plastic: the bodies move together
            bounce = float(after_stick(strike._replace(t=t_z))) if after_stick else 0.0
            if bounce > 0:
                rows.append((t_z, "impact", wall, 0.0, n * bounce, x1_i, v1_z - share * n * bounce, ""))
                t, x1, v1, y, vy = t_z, x1_i, v1_z - share * n * bounce, y_wall, n * bounce
                wall_prev, t_prev = wall, t_z
                continue
            rows.append((t_z, "stick", wall, 0.0, 0.0, x1_i, v1_z, "zeno"))
            t, x1, v1, y, vy = t_z, x1_i, v1_z, y_wall, 0.0
            continue
        vy_out = n * v_out
        v1_out = v1_in + share * (vy_in - vy_out)  # momentum: m1 v1 + m2 (v1 + vy) conserved
        rows.append((t_i, "impact", wall, vy_in, vy_out, x1_i, v1_out, ""))
        t, x1, v1, y, vy = t_i, x1_i, v1_out, y_wall, vy_out
        wall_prev, t_prev = wall, t_i
    log = log_frame(rows)
    return Result(scene=scene, options=Options(chatter="exhaustive"), log=log, episodes=episodes(log),
                  final=(scene.t_end, x1, v1, y, vy))


def sampled(run: Result, dt: float, forces: bool = True) -> Trajectory:
    """``run`` sampled every ``dt`` [s] like an engine (``reference_trajectory``); without ``forces``
    the contact flags and forces are left out (an engine that reports positions and velocities only)."""
    traj = reference_trajectory(run.scene, dt, run)
    return traj if forces else dataclasses.replace(traj, contact={}, normal_force={})
