"""Feigin's sliding model (1967) as an exact, event-driven reference simulator.

    >>> from chatterbench.reference import load_scene, simulate
    >>> result = simulate(load_scene("feigin-pair"))
    >>> result.episodes[["wall", "t_stick", "t_exit"]].head(2).round(4).values.tolist()
    [['lower', 1.5977, 3.1416], ['upper', 5.0682, 6.2832]]

This package imports no engine: it is the physics the engines are judged against. Its public
names are loaded on first use, so importing one module of it (``errors``, ``tables``) does not
load numba and pandas (``chatterbench --help`` stays fast).
"""

from __future__ import annotations

import importlib
import sys
import types

_PUBLIC = {
    **dict.fromkeys(("Force", "Gap", "Initial", "Prescribed", "SceneError"), "scene_parts"),
    **dict.fromkeys(("Scene", "load_scene", "scene_from_dict"), "scene"),
    **dict.fromkeys(("Options", "Result", "simulate"), "simulate"),
}
__all__ = list(_PUBLIC)


class _Package(types.ModuleType):
    """This package, whose public names are looked up in their modules on each use.

    A module-level ``__getattr__`` would not do: importing the submodule ``simulate`` binds the
    package's attribute ``simulate`` to that module, and the function must win, as it did when
    this file imported it.
    """

    def __getattribute__(self, name: str):
        if name in _PUBLIC:
            return getattr(importlib.import_module(f"{__name__}.{_PUBLIC[name]}"), name)
        return super().__getattribute__(name)


sys.modules[__name__].__class__ = _Package
