"""The contract an engine adapter is checked against when it is registered: what it is missing, in one line.

    >>> from chatterbench.engines.contract import problem
    >>> from chatterbench.engines.pybullet_engine import PybulletEngine
    >>> problem(PybulletEngine, "pybullet")              # "": it keeps the contract
    ''
    >>> problem(int, "pybullet")
    'int is not an EngineAdapter subclass (chatterbench.engines.api.EngineAdapter)'

``problem(cls, name)`` is what the registry asks of every adapter class it loads, built in or
a plugin's (``registry.adapter``): the first thing that breaks the contract of ``base.py``, or
"" when none does. It checks, in order:

- the class is an ``EngineAdapter`` subclass that can be made without arguments, named
  ``name`` (the table's name), with a ``package`` (the distribution whose version is reported);
- ``settings_type`` is a frozen dataclass with a ``dt`` field [s] and defaults for every field;
  its defaults make settings with a finite ``dt`` > 0, and ``dt`` = -1, 0 and NaN are each
  refused with ``SettingsError`` (a checked ``dt``: ``reference.errors.check_number``);
- the adapter writes ``build`` and ``step`` (the base's step loop runs them) or ``samples``
  (a whole run at once, a generator the base drives: ``wholerun.py``), and not ``simulate``
  (the base's);
- its facts have their types: ``compliant`` and ``batches`` booleans, ``precision`` one of
  ``PRECISIONS``, ``bytes_per_step`` a finite number > 0, ``bench_step_cap`` None or an integer
  >= 1, ``force_sum`` one of ``FORCE_SUMS``, ``same_model_as``, ``first_run_note`` and
  ``export_kind`` strings, ``exports`` a tuple of file names (with an ``export_kind``).

Everything it runs is the class's own code (the settings' ``__post_init__``), so the registry
runs it for a plugin in a forked child first (``plugins.py``): a check that crashes or hangs
is that plugin's failure.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .base import EngineAdapter
from .settings import SettingsError

PRECISIONS = ("float32", "float64")
FORCE_SUMS = ("grouped", "in order")
_FACTS = {  # fact -> (type check, what it must be)
    "compliant": (lambda v: isinstance(v, bool), "a bool"),
    "batches": (lambda v: isinstance(v, bool), "a bool"),
    "precision": (lambda v: v in PRECISIONS, f"one of {', '.join(PRECISIONS)}"),
    "bytes_per_step": (lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < math.inf,
                       "a finite number of bytes > 0"),
    "bench_step_cap": (lambda v: v is None or (isinstance(v, int) and not isinstance(v, bool) and v >= 1),
                       "None or an integer >= 1"),
    "force_sum": (lambda v: v in FORCE_SUMS, f"one of {', '.join(map(repr, FORCE_SUMS))}"),
    "same_model_as": (lambda v: isinstance(v, str), "a str"),
    "first_run_note": (lambda v: isinstance(v, str), "a str"),
    "export_kind": (lambda v: isinstance(v, str), "a str"),
    "exports": (lambda v: isinstance(v, tuple) and all(isinstance(f, str) and f and "/" not in f for f in v),
                "a tuple of file names"),
}


def problem(cls: Any, name: str) -> str:
    """The first way adapter class ``cls`` breaks the contract for the engine ``name`` (module docstring), "" if none."""
    if not (isinstance(cls, type) and issubclass(cls, EngineAdapter)):
        return f"{getattr(cls, '__name__', repr(cls))} is not an EngineAdapter subclass (chatterbench.engines.api.EngineAdapter)"
    for check in (_named, _settings, _methods, _facts):
        found = check(cls, name)
        if found:
            return found
    return ""


def _named(cls: type, name: str) -> str:
    own = getattr(cls, "name", None)
    if own != name:
        return f"{cls.__name__}.name is {own!r}, not the name it is registered under ({name!r})"
    package = getattr(cls, "package", None)
    if not isinstance(package, str) or not package:
        return f"{cls.__name__}.package: the distribution whose version is reported (a non-empty str), is missing"
    return ""


def _settings(cls: type, name: str) -> str:
    st = getattr(cls, "settings_type", None)
    where = f"{cls.__name__}.settings_type"
    if not (isinstance(st, type) and dataclasses.is_dataclass(st)):
        return f"{where} ({getattr(st, '__name__', repr(st))}) is not a dataclass"
    if not st.__dataclass_params__.frozen:
        return f"{where} ({st.__name__}) is not a frozen dataclass (@dataclass(frozen=True))"
    fields = {f.name: f for f in dataclasses.fields(st)}
    if "dt" not in fields:
        return f"{where} ({st.__name__}) has no field 'dt' (the step [s])"
    bare = [f for f, v in fields.items() if v.default is dataclasses.MISSING and v.default_factory is dataclasses.MISSING]
    if bare:
        return f"{where} ({st.__name__}): field {bare[0]!r} has no default (the defaults are the engine's settings)"
    try:
        dt = st().dt
    except Exception as exc:  # noqa: BLE001  the plugin's own code: any failure is its problem, in one line
        return f"{where}() with the defaults failed: {type(exc).__name__}: {exc}".splitlines()[0]
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not 0 < dt < math.inf:
        return f"{where}().dt = {dt!r}: the default step must be a finite number of seconds > 0"
    for bad in (-1.0, 0.0, math.nan):
        try:
            st(dt=bad)
        except SettingsError:
            continue
        except Exception as exc:  # noqa: BLE001
            return f"{where}(dt={bad}) raised {type(exc).__name__}, not SettingsError: dt is not checked"
        return f"{where}(dt={bad}) was accepted: dt is not checked (reference.errors.check_number, error=SettingsError)"
    return ""


def _methods(cls: type, name: str) -> str:
    if cls.simulate is not EngineAdapter.simulate:
        return (f"{cls.__name__} writes simulate, the base's run: a whole-run engine writes samples(run), a generator "
                "of its samples the base times and records (chatterbench.engines.api.Samples)")
    if cls.steps() or cls.whole_runs():
        return ""
    half = [m for m in ("build", "step") if getattr(cls, m) is not getattr(EngineAdapter, m)]
    if half:
        missing = ({"build", "step"} - set(half)).pop()
        return f"{cls.__name__} writes {half[0]} but not {missing} (an adapter writes build and step, or samples)"
    return f"{cls.__name__} writes neither build and step nor samples (base.EngineAdapter)"


def _facts(cls: type, name: str) -> str:
    for fact, (ok, what) in _FACTS.items():
        value = getattr(cls, fact)
        if not ok(value):
            return f"{cls.__name__}.{fact} = {value!r}: must be {what}"
    if cls.exports and not cls.export_kind:
        return f"{cls.__name__}.export_kind: what its model file is (\"a Python script\"), for messages, is missing"
    return ""
