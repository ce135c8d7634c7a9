"""The parts of a scene: its force terms, the prescribed motion of body 1, the gap's walls and the initial state, each
frozen and validated on construction (the model and the signs: ``scene``'s module docstring).

    >>> from chatterbench.reference.scene_parts import Force, Gap
    >>> Force(kind="spring", on="coupling", stiffness=100.0, rest=0.05).params, Gap(lower=0.0, upper=0.1).walls
    (('stiffness', 'rest'), ('lower', 'upper'))

Every refusal is a ``SceneError`` naming the field, the value and what is allowed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import InputError, check_number, check_speed, did_you_mean

BODIES = ("body1", "body2", "coupling")
FORCE_KINDS = ("constant", "harmonic", "spring", "damper")


class SceneError(InputError):
    """A scene field has a value that is not allowed; the message names the field."""


def finite(where: str, value: Any) -> float:
    """``value`` as a finite float, else a SceneError naming ``where``."""
    return check_number(where, value, error=SceneError)


def positive(where: str, value: Any) -> float:
    """``value`` as a float > 0, else a SceneError naming ``where``."""
    return check_number(where, value, lo=0.0, lo_open=True, error=SceneError)


def non_negative(where: str, value: Any) -> float:
    """``value`` as a float >= 0, else a SceneError naming ``where``."""
    return check_number(where, value, lo=0.0, error=SceneError)


@dataclass(frozen=True)
class Force:
    """One force term (``scene``'s module docstring gives each kind's formula and sign).

    Only the parameters of its kind are used; the others stay at their defaults.
    """

    kind: str  # one of FORCE_KINDS
    on: str  # "body1", "body2" or "coupling"
    value: float = 0.0  # constant force [N]
    amplitude: float = 0.0  # harmonic amplitude [N]
    omega: float = 0.0  # harmonic angular frequency [rad/s], > 0 for harmonic
    phase: float = 0.0  # harmonic phase [rad]
    stiffness: float = 0.0  # spring stiffness [N/m], >= 0
    rest: float = 0.0  # spring rest position [m] (body) or rest separation y [m] (coupling)
    damping: float = 0.0  # damper coefficient [N s/m], >= 0

    _PARAMS = {
        "constant": ("value",),
        "harmonic": ("amplitude", "omega", "phase"),
        "spring": ("stiffness", "rest"),
        "damper": ("damping",),
    }

    def __post_init__(self) -> None:
        if self.kind not in FORCE_KINDS:
            raise SceneError(
                f"force kind = {self.kind!r}: must be one of {', '.join(FORCE_KINDS)}"
                + did_you_mean(str(self.kind), FORCE_KINDS)
            )
        if self.on not in BODIES:
            raise SceneError(
                f"force on = {self.on!r}: must be one of {', '.join(BODIES)}"
                + did_you_mean(str(self.on), BODIES)
            )
        for name in ("value", "amplitude", "omega", "phase", "stiffness", "rest", "damping"):
            object.__setattr__(self, name, finite(f"{self.kind} force {name}", getattr(self, name)))
        if self.kind == "harmonic":
            positive("harmonic force omega", self.omega)
        if self.kind == "spring":
            non_negative("spring force stiffness", self.stiffness)
        if self.kind == "damper":
            non_negative("damper force damping", self.damping)

    @property
    def params(self) -> tuple[str, ...]:
        """Names of the parameters this kind uses."""
        return self._PARAMS[self.kind]


@dataclass(frozen=True)
class Prescribed:
    """Prescribed harmonic motion of an infinite body 1: x1 = offset + amplitude sin(omega t + phase)."""

    amplitude: float = 0.0  # [m]
    omega: float = 1.0  # [rad/s], > 0
    phase: float = 0.0  # [rad]
    offset: float = 0.0  # [m]

    def __post_init__(self) -> None:
        finite("prescribed.amplitude", self.amplitude)
        positive("prescribed.omega", self.omega)
        finite("prescribed.phase", self.phase)
        finite("prescribed.offset", self.offset)

    def position(self, t):
        """x1(t) [m]; t may be a float or a numpy array [s]."""
        return self.offset + self.amplitude * np.sin(self.omega * t + self.phase)

    def velocity(self, t):
        """x1'(t) [m/s]."""
        return self.amplitude * self.omega * np.cos(self.omega * t + self.phase)

    def acceleration(self, t):
        """x1''(t) [m/s^2]."""
        return -self.amplitude * self.omega**2 * np.sin(self.omega * t + self.phase)


@dataclass(frozen=True)
class Gap:
    """Limits on y = x2 - x1 [m]: the ``lower`` wall and an optional ``upper`` wall."""

    lower: float = 0.0  # [m]
    upper: float | None = None  # [m], > lower; None: one-sided gap

    def __post_init__(self) -> None:
        finite("gap.lower", self.lower)
        if self.upper is not None:
            finite("gap.upper", self.upper)
            if not self.upper > self.lower:
                raise SceneError(
                    f"gap.upper = {self.upper!r}: must be > gap.lower = {self.lower!r}"
                )

    @property
    def walls(self) -> tuple[str, ...]:
        """Names of the walls present: ``("lower",)`` or ``("lower", "upper")``."""
        return ("lower",) if self.upper is None else ("lower", "upper")

    def position(self, wall: str) -> float:
        """y of the named wall [m]."""
        if wall == "lower":
            return self.lower
        if wall == "upper" and self.upper is not None:
            return self.upper
        raise SceneError(f"wall = {wall!r}: must be one of {', '.join(self.walls)}")


@dataclass(frozen=True)
class Initial:
    """Initial state: time [s], body 1 position [m] and velocity [m/s], gap y [m] and vy [m/s]."""

    t: float = 0.0
    x1: float = 0.0
    v1: float = 0.0
    y: float = 0.0
    vy: float = 0.0

    def __post_init__(self) -> None:
        for name in ("t", "x1", "v1", "y", "vy"):  # speeds slower than light (``errors.SPEED_OF_LIGHT``)
            value = finite(f"initial.{name}", getattr(self, name))
            _ = check_speed(f"initial.{name}", value, SceneError) if name in ("v1", "vy") else value
