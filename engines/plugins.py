"""Engines other packages add: declared by entry points, loaded only when named, checked in a forked child first.

    >>> from chatterbench.engines.plugins import ENTRY_POINT_GROUP, check_name
    >>> ENTRY_POINT_GROUP
    'chatterbench.engines'
    >>> check_name("reference", built_in=("mujoco",)), check_name("mujoco", built_in=("mujoco",))
    ("the name 'reference' is reserved (the exact reference)", "the name of a built-in engine ('mujoco')")

A package adds an engine with one entry point in the group ``ENTRY_POINT_GROUP`` of its
``pyproject.toml`` (``NAME = "module:AdapterClass"``), the way pytest finds its plugins.
``declared`` reads the entry points without importing anything, so the engine table knows every
plugin's name and package at no cost; a name that is taken (``reference``, a built-in engine's,
another plugin's) or that a command line cannot carry is refused there, with its reason.

``load_plugin`` imports a plugin only when a command names it, and first in a forked child
(``isolate.run_isolated``, under ``load_limit``): the import, the class lookup and the contract
check (``contract.problem``). Whatever goes wrong there (an import error, a missing class, a
broken contract, a crash, a signal, ``os._exit``, a hang) comes back as one line naming the
package and what is wrong, and the command's process never imported it; only then is the
plugin imported here. Its runs are isolated too (``base.EngineAdapter.isolated``, set by the
registry). ``engines.registry`` holds the table and caches what ``load_plugin`` returns.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import re
from dataclasses import dataclass
from typing import Sequence

from .contract import problem
from .isolate import run_isolated, run_limit

ENTRY_POINT_GROUP = "chatterbench.engines"  # a third party's package adds an engine here: NAME = "module:AdapterClass"
RESERVED = ("reference",)  # names no engine can take: the exact reference is ``reference`` in every command
LOAD_LIMIT = 60.0  # [s] most a plugin's import and contract check may take (less when the command's run limit is)
NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,63}")  # a name ``--engines a,b`` and ``--set NAME.KEY=V`` can carry


@dataclass(frozen=True)
class Declared:
    """One engine a package declares in ``ENTRY_POINT_GROUP``."""

    name: str  # the entry point's name: the engine's name
    value: str  # "module:Class" of its adapter
    package: str  # the distribution that declares it
    version: str  # that distribution's version
    refused: str = ""  # why the name cannot be used ("": it can)

    @property
    def label(self) -> str:
        """``plugin chatterbench-pymunk (engine 'pymunk')``: how messages name it."""
        return f"plugin {self.package} (engine {self.name!r})"


def check_name(name: str, built_in: Sequence[str], taken: Sequence[str] = ()) -> str:
    """Why a plugin cannot be called ``name`` ("" when it can)."""
    if name in RESERVED:
        return f"the name {name!r} is reserved (the exact reference)"
    if name in built_in:
        return f"the name of a built-in engine ({name!r})"
    if name in taken:
        return f"the name {name!r} is taken by another plugin"
    if not NAME.fullmatch(name):
        return f"the name {name!r} is not a letter then letters, digits, _ or - (at most 64)"
    return ""


def declared(built_in: Sequence[str]) -> tuple[Declared, ...]:
    """Every engine the installed packages declare, sorted by name then package, each with why it is refused."""
    found: list[Declared] = []
    points = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    for ep in sorted(points, key=lambda e: (e.name, e.dist.name if e.dist else "")):
        package = ep.dist.name if ep.dist else ep.value.partition(":")[0]
        version = ep.dist.version if ep.dist else ""
        taken = [d.name for d in found if not d.refused]
        found.append(Declared(ep.name, ep.value, package, version, check_name(ep.name, built_in, taken)))
    return tuple(found)


def load_limit() -> float:
    """Seconds a plugin's load may take: ``LOAD_LIMIT``, or the command's run limit when that is shorter."""
    return min(LOAD_LIMIT, run_limit())


def resolve(value: str, name: str) -> type | str:
    """Import ``module:Class`` and return the class, or why not in one line (no exception leaves)."""
    module, colon, attr = value.partition(":")
    if not colon or not module.strip() or not attr.strip():
        return f"entry point {name} = {value!r} names no class (module:Class)"
    try:
        found = importlib.import_module(module.strip())
    except BaseException as exc:  # noqa: BLE001  SystemExit too: the plugin's import, not this process's exit
        return f"cannot import {module.strip()}: {type(exc).__name__}: {exc}".splitlines()[0]
    for part in attr.strip().split("."):
        found = getattr(found, part, None)
        if found is None:
            return f"module {module.strip()} has no {attr.strip()}"
    return found


def checked(value: str, name: str) -> str:
    """What is wrong with the adapter ``module:Class`` for engine ``name``: the import, the lookup, the contract."""
    cls = resolve(value, name)
    return cls if isinstance(cls, str) else problem(cls, name)


def load_plugin(entry: Declared) -> type | str:
    """The adapter class of ``entry``, imported here only once a forked child has imported and checked it; or why
    not, in one line naming the package."""
    if entry.refused:
        return f"{entry.label}: {entry.refused}; rename its entry point in {ENTRY_POINT_GROUP}"
    limit = load_limit()
    outcome = run_isolated(checked, entry.value, entry.name, timeout=limit)
    if outcome.status == "ok" and outcome.value:
        return f"{entry.label}: {outcome.value}"
    if outcome.status == "timeout":
        return f"{entry.label}: loading it took more than {limit:g} s (the child was killed)"
    if outcome.status != "ok":
        lines = outcome.message.strip().splitlines()
        return f"{entry.label}: loading it failed: {lines[0] if lines else outcome.status}"
    cls = resolve(entry.value, entry.name)
    reason = cls if isinstance(cls, str) else problem(cls, entry.name)
    return f"{entry.label}: {reason}" if reason else cls
