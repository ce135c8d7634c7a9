"""Engines by name: default settings with overrides, a run, and the engine's version.

    >>> settings = make_settings("pybullet", dt=1e-4, overrides=["pybullet.restitution_velocity_threshold=0.5"])
    >>> traj = run_engine("pybullet", scene, settings)
    >>> engine_version("mujoco")

Engine modules are imported on first use, so asking for one engine never loads the other.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
from typing import Any, Sequence

from chatterbench.reference.scene import Scene, did_you_mean

from .faults import inject
from .settings import SettingsError, settings_with_overrides
from .trajectory import Trajectory

ENGINE_NAMES = ("mujoco", "pybullet")
_MODULES = {"mujoco": ("chatterbench.engines.mujoco_engine", "MujocoSettings"),
            "pybullet": ("chatterbench.engines.pybullet_engine", "PybulletSettings")}


def check_engine(name: str) -> str:
    """Return ``name`` if it is a known engine, else raise SettingsError with a suggestion."""
    if name not in ENGINE_NAMES:
        raise SettingsError(f"engine {name!r}: must be one of {', '.join(ENGINE_NAMES)}" + did_you_mean(name, ENGINE_NAMES))
    return name


def engine_module(name: str):
    """The adapter module of engine ``name``."""
    return importlib.import_module(_MODULES[check_engine(name)][0])


def make_settings(name: str, dt: float | None = None, overrides: Sequence[str] | dict = ()) -> Any:
    """Default settings of engine ``name`` with ``dt`` [s] and ``NAME.KEY=VALUE`` overrides applied.

    Overrides for the other engine are ignored, so one ``--set`` list serves both.
    """
    cls = getattr(engine_module(name), _MODULES[name][1])
    base = cls() if dt is None else cls(dt=dt)
    return settings_with_overrides(base, overrides, prefix=name)


def settings_dict(settings: Any) -> dict[str, Any]:
    """Plain-data form of a settings object (for reports and Parquet rows)."""
    return dataclasses.asdict(settings)


def run_engine(name: str, scene: Scene, settings: Any) -> Trajectory:
    """Run ``scene`` in engine ``name``; failures come back as a Trajectory status, not an exception.

    A settings ``fault`` (test-only, see ``faults.py``) is injected before the engine starts.
    """
    fault = getattr(settings, "fault", "")
    if fault:
        inject(fault)
    return engine_module(name).run(scene, settings)


def run_engine_batch(name: str, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs of engine ``name``; one trajectory per pair, in order.

    Engines with a batched runner (MuJoCo: ``mujoco_engine.run_batch``, compatible models in
    one ``mujoco.rollout`` call) use it; the others run the pairs one by one. Each pair's
    ``fault`` (test-only) is injected first, as ``run_engine`` does.
    """
    for _, settings in jobs:
        fault = getattr(settings, "fault", "")
        if fault:
            inject(fault)
    module = engine_module(name)
    batch = getattr(module, "run_batch", None)
    if batch is None:
        return [module.run(scene, settings) for scene, settings in jobs]
    return batch(list(jobs))


def can_batch(name: str) -> bool:
    """Does engine ``name`` run compatible jobs together (see ``run_engine_batch``)?"""
    return hasattr(engine_module(name), "run_batch")


@functools.cache
def engine_version(name: str) -> str:
    """Version string of the engine's Python package."""
    from importlib.metadata import version

    return version(check_engine(name))
