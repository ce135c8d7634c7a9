"""MuJoCo Warp's settings: MuJoCo's (``MujocoSettings``, the same model and contact law) plus precision and device.

    >>> from chatterbench.engines.mujoco_warp_engine.settings import MujocoWarpSettings
    >>> s = MujocoWarpSettings(dt=1e-3)
    >>> s.w0, s.precision, s.device
    (30.0, 'float32', 'auto')
    >>> MujocoWarpSettings(precision="float64")
    Traceback (most recent call last):
    ...
    chatterbench.engines.settings.SettingsError: mujoco_warp.precision = 'float64': must be one of float32 (mujoco_warp computes in float32 only)

Every MuJoCo field means what it means for MuJoCo C, and is checked the same way; the
messages name ``mujoco_warp.FIELD`` (the ``--set`` key that sets it). Two choices MuJoCo C
has are refused because MuJoCo Warp 4.0 lacks them: the ``PGS`` solver, and any precision
but float32 (every array of ``mujoco_warp`` is ``wp.float32``; there is no float64 build).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from chatterbench.reference.errors import check_choice

from ..mujoco_engine.settings import SOLVERS, MujocoSettings
from ..settings import SettingsError

PRECISIONS = ("float32",)  # mujoco_warp 4.0.0: every Model / Data array is wp.float32
DEVICES = ("auto", "cpu", "cuda")  # auto: cuda when warp finds a GPU, else cpu
WARP_SOLVERS = tuple(name for name in SOLVERS if name != "PGS")  # mujoco_warp.SolverType: CG, Newton
PREFIX = "mujoco_warp"


def _renamed(exc: SettingsError) -> SettingsError:
    """MuJoCo's message with its ``mujoco.`` keys named as this engine's ``mujoco_warp.`` keys."""
    return SettingsError(re.sub(r"\bmujoco\.", f"{PREFIX}.", str(exc)))


@dataclass(frozen=True)
class MujocoWarpSettings(MujocoSettings):
    """How MuJoCo Warp runs a scene: ``MujocoSettings``' fields, and where and in what precision it computes."""

    precision: str = "float32"  # floating-point type of every engine array: "float32" (the only one mujoco_warp has)
    device: str = "auto"  # warp device: "auto" (cuda when present, else cpu), "cpu" or "cuda"

    def __post_init__(self) -> None:
        try:
            super().__post_init__()
        except SettingsError as exc:
            raise _renamed(exc) from None
        check_choice(f"{PREFIX}.solver", self.solver, WARP_SOLVERS, error=SettingsError)
        if self.precision not in PRECISIONS:
            raise SettingsError(f"{PREFIX}.precision = {self.precision!r}: must be one of {', '.join(PRECISIONS)} "
                                "(mujoco_warp computes in float32 only)")
        check_choice(f"{PREFIX}.device", self.device, DEVICES, error=SettingsError)

    def check_stability(self, zeta: float) -> None:
        """``MujocoSettings.check_stability``, naming this engine's keys."""
        try:
            super().check_stability(zeta)
        except SettingsError as exc:
            raise _renamed(exc) from None
