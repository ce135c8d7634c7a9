"""MuJoCo's settings for a scene: timestep, contact stiffness, integrator, solver, and their limits.

    >>> from chatterbench.engines.mujoco_engine.settings import MujocoSettings, stability_limit
    >>> MujocoSettings(dt=1e-4, w0_dt=0.03).w0                 # contact natural frequency [rad/s]
    300.0
    >>> round(stability_limit("euler", 0.2553), 3)             # largest stable w0 dt for R = 0.5
    1.554

Every field is checked when the settings are made (``SettingsError`` naming the field, the
value and the allowed range), so an engine never starts with a user mistake.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco

from chatterbench.reference.errors import check_bool, check_choice, check_number

from ..restitution import damping_ratio_from_restitution
from ..settings import SettingsError

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}
SOLVERS = {
    "Newton": mujoco.mjtSolver.mjSOL_NEWTON,
    "PGS": mujoco.mjtSolver.mjSOL_PGS,
    "CG": mujoco.mjtSolver.mjSOL_CG,
}
GAP_MODELS = ("limit", "geom")
# zeta for R, found by bisection (``restitution.py``): kept, since every run of a study asks for the same few R
_damping_ratio = functools.lru_cache(maxsize=1024)(damping_ratio_from_restitution)
IMPEDANCE_RANGE = (1e-4, 0.9999)  # MuJoCo clamps solimp to [mjMINIMP, mjMAXIMP]
@functools.lru_cache(maxsize=1024)  # every run checks its settings; a study asks about a few (integrator, zeta)
def stability_limit(integrator: str, zeta: float) -> float:
    """Largest w0 dt for which a persistent contact (x'' + 2 zeta w0 x' + w0^2 x = 0) is stable.

    ``euler`` and ``implicitfast`` integrate constraint forces explicitly (semi-implicit
    Euler, v+ = v + h a, x+ = x + h v+): the step matrix has det = 1 - 2 zeta a and
    trace = 2 - 2 zeta a - a^2 (a = w0 dt); Jury's conditions give
    a < 2 (sqrt(1 + zeta^2) - zeta) and a < 1 / zeta. ``rk4``: the largest a with
    |P(a lambda)| <= 1 for both roots lambda, P the RK4 polynomial (found by bisection).
    """
    if integrator in ("euler", "implicitfast"):
        lim = 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta)
        return min(lim, 1.0 / zeta) if zeta > 0 else lim
    if zeta < 1.0:
        roots = [complex(-zeta, math.sqrt(1.0 - zeta * zeta))]
    else:
        sq = math.sqrt(zeta * zeta - 1.0)
        roots = [complex(-zeta + sq, 0.0), complex(-zeta - sq, 0.0)]

    def stable(a: float) -> bool:
        for lam in roots:
            z = a * lam
            if abs(1 + z + z * z / 2 + z**3 / 6 + z**4 / 24) > 1.0 + 1e-12:
                return False
        return True

    lo, hi = 0.0, 3.0 / max(1.0, abs(roots[-1]))
    while stable(hi):
        lo, hi = hi, 2.0 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


# the most permissive limit over zeta, for checks made before the scene (and its zeta) is known
_LOOSEST_LIMIT = {name: max(stability_limit(name, z / 100.0) for z in range(101)) for name in INTEGRATORS}


@dataclass(frozen=True)
class MujocoSettings:
    """How MuJoCo runs a scene (MuJoCo's own names where it has one)."""

    dt: float = 1e-4  # MuJoCo's timestep [s], > 0
    w0_dt: float = 0.03  # contact natural frequency times dt [-], > 0, <= stability limit
    integrator: str = "euler"  # "euler", "implicitfast" or "rk4"
    gap_model: str = "limit"  # "limit": joint range of y; "geom": wall boxes vs a ball
    solver: str = "Newton"  # MuJoCo's constraint solver: "Newton" (exact for one row), "PGS" (~35% faster), "CG"
    impedance: float = 0.99  # constant solimp d [-], in [1e-4, 0.9999]
    allow_unstable: bool = False  # accept w0_dt above the integrator's stability limit
    ball_radius: float = 0.01  # radius of body 2's sphere in the geom model [m], > 0
    wall_thickness: float = 0.01  # thickness of the wall boxes in the geom model [m], > 0
    plastic_zeta_w0_dt: float = 0.5  # for R = 0: zeta w0 dt; 0.5 stops the approach in one Euler step [-]

    def __post_init__(self) -> None:
        for name in ("dt", "w0_dt", "ball_radius", "wall_thickness", "plastic_zeta_w0_dt"):
            object.__setattr__(self, name, check_number(f"mujoco.{name}", getattr(self, name), lo=0.0, lo_open=True,
                                                        error=SettingsError))
        check_bool("mujoco.allow_unstable", self.allow_unstable, error=SettingsError)
        check_choice("mujoco.integrator", self.integrator, list(INTEGRATORS), error=SettingsError)
        check_choice("mujoco.solver", self.solver, list(SOLVERS), error=SettingsError)
        check_choice("mujoco.gap_model", self.gap_model, GAP_MODELS, error=SettingsError)
        lo, hi = IMPEDANCE_RANGE
        object.__setattr__(self, "impedance", check_number("mujoco.impedance", self.impedance, lo=lo, hi=hi,
                                                           unit=" (MuJoCo's solimp range)", error=SettingsError))
        # the scene's zeta is not known here: refuse what no zeta allows; build() checks
        # again with the scene's own zeta
        loosest = _LOOSEST_LIMIT[self.integrator]
        if self.w0_dt > loosest and not self.allow_unstable:
            raise SettingsError(
                f"mujoco.w0_dt = {self.w0_dt!r}: must be in (0, {loosest:.4g}], the stability limit of "
                f"{self.integrator} for any contact damping (0.1 or less keeps the restitution within ~2%); "
                "set mujoco.allow_unstable=true to run it anyway"
            )

    @property
    def w0(self) -> float:
        """Contact natural frequency [rad/s]."""
        return self.w0_dt / self.dt

    def check_stability(self, zeta: float) -> None:
        """Raise SettingsError when w0_dt exceeds the integrator's stability limit for ``zeta``."""
        limit = stability_limit(self.integrator, zeta)
        if self.w0_dt > limit and not self.allow_unstable:
            raise SettingsError(
                f"mujoco.w0_dt = {self.w0_dt!r}: must be in (0, {limit:.4g}], the stability limit of "
                f"{self.integrator} for a contact with damping ratio {zeta:.4g} (0.1 or less keeps "
                "the restitution within ~2%); set mujoco.allow_unstable=true to run it anyway"
            )

    def zeta(self, restitution: float) -> float:
        """Contact damping ratio for Newton's R (R = 0: zeta = plastic_zeta_w0_dt / w0_dt)."""
        if restitution == 0.0:
            return self.plastic_zeta_w0_dt / self.w0_dt
        return _damping_ratio(restitution)


