"""Engine settings from dotted overrides: ``--set mujoco.w0_dt=0.05`` onto a frozen dataclass.

    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> from chatterbench.engines.settings import settings_with_overrides
    >>> settings_with_overrides(MujocoSettings(), ["mujoco.w0_dt=0.05"], prefix="mujoco").w0_dt
    0.05

Unknown keys are refused with the nearest valid name; values are parsed as TOML and
validated by the settings class itself, with the checks here (``check_dt``, ``check_number``,
``check_integer``, ``check_choice``: ``SettingsError`` naming the field and its range, which a
plugin imports from ``api.py``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Sequence, TypeVar

from chatterbench.reference.errors import InputError, did_you_mean
from chatterbench.reference.errors import check_choice as _check_choice
from chatterbench.reference.errors import check_integer as _check_integer
from chatterbench.reference.errors import check_number as _check_number
from chatterbench.reference.scene import split_assignment

T = TypeVar("T")


class SettingsError(InputError):
    """An engine setting is unknown or out of range; the message names it."""


def settings_with_overrides(base: T, overrides: Sequence[str] | Mapping[str, Any], prefix: str) -> T:
    """Return ``base`` with every ``PREFIX.KEY=VALUE`` override applied (others are ignored)."""
    items = overrides.items() if isinstance(overrides, Mapping) else (split_assignment(s) for s in overrides)
    names = [f.name for f in dataclasses.fields(base)]
    changes: dict[str, Any] = {}
    for key, value in items:
        head, _, rest = key.partition(".")
        if head != prefix:
            continue
        if rest not in names:
            raise SettingsError(
                f"--set {key}: unknown {prefix} setting; allowed: {', '.join(names)}" + did_you_mean(rest, names)
            )
        changes[rest] = value
    try:
        return dataclasses.replace(base, **changes)
    except TypeError as exc:
        raise SettingsError(f"{prefix} settings: {exc}") from None


def check_dt(engine: str, dt: Any) -> float:
    """Engine ``engine``'s step ``dt`` [s] as a float when it is a finite number > 0, else ``SettingsError`` naming
    ``ENGINE.dt`` and the range (``euler.dt = 0: must be > 0 [s]``): what every settings ``__post_init__`` checks."""
    return _check_number(f"{engine}.dt", dt, lo=0.0, lo_open=True, unit=" [s]", error=SettingsError)


def check_number(where: str, value: Any, lo: float | None = None, hi: float | None = None, lo_open: bool = False,
                 hi_open: bool = False, unit: str = "") -> float:
    """A setting ``value`` as a float when it is a finite number in the range, else ``SettingsError`` naming ``where``
    (``"euler.damping"``) and the range, with ``unit`` (``" [s]"``) after it."""
    return _check_number(where, value, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open, unit=unit, error=SettingsError)


def check_integer(where: str, value: Any, lo: int | None = None, hi: int | None = None) -> int:
    """A setting ``value`` when it is an integer (not a bool) in [lo, hi], else ``SettingsError`` naming ``where``."""
    return _check_integer(where, value, lo=lo, hi=hi, error=SettingsError)


def check_choice(where: str, value: Any, allowed: Sequence[str]) -> str:
    """A setting ``value`` when it is one of ``allowed``, else ``SettingsError`` naming ``where`` and listing them."""
    return _check_choice(where, value, allowed, error=SettingsError)
