"""What an engine run returns: sampled states, per-wall contact, and the cost of stepping.

    >>> traj = run_engine(scene, MujocoSettings(dt=1e-4))
    >>> traj.y.shape, traj.contact["lower"].dtype, traj.wall_time
    ((n,), dtype('bool'), 0.21)

Arrays all have shape ``(n,)``, one entry per sample; sample 0 is the initial state and
sample k is the state after k engine steps (``t[k] = t0 + k dt``). Units: s, m, m/s, N.
``normal_force[wall]`` is the magnitude of the wall's contact force on body 2 (>= 0).
``status`` is ``"ok"`` or a failure class (``"diverged"``, ``"error"``, ``"timeout"``);
a failed run keeps every sample it finished.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from chatterbench.reference.scene import Scene


@dataclass(frozen=True)
class Trajectory:
    """A sampled engine (or reference) trajectory; see the module docstring for shapes."""

    engine: str  # "mujoco", "pybullet" or "reference"
    t: np.ndarray  # [s]
    x1: np.ndarray  # [m]
    x2: np.ndarray  # [m]
    v1: np.ndarray  # [m/s]
    v2: np.ndarray  # [m/s]
    contact: dict[str, np.ndarray]  # wall -> bool, contact active at the sample
    normal_force: dict[str, np.ndarray]  # wall -> contact force magnitude [N]
    wall_time: float  # seconds of wall clock spent stepping the engine
    settings: dict[str, Any] = field(default_factory=dict)  # the settings used, engine names
    status: str = "ok"  # "ok" or a failure class
    message: str = ""  # what went wrong, when status != "ok"

    @property
    def y(self) -> np.ndarray:
        """Gap coordinate y = x2 - x1 [m]."""
        return self.x2 - self.x1

    @property
    def vy(self) -> np.ndarray:
        """Relative velocity vy = v2 - v1 [m/s]."""
        return self.v2 - self.v1

    @property
    def dt(self) -> float:
        """Sampling step [s] (the engine timestep)."""
        return float(self.t[1] - self.t[0]) if len(self.t) > 1 else float("nan")


class Engine(Protocol):
    """An engine adapter: builds its model from a scene and runs it."""

    name: str

    def build(self, scene: Scene, settings: Any) -> Any:
        """Return the engine's model for ``scene`` (an MjModel, a PyBullet world, ...)."""

    def run(self, scene: Scene, settings: Any) -> Trajectory:
        """Simulate ``scene.duration`` seconds and return the sampled trajectory."""
