"""What an engine run returns: sampled states, per-wall contact, the cost of stepping, the contact's own scales.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.registry import make_settings, run_engine
    >>> traj = run_engine("pybullet", load_scene("bouncing-ball"), make_settings("pybullet", dt=1e-3))
    >>> traj.y.shape, traj.contact["lower"].dtype, traj.status
    ((2001,), dtype('bool'), 'ok')

Arrays all have shape ``(n,)``, one entry per sample; sample 0 is the initial state and
sample k is the state after k engine steps (``t[k] = t0 + k dt``; ``base.sample_times``).
Units: s, m, m/s, N. ``normal_force[wall]`` is the magnitude of the wall's contact force on
body 2 (>= 0) and ``contact[wall]`` says where it is on. ``status`` is ``"ok"`` or a failure
class (``"diverged"``, ``"error"``, ``"timeout"``, ``"crashed"``: ``base.Status`` and its
message table); a failed run keeps every sample it finished.

A long run comes *compact* (``window.py``): only the samples the judge needs, ``index[i]``
the step number of sample i (``t[i] = t0 + index[i] dt``); ``index`` None (the default) is a full
trajectory, sample k after k steps.

``step`` is the run's timestep dt [s], carried with the run, never re-derived: an engine run's is its settings'
dt, recorded by the base (``recording.Recording``); samples from elsewhere (a trajectory file, the reference sampled)
give none, and their median sample spacing is taken once, when the trajectory is made.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """A sampled engine (or reference) trajectory; see the module docstring for shapes."""

    engine: str  # the engine's registry name (``registry.ENGINE_NAMES``), or "reference"
    t: np.ndarray  # [s]
    x1: np.ndarray  # [m]
    x2: np.ndarray  # [m]
    v1: np.ndarray  # [m/s]
    v2: np.ndarray  # [m/s]
    contact: dict[str, np.ndarray]  # wall -> bool, the wall's contact force is on at the sample
    normal_force: dict[str, np.ndarray]  # wall -> contact force magnitude [N]
    wall_time: float  # seconds of wall clock spent stepping the engine
    settings: dict[str, Any] = field(default_factory=dict)  # the settings used, by the engine's own names
    status: str = "ok"  # "ok" or a failure class (``base.Status``, which equals its string)
    message: str = ""  # what went wrong, when status != "ok"
    contact_time: float = 0.0  # [s] duration of one bounce of the engine's contact law at these settings (0: rigid)
    contact_frequency: float = math.inf  # [rad/s] natural frequency of a compliant contact (inf: rigid)
    index: np.ndarray | None = None  # step number of each sample (compact); None: every sample, 0..n
    step: float = math.nan  # [s] the run's timestep dt (module docstring); NaN given: the median sample spacing

    def __post_init__(self) -> None:
        if math.isnan(self.step) and self.index is None and len(self.t) > 1:  # samples from elsewhere: derived once
            object.__setattr__(self, "step", float(np.median(np.diff(self.t))))

    @property
    def compact(self) -> bool:
        """Whether this is a compact trajectory (some samples between contacts left out)."""
        return self.index is not None

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
        """The run's timestep [s], ``step`` (module docstring); NaN for one sample from elsewhere."""
        return self.step
