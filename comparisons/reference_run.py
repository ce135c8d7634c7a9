"""The reference as a sampled trajectory: a ``Result`` on an engine's time grid, with contact flags and forces.

    >>> result = simulate(scene, chatter="exhaustive")
    >>> traj = reference_trajectory(scene, result, dt=1e-4)
    >>> extract_episodes(traj, scene)        # the same pipeline an engine's trajectory goes through

Samples are at t0 + k dt, k = 0..n, with t0 + n dt <= t_end. Each one is the closed-form
flow (``reference/linear.py``) from the last logged event at or before it, exactly as
``reference.dense.sample_states`` computes it (1e6 samples in about a second).

``contact[wall]`` is true where the masses move in kinematic constraint on that wall, or
y lies on the wall to ``ON_WALL_RTOL`` (relative to the size of the motion); impacts of the
exact reference take no time, so they fall between samples and raise no flag.
``normal_force[wall]`` is the constraint force while stuck, m_eff |y''_free| with
m_eff = m1 m2 / (m1 + m2) (m2 when m1 = inf): Feigin (1.4), the force that cancels the
free relative acceleration; 0 otherwise.
"""

from __future__ import annotations

import math

import numpy as np

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.dense import sample_states
from chatterbench.reference.scene import Scene, SceneError
from chatterbench.reference.simulate import Result

from .extract import free_relative_acceleration

ON_WALL_RTOL = 1e-12  # [-] |y - wall| below this times the motion's size counts as on the wall


def sample_grid(scene: Scene, dt: float) -> np.ndarray:
    """Sample times t0 + k dt [s], k = 0..n with t0 + n dt <= t_end (to rounding), shape (n + 1,)."""
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not (math.isfinite(dt) and dt > 0):
        raise SceneError(f"dt = {dt!r}: must be a finite number > 0 [s]")
    n = int(math.floor(scene.duration / dt * (1.0 + 1e-12)))
    return scene.initial.t + dt * np.arange(n + 1)


def reference_trajectory(scene: Scene, result: Result, dt: float) -> Trajectory:
    """Sample a reference ``result`` every ``dt`` [s] as a ``Trajectory`` (engine ``"reference"``).

    Arrays have shape (n + 1,) on ``sample_grid(scene, dt)``; when the reference stopped
    early (``result.status != "ok"``) the grid ends at its last event and the status and
    message are passed on.
    """
    times = sample_grid(scene, dt)
    if result.status != "ok" and len(result.log):
        times = times[times <= float(result.log["t"].iloc[-1])]
    state, stuck_y = sample_states(scene, result.log, times)
    x1, v1, y, vy = state.T
    walls = scene.gap.walls
    wall_y = {w: scene.gap.position(w) for w in walls}
    size = max([abs(v) for v in wall_y.values()] + [float(np.ptp(y)) if len(y) else 0.0, math.ulp(1.0)])
    acc = free_relative_acceleration(scene, times, x1, v1, y, vy)
    m_eff = scene.mass2 if scene.body1_infinite else scene.mass1 * scene.mass2 / (scene.mass1 + scene.mass2)
    contact, force = {}, {}
    for w in walls:
        stuck_here = stuck_y == wall_y[w]
        contact[w] = stuck_here | (np.abs(y - wall_y[w]) <= ON_WALL_RTOL * size)
        force[w] = np.where(stuck_here, m_eff * np.abs(acc), 0.0)
    return Trajectory(
        engine="reference", t=times, x1=x1, x2=x1 + y, v1=v1, v2=v1 + vy,
        contact=contact, normal_force=force, wall_time=result.wall_time,
        settings={"dt": dt, "chatter": result.options.chatter, "contact_time": 0.0},
        status=result.status, message=result.message,
    )
