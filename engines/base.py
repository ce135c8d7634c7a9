"""The engine contract: what every adapter provides, the one step-count rule and the failed-run trajectory.

    >>> from chatterbench.engines.base import n_steps, sample_times
    >>> n_steps(1.0, 3e-4)                  # the last sample at or before the end of the run
    3333
    >>> sample_times(load_scene("bouncing-ball"), 0.5)
    array([0. , 0.5, 1. , 1.5, 2. ])

An adapter (``mujoco_engine``, ``pybullet_engine``) is a subclass of ``EngineAdapter``: its
``name``, the Python package it drives (for the version), its frozen settings dataclass,
and ``build`` (the engine's model of a scene), ``run`` (a scene in, a ``Trajectory`` out),
``run_batch`` (many runs; one by one unless the engine batches), ``snippet`` (the settings
as a user pastes them into their own model), ``benchmark`` and ``tuning_space`` (what
``tune`` searches). The registry
(``registry.py``) goes through this class and nothing else.

Promises every adapter keeps, and the tests check for each:

- ``run`` samples the scene at ``sample_times(scene, settings.dt)``: sample 0 is the initial
  state, sample k the state after k steps, the last one at or before the scene's end;
- a user mistake in the settings is refused (``SettingsError``) before the engine starts;
  anything that goes wrong inside the engine is a ``status`` of the trajectory (``error``,
  ``diverged``) with the samples finished before it, never an exception;
- the trajectory carries the contact law's own scales as typed fields
  (``Trajectory.contact_time``, ``contact_frequency``), for reports: the judge never reads them.
"""

from __future__ import annotations

import abc
import functools
import math
from importlib.metadata import version as package_version
from typing import Any, Sequence

import numpy as np

from chatterbench.reference.scene import Scene

from .trajectory import Trajectory

_ROUNDING = 1e-12  # [-] relative slack of duration / dt, so that 2.0 / 1e-4 gives 20000 steps


def n_steps(duration: float, dt: float) -> int:
    """Steps of ``dt`` [s] covering ``duration`` [s]: the largest n with n dt <= duration (to rounding), >= 1."""
    return max(1, int(math.floor(duration / dt * (1.0 + _ROUNDING))))


def sample_times(scene: Scene, dt: float) -> np.ndarray:
    """The sample times of a run [s], t0 + k dt for k = 0..n_steps(duration, dt); shape (n + 1,)."""
    return scene.initial.t + dt * np.arange(n_steps(scene.duration, dt) + 1)


def failed_trajectory(engine: str, scene: Scene, status: str, message: str, settings: dict[str, Any] | None = None,
                      wall_time: float = 0.0) -> Trajectory:
    """The trajectory of a run that failed before its first step: the initial state as its one sample."""
    ini = scene.initial
    one = lambda v: np.array([float(v)])  # noqa: E731
    walls = scene.gap.walls
    return Trajectory(
        engine=engine, t=one(ini.t), x1=one(ini.x1), x2=one(ini.x1 + ini.y), v1=one(ini.v1), v2=one(ini.v1 + ini.vy),
        contact={w: np.zeros(1, bool) for w in walls}, normal_force={w: np.zeros(1) for w in walls},
        wall_time=wall_time, settings=dict(settings or {}), status=status, message=message,
    )


class EngineAdapter(abc.ABC):
    """One engine behind the suite's contract (module docstring)."""

    name: str  # "mujoco", "pybullet"
    package: str  # the distribution whose version is reported
    settings_type: type  # a frozen dataclass with a ``dt`` field [s]
    batches: bool = False  # does run_batch do better than one run after another?
    bytes_per_step: float = 500.0  # [B] memory a run holds per step, samples and engine state (measured per engine)

    @abc.abstractmethod
    def build(self, scene: Scene, settings: Any) -> Any:
        """The engine's own model of ``scene`` (an MjModel, a PyBullet world, ...)."""

    @abc.abstractmethod
    def run(self, scene: Scene, settings: Any) -> Trajectory:
        """Simulate ``scene.duration`` seconds from ``scene.initial``; never raises for an engine failure."""

    def run_batch(self, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
        """Run many (scene, settings) pairs; one trajectory per pair, in order."""
        return [self.run(scene, settings) for scene, settings in jobs]

    @abc.abstractmethod
    def snippet(self, scene: Scene, settings: Any) -> str:
        """The settings as a user pastes them into their own model (MJCF, Python)."""

    @abc.abstractmethod
    def benchmark(self, scene: Scene, settings: Any, n_steps: int, repeats: int) -> dict[str, Any]:
        """Steps per second of ``run`` against the bare engine loop (``adapter_steps_per_s``,
        ``raw_steps_per_s``, ``ratio``)."""

    def tuning_space(self, scene: Scene) -> dict[str, tuple] | None:
        """What ``tune`` searches for ``scene``: ``"dt"`` [s], a ladder from coarse to fine, and per setting
        (``"engine.field"``) its candidate values, the default first; None: the engine declares none."""
        return None

    def cost_lever(self, settings: Any) -> str:
        """The settings field a user turns to trade accuracy for cost: ``"dt"`` for fixed-step engines,
        ``"accuracy"`` for an error-controlled integrator (charts label their points with it)."""
        return "dt"

    def version(self) -> str:
        """The engine package's version."""
        return _version(self.package)


@functools.cache
def _version(package: str) -> str:
    return package_version(package)
