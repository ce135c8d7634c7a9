"""Engines by name, through the one contract (``base.EngineAdapter``): settings, runs, snippets, versions.

    >>> from chatterbench.engines.registry import make_settings, run_engine, engine_version
    >>> from chatterbench.reference.scene import load_scene
    >>> settings = make_settings("pybullet", dt=1e-3, overrides=["pybullet.restitution_velocity_threshold=0.5"])
    >>> settings.restitution_velocity_threshold
    0.5
    >>> run_engine("pybullet", load_scene("bouncing-ball"), settings).status
    'ok'

One table (``ENGINES``: name, adapter, extra, default or not) says which engines there are;
``ENGINE_NAMES``, ``DEFAULT_ENGINES`` and ``EXTRAS`` are read from it. Other packages add
engines through the entry-point group ``chatterbench.engines`` (``examples/engine_plugin``:
``NAME = "module:AdapterClass"``). Adapters are imported on first use, so asking for one
engine never loads the other.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.metadata
import importlib.util
from dataclasses import dataclass
from typing import Any, Sequence

from chatterbench.reference.errors import did_you_mean
from chatterbench.reference.scene import Scene

from .base import EngineAdapter, Status, failed_trajectory
from .faults import inject_planned
from .isolate import run_isolated
from .settings import SettingsError, settings_with_overrides
from .trajectory import Trajectory

ENTRY_POINT_GROUP = "chatterbench.engines"  # a third party's package adds an engine here: NAME = "module:AdapterClass"


@dataclass(frozen=True)
class Engine:
    """One row of the engine table: how to load an engine and whether it runs when none is named."""

    name: str  # the registry name, also the ``--set NAME.KEY=VALUE`` prefix
    adapter: str  # "module:Class" of its ``EngineAdapter`` subclass
    extra: str = ""  # the pyproject extra that installs it ("": always installed)
    module: str = ""  # the Python module that extra provides (how a missing extra is told)
    default: bool = False  # run by commands and sweeps when no engine is named
    plugin: str = ""  # the distribution that declared it through ENTRY_POINT_GROUP ("": built in)
    # "module:function" returning "" when the engine can run here, else why not and how to install it; for an
    # engine whose own check is not an importable module (Siconos runs under another interpreter)
    probe: str = ""


BUILT_IN = (
    Engine("mujoco", "chatterbench.engines.mujoco_engine:MujocoEngine", default=True),
    Engine("pybullet", "chatterbench.engines.pybullet_engine:PybulletEngine", default=True),
    Engine("drake", "chatterbench.engines.drake_engine:DrakeEngine", extra="drake", module="pydrake"),
    Engine("mujoco_warp", "chatterbench.engines.mujoco_warp_engine:MujocoWarpEngine", extra="warp", module="mujoco_warp"),
    Engine("physx", "chatterbench.engines.physx_engine:PhysxEngine", extra="physx", module="sapien"),
    Engine("dart", "chatterbench.engines.dart_engine:DartEngine", extra="dart", module="dartpy"),
    Engine("siconos", "chatterbench.engines.siconos_engine:SiconosEngine",
           probe="chatterbench.engines.siconos_engine.run:unavailable"),
)


def _plugins(known: Sequence[str]) -> tuple[Engine, ...]:
    """The engines other packages declare in ``ENTRY_POINT_GROUP`` (a name already taken is skipped)."""
    found = []
    for ep in sorted(importlib.metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        if ep.name not in known and ep.name not in [e.name for e in found]:
            found.append(Engine(ep.name, ep.value, plugin=ep.dist.name if ep.dist else ep.module))
    return tuple(found)


ENGINES = BUILT_IN + _plugins([e.name for e in BUILT_IN])  # the engine table: every list of engines reads it
_TABLE = {e.name: e for e in ENGINES}
ENGINE_NAMES = tuple(_TABLE)  # every engine the suite knows, built in first
DEFAULT_ENGINES = tuple(e.name for e in ENGINES if e.default)  # what commands and sweeps run when no engine is named
# optional engines: the Python module an engine needs, and the pyproject extra that installs it
EXTRAS = {e.name: (e.module, e.extra) for e in ENGINES if e.extra}


class EngineUnavailable(SettingsError):
    """An optional engine's extra is not installed; the message says which ``pip install`` adds it."""


def check_engine(name: str) -> str:
    """Return ``name`` if it is a known engine, else raise SettingsError with a suggestion."""
    if name not in _TABLE:
        raise SettingsError(f"engine {name!r}: must be one of {', '.join(ENGINE_NAMES)}" + did_you_mean(str(name), ENGINE_NAMES))
    return name


def unavailable_reason(name: str) -> str:
    """Why engine ``name`` cannot run here ("" when it can): the missing extra and how to install it."""
    entry = _TABLE[check_engine(name)]
    if entry.extra and importlib.util.find_spec(entry.module) is None:
        return (f"engine {name!r} needs the optional extra {entry.extra!r}: pip install \".[{entry.extra}]\" "
                f"(module {entry.module} not found)")
    if entry.probe:
        module, _, function = entry.probe.partition(":")
        return getattr(importlib.import_module(module), function)()
    return ""


def available_engines() -> tuple[str, ...]:
    """The engines that can run on this machine (every non-optional one, and the optional ones installed)."""
    return tuple(n for n in ENGINE_NAMES if not unavailable_reason(n))


@functools.cache
def adapter(name: str) -> EngineAdapter:
    """The adapter of engine ``name`` (imported on first use); EngineUnavailable when its extra is missing."""
    reason = unavailable_reason(name)
    if reason:
        raise EngineUnavailable(reason)
    module, _, cls = _TABLE[name].adapter.partition(":")
    made = getattr(importlib.import_module(module), cls)()
    if not isinstance(made, EngineAdapter) or made.name != name:
        raise TypeError(f"engine {name!r}: {_TABLE[name].adapter} is not an EngineAdapter named {name!r}")
    return made


def make_settings(name: str, dt: float | None = None, overrides: Sequence[str] | dict = ()) -> Any:
    """Default settings of engine ``name`` with ``dt`` [s] and ``NAME.KEY=VALUE`` overrides applied.

    Overrides for the other engine are ignored, so one ``--set`` list serves both.
    """
    cls = adapter(name).settings_type
    base = cls() if dt is None else cls(dt=dt)
    return settings_with_overrides(base, overrides, prefix=name)


def settings_dict(settings: Any) -> dict[str, Any]:
    """Plain-data form of a settings object (for reports and Parquet rows)."""
    return dataclasses.asdict(settings)


def run_engine(name: str, scene: Scene, settings: Any) -> Trajectory:
    """Run ``scene`` in engine ``name``; failures come back as a Trajectory status, not an exception (the
    adapter catches them, the test-only faults of ``faults.py`` included); SettingsError for settings the
    scene cannot run with, before the engine starts."""
    return adapter(name).run(scene, settings)


def run_engine_isolated(name: str, scene: Scene, settings: Any, timeout: float) -> Trajectory:
    """``run_engine`` in a forked child with a wall-clock limit ``timeout`` [s] (``isolate.run_isolated``).

    The caller's process is never touched: an engine that dies (SIGSEGV, out of memory) comes
    back as a trajectory with status ``crashed``, one that runs past ``timeout`` as ``timeout``,
    one that raises as ``error``; the message says which, and other results are kept.
    """
    outcome = run_isolated(run_engine, name, scene, settings, timeout=timeout)
    if outcome.status == "ok":
        return outcome.value
    message = outcome.message.strip().splitlines()[0] if outcome.message.strip() else outcome.status
    return failed_trajectory(name, scene, Status(outcome.status), message, settings_dict(settings), outcome.wall_time)


def run_engine_batch(name: str, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs of engine ``name``; one trajectory per pair, in order.

    Engines that batch (``EngineAdapter.batches``: MuJoCo, compatible models in one
    ``mujoco.rollout`` call) do; the others run the pairs one by one. Each pair's planned
    test fault is injected first, for the whole batch: a ``raise`` fault raises from here
    (a sweep then runs each pair alone, where the adapter classifies it).
    """
    for scene, _ in jobs:
        inject_planned(name, scene)
    return adapter(name).run_batch(list(jobs))


def can_batch(name: str) -> bool:
    """Does engine ``name`` run compatible jobs together (see ``run_engine_batch``)?"""
    return adapter(name).batches


def engine_version(name: str) -> str:
    """Version string of the engine's Python package."""
    return adapter(name).version()
