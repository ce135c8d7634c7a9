"""The exact reference as a sampled trajectory on an engine's time grid, with contact flags and forces.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import compare, reference_trajectory
    >>> scene = load_scene("bouncing-ball")
    >>> traj = reference_trajectory(scene, dt=1e-3)
    >>> traj.t.shape, bool(traj.contact["lower"][-1])       # stuck on the floor at the end
    ((2001,), True)
    >>> compare(scene, engines=("mujoco",), trajectories={"mujoco": traj}).table["verdict"].tolist()  # a known answer
    ['match']

The sampled reference goes through the same extraction and judge as an engine's
trajectory, so it is the known answer every judge test starts from.

Samples are at t0 + k dt, k = 0..n, with t0 + n dt <= t_end. Each one is the closed-form
flow (``reference/linear.py``) from the last logged event at or before it, exactly as
``reference.dense.sample_states`` computes it (1e6 samples in about a second).

``contact[wall]`` is true where the masses move in kinematic constraint on that wall (the
wall's force is on); impacts of the exact reference take no time, so they fall between
samples and raise no flag, and just after an exit the bodies are free although y leaves
the wall only as (t - t_exit)^3.
``normal_force[wall]`` is the constraint force while stuck, m_eff |y''_free| with
m_eff = m1 m2 / (m1 + m2) (m2 when m1 = inf): Feigin (1.4), the force that cancels the
free relative acceleration; 0 otherwise.
"""

from __future__ import annotations


import numpy as np

from chatterbench.engines.base import sample_times
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.errors import check_number
from chatterbench.reference.dense import sample_states
from chatterbench.reference.scene import Scene, SceneError
from chatterbench.reference.simulate import Result, simulate

from .extract import free_relative_acceleration


def sample_grid(scene: Scene, dt: float) -> np.ndarray:
    """The engines' sample times (``engines.base.sample_times``: the one step-count rule) [s], shape (n + 1,)."""
    return sample_times(scene, check_number("dt", dt, lo=0.0, lo_open=True, unit=" [s]", error=SceneError))


def reference_trajectory(scene: Scene, dt: float, result: Result | None = None,
                         times: np.ndarray | None = None) -> Trajectory:
    """The exact reference sampled every ``dt`` [s] as a ``Trajectory`` (engine ``"reference"``).

    ``result`` is a reference run of ``scene`` to sample (default: ``simulate(scene,
    "exhaustive")``, every impact up to each Zeno point). Arrays have shape (n + 1,) on
    ``sample_grid(scene, dt)``, or on ``times`` [s] (increasing; any spacing) when given;
    when the reference stopped early (``result.status != "ok"``) the grid ends at its last
    event and the status and message are passed on.
    """
    if result is None:
        sample_grid(scene, dt)  # a bad dt is refused before the reference runs
        result = simulate(scene, "exhaustive")
    times = sample_grid(scene, dt) if times is None else np.asarray(times, dtype=float)
    if result.status != "ok" and len(result.log):
        times = times[times <= float(result.log["t"].iloc[-1])]
    state, stuck_y = sample_states(scene, result.log, times)
    x1, v1, y, vy = state.T
    walls = scene.gap.walls
    wall_y = {w: scene.gap.position(w) for w in walls}
    acc = free_relative_acceleration(scene, times, x1, v1, y, vy)
    m_eff = scene.mass2 if scene.body1_infinite else scene.mass1 * scene.mass2 / (scene.mass1 + scene.mass2)
    contact, force = {}, {}
    for w in walls:
        stuck_here = stuck_y == wall_y[w]
        contact[w] = stuck_here
        force[w] = np.where(stuck_here, m_eff * np.abs(acc), 0.0)
    return Trajectory(
        engine="reference", t=times, x1=x1, x2=x1 + y, v1=v1, v2=v1 + vy,
        contact=contact, normal_force=force, wall_time=result.wall_time,
        settings={"dt": dt, "chatter": result.options.chatter},
        status=result.status, message=result.message,
    )
