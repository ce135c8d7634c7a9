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
engines through the entry-point group ``chatterbench.engines`` (``plugins.py``;
``examples/engine_plugin``: ``NAME = "module:AdapterClass"``). Adapters are imported on first
use, so asking for one engine never loads another, and every adapter is checked against the
contract as it loads (``contract.py``). A plugin is loaded only when named, checked in a forked
child first, and runs isolated; whatever is wrong with it is one line (``PluginError``, exit 2
on the command line) naming its package, and no other engine or command notices.
``engine_rows`` is the table as ``chatterbench engines`` shows it.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.metadata
import importlib.util
import warnings
from dataclasses import dataclass
from typing import Any, Sequence

from chatterbench.reference.errors import did_you_mean
from chatterbench.reference.scene import Scene

from .base import EngineAdapter, Status, failed_trajectory
from .contract import problem
from .faults import inject_planned
from .isolate import run_isolated
from .plugins import ENTRY_POINT_GROUP, declared, load_plugin  # noqa: F401  (ENTRY_POINT_GROUP: as before)
from .settings import SettingsError, settings_with_overrides
from .trajectory import Trajectory


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
    Engine("newton_xpbd", "chatterbench.engines.newton_engine:NewtonXpbdEngine", extra="newton", module="newton"),
    Engine("newton_semi", "chatterbench.engines.newton_engine:NewtonSemiEngine", extra="newton", module="newton"),
    Engine("siconos", "chatterbench.engines.siconos_engine:SiconosEngine",
           probe="chatterbench.engines.siconos_engine.run:unavailable"),
)


DECLARED = declared([e.name for e in BUILT_IN])  # every plugin installed, refused names included
ENGINES = BUILT_IN + tuple(Engine(d.name, d.value, plugin=d.package) for d in DECLARED if not d.refused)  # the table
_TABLE = {e.name: e for e in ENGINES}
_PLUGINS = {d.name: d for d in DECLARED if not d.refused}
ENGINE_NAMES = tuple(_TABLE)  # every engine the suite knows, built in first
DEFAULT_ENGINES = tuple(e.name for e in ENGINES if e.default)  # what commands and sweeps run when no engine is named
# optional engines: the Python module an engine needs, and the pyproject extra that installs it
EXTRAS = {e.name: (e.module, e.extra) for e in ENGINES if e.extra}


class EngineUnavailable(SettingsError):
    """An optional engine's extra is not installed; the message says which ``pip install`` adds it."""


class PluginError(EngineUnavailable):
    """A plugin cannot be loaded (its import, its class, the contract, a crash or hang while loading); the message
    is one line naming its package and what is wrong."""


_ADAPTERS: dict[str, EngineAdapter] = {}  # the adapters loaded in this process
_BROKEN: dict[str, str] = {}  # plugins that failed to load here, and why (a load forks a child: once is enough)


def check_engine(name: str) -> str:
    """Return ``name`` if it is a known engine, else raise SettingsError with a suggestion."""
    if name not in _TABLE:
        raise SettingsError(f"engine {name!r}: must be one of {', '.join(ENGINE_NAMES)}" + did_you_mean(str(name), ENGINE_NAMES))
    return name


def unavailable_reason(name: str) -> str:
    """Why engine ``name`` cannot run here ("" when it can): the missing extra and how to install it, or what is
    wrong with a plugin (which this loads)."""
    entry = _TABLE[check_engine(name)]
    if entry.plugin:
        try:
            adapter(name)
        except PluginError as exc:
            return str(exc)
        return ""
    if entry.extra and importlib.util.find_spec(entry.module) is None:
        return (f"engine {name!r} needs the optional extra {entry.extra!r}: pip install \".[{entry.extra}]\" "
                f"(module {entry.module} not found)")
    if entry.probe:
        module, _, function = entry.probe.partition(":")
        return getattr(importlib.import_module(module), function)()
    return ""


def available_engines() -> tuple[str, ...]:
    """The engines that can run on this machine (every non-optional one, the optional ones installed, the plugins
    that load)."""
    return tuple(n for n in ENGINE_NAMES if not unavailable_reason(n))


def adapter(name: str) -> EngineAdapter:
    """The adapter of engine ``name``, loaded once per process (``load``); EngineUnavailable when it cannot run here
    (PluginError for a plugin that does not load)."""
    made = _ADAPTERS.get(name)
    if made is None:
        made = _ADAPTERS[name] = load(name)
    return made


def load(name: str) -> EngineAdapter:
    """Import engine ``name``'s adapter, check it against the contract and make it (``adapter`` keeps it)."""
    entry = _TABLE[check_engine(name)]
    if entry.plugin:
        return _plugin(name)
    reason = unavailable_reason(name)
    if reason:
        raise EngineUnavailable(reason)
    module, _, cls = entry.adapter.partition(":")
    found = getattr(importlib.import_module(module), cls)
    broken = problem(found, name)
    if broken:
        raise TypeError(f"engine {name!r}: {entry.adapter} breaks the engine contract: {broken}")
    return found()


def _plugin(name: str) -> EngineAdapter:
    """Plugin ``name``'s adapter, marked ``isolated`` (``plugins.load_plugin``); PluginError with its one line, once
    known (a load forks a child: it is not tried twice)."""
    if name not in _BROKEN:
        got = load_plugin(_PLUGINS[name])
        if not isinstance(got, str):
            try:
                made = got()
                made.isolated = True  # its runs go to a forked child under the command's run limit
                return made
            except Exception as exc:  # noqa: BLE001  the plugin's own __init__: its failure, in one line
                got = f"{_PLUGINS[name].label}: {got.__name__}() failed: {type(exc).__name__}: {exc}".splitlines()[0]
        _BROKEN[name] = got
    raise PluginError(_BROKEN[name])


def make_settings(name: str, dt: float | None = None, overrides: Sequence[str] | dict = ()) -> Any:
    """Default settings of engine ``name`` with ``dt`` [s] and ``NAME.KEY=VALUE`` overrides applied.

    Overrides for the other engine are ignored, so one ``--set`` list serves both.
    """
    cls = adapter(name).settings_type
    try:
        base = cls() if dt is None else cls(dt=dt)
        return settings_with_overrides(base, overrides, prefix=name)
    except SettingsError:
        raise
    except Exception as exc:  # a plugin's settings that refuse a value with another exception: still one line
        if not _TABLE[name].plugin:
            raise
        raise PluginError(f"{_PLUGINS[name].label}: its settings refused the values given: "
                          f"{type(exc).__name__}: {exc}".splitlines()[0]) from None


def settings_for(engines: Sequence[str], dt: float | None = None,
                 overrides: Sequence[str] | dict = ()) -> dict[str, Any]:
    """Each engine's settings object (``make_settings``) from one timestep ``dt`` [s] (None: each engine's default)
    and ``NAME.KEY=VALUE`` overrides: the way text and numbers become settings, checked once, here.

    >>> from chatterbench.engines.registry import settings_for
    >>> {name: s.dt for name, s in settings_for(("mujoco", "pybullet"), 1e-3).items()}
    {'mujoco': 0.001, 'pybullet': 0.001}
    """
    return {name: make_settings(check_engine(name), dt, overrides) for name in engines}


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
    return adapter(name).batch(list(jobs))


def can_batch(name: str) -> bool:
    """Does engine ``name`` run compatible jobs together (see ``run_engine_batch``; a plugin's runs go one by one,
    each isolated)?"""
    made = adapter(name)
    return made.batches and not made.isolated


def is_plugin(name: str) -> bool:
    """Whether engine ``name`` comes from another package (``plugins.py``): loaded when named, run isolated."""
    return bool(_TABLE[check_engine(name)].plugin)


class PluginFault(UserWarning):
    """A plugin's own reporting code (``version``, ``snippet``) raised: the work around it is kept, the text it could
    not give is replaced (``engine_version``, ``engine_snippet``), and the command line shows this as a note."""


def plugin_said(name: str, method: str, *args: Any, instead: Any, kept: str) -> Any:
    """``adapter(name).method(*args)``; for a plugin whose method raises, ``instead(fault)`` and a ``PluginFault``
    warning ``fault; kept`` (``fault``: ``plugin engine 'line': its snippet() raised RuntimeError: ...``). A built-in
    engine's failure is a bug: raised."""
    try:
        return getattr(adapter(name), method)(*args)
    except Exception as exc:
        if not is_plugin(name):
            raise
        said = " ".join(str(exc).split())
        fault = f"plugin engine {name!r}: its {method}() raised {type(exc).__name__}" + (f": {said[:200]}" if said else "")
        warnings.warn(f"{fault}; {kept}", PluginFault, stacklevel=2)
        return instead(fault)


def engine_version(name: str) -> str:
    """Version string of the engine's Python package (``unknown (why)`` for a plugin whose ``version()`` raises)."""
    return str(plugin_said(name, "version", instead=lambda fault: f"unknown ({fault})",
                           kept="its version is recorded as unknown"))


def engine_snippet(name: str, scene: Scene, settings: Any) -> str:
    """The engine's snippet of ``settings`` (``EngineAdapter.snippet``); for a plugin whose ``snippet()`` raises, the
    settings as chatterbench holds them (the base adapter's snippet) under a comment saying so."""
    def instead(fault: str) -> str:
        return f"# {fault}; its settings as chatterbench holds them:\n{EngineAdapter.snippet(adapter(name), scene, settings)}"

    return plugin_said(name, "snippet", scene, settings, instead=instead,
                       kept="its settings are written as chatterbench holds them")


@dataclass(frozen=True)
class EngineRow:
    """One engine as ``chatterbench engines`` lists it."""

    name: str  # the name commands take (a refused plugin's declared name)
    source: str  # "built in", or "plugin DISTRIBUTION VERSION"
    install: str  # what installs it: "chatterbench", the extra (pip install ".[drake]") or the plugin's distribution
    version: str  # the engine package's version ("-" where it cannot be loaded)
    status: str  # "ok", "not installed" (an optional engine) or "broken" (a plugin that does not load)
    reason: str = ""  # why not "ok", one line


def engine_rows(names: Sequence[str] | None = None) -> list[EngineRow]:
    """Every engine of the table and every refused plugin (those called ``names``, when given), each loaded to say
    its version and status (a plugin in a forked child first: a broken one is its row, never this process's
    failure)."""
    rows = []
    for e in ENGINES:
        if names is not None and e.name not in names:
            continue
        install = f'pip install ".[{e.extra}]"' if e.extra else (e.plugin or "chatterbench")
        source = f"plugin {e.plugin} {_PLUGINS[e.name].version}" if e.plugin else "built in"
        reason = unavailable_reason(e.name)
        status = "ok" if not reason else "broken" if e.plugin else "not installed"
        rows.append(EngineRow(e.name, source, install, _version(e.name) if status == "ok" else "-", status, reason))
    for d in DECLARED:
        if d.refused and (names is None or d.name in names):
            rows.append(EngineRow(d.name, f"plugin {d.package} {d.version}", d.package, "-", "broken",
                                  load_plugin(d)))
    return rows


def _version(name: str) -> str:
    """The engine package's version, or why it has none (a plugin's ``version`` is its own code)."""
    try:
        return str(adapter(name).version())
    except Exception as exc:  # noqa: BLE001  a plugin's version() that fails is that row's, not the listing's
        return f"- ({type(exc).__name__})"
