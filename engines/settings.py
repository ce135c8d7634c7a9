"""Engine settings from dotted overrides: ``--set mujoco.w0_dt=0.05`` onto a frozen dataclass.

    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> from chatterbench.engines.settings import settings_with_overrides
    >>> settings_with_overrides(MujocoSettings(), ["mujoco.w0_dt=0.05"], prefix="mujoco").w0_dt
    0.05

Unknown keys are refused with the nearest valid name; values are parsed as TOML and
validated by the settings class itself.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Sequence, TypeVar

from chatterbench.reference.errors import InputError, did_you_mean
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
