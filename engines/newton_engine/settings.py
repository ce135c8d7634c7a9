"""Newton's settings for a scene, one dataclass per solver: the knobs that change a bounce, each checked when made.

    >>> from chatterbench.engines.newton_engine.settings import XpbdSettings, SemiSettings
    >>> XpbdSettings().iterations, SemiSettings().w0_dt           # Newton's XPBD default: 2 iterations
    (2, 0.03)
    >>> SemiSettings(w0_dt=3.0)
    Traceback (most recent call last):
    chatterbench.engines.settings.SettingsError: newton_semi.w0_dt = 3.0: must be in (0, 1]

Every field is checked when the settings are made (``SettingsError`` naming ``ENGINE.FIELD``, the
value and the allowed range: ``chatterbench.engines.api``'s checks). Where each goes in Newton 1.8:
``XpbdSettings``' solver fields are ``SolverXPBD``'s keyword arguments (``enable_restitution=True``
always); ``SemiSettings`` sets each shape's ``ke`` and ``kd`` (``ModelBuilder.ShapeConfig``) from
the contact's natural frequency ``w0_dt / dt`` and the damping ratio that gives the scene's R
(``penalty.py``). Both: no friction (``mu = 0``), no angular damping, ``gravity_in_model``.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..api import SettingsError, check_choice, check_dt, check_integer, check_number

DEVICES = ("auto", "cpu", "cuda")  # "auto": cuda where warp finds a GPU, else warp's CPU device


def _check_bool(where: str, value: object) -> bool:
    if not isinstance(value, bool):
        raise SettingsError(f"{where} = {value!r}: must be true or false")
    return value


@dataclass(frozen=True)
class XpbdSettings:
    """``SolverXPBD(model, enable_restitution=True, ...)``: Newton's position-based solver with its restitution pass."""

    dt: float = 1e-4  # [s] the step, > 0
    iterations: int = 2  # position-constraint iterations per step, >= 1 (Newton: 2)
    rigid_contact_relaxation: float = 0.8  # share of a contact's position correction applied per iteration, (0, 1] (Newton: 0.8)
    # outer iterations of the velocity-level restitution solve, >= 1 (Newton: 2); 1 suffices for one contact per body
    restitution_iterations: int = 2
    # The scene's gravity in Newton's model (as a user's model has it) rather than in the applied forces. XPBD's
    # restitution acts only on approach speeds above 2 |g| dt (``restitution_kernels.build_restitution_manifolds``):
    # slower impacts are plastic, so the chatter ends early. False: gravity applied as a force, no threshold.
    gravity_in_model: bool = True
    device: str = "auto"  # warp device: "auto" (cuda where present, else cpu), "cpu" or "cuda"
    # Newton model length units per metre, >= 1: 1 a model in metres, 1000 in millimetres (masses in kg either way).
    # XPBD sets every body's speed below 1e-4 model units/s to 0 (``kernels.apply_body_deltas``): 1e-4 m/s in metres,
    # 1e-7 m/s in millimetres. The same physics otherwise (float32 keeps the same relative precision).
    length_unit: float = 1.0

    def __post_init__(self) -> None:
        check_dt("newton_xpbd", self.dt)
        check_number("newton_xpbd.length_unit", self.length_unit, lo=1.0, hi=1e6)
        check_integer("newton_xpbd.iterations", self.iterations, lo=1, hi=1000)
        check_number("newton_xpbd.rigid_contact_relaxation", self.rigid_contact_relaxation, lo=0.0, hi=1.0, lo_open=True)
        check_integer("newton_xpbd.restitution_iterations", self.restitution_iterations, lo=1, hi=100)
        _check_bool("newton_xpbd.gravity_in_model", self.gravity_in_model)
        check_choice("newton_xpbd.device", self.device, DEVICES)

    def threshold(self, gravity: float) -> float:
        """The approach speed [m/s] below which XPBD's restitution does not act: 2 |g| dt, g in the model."""
        return 2.0 * abs(gravity) * self.dt if self.gravity_in_model else 0.0


@dataclass(frozen=True)
class SemiSettings:
    """``SolverSemiImplicit``: Newton's symplectic Euler with penalty contact (per-shape ke, kd)."""

    dt: float = 1e-4  # [s] the step, > 0
    # contact natural frequency times dt, (0, 1]: ke = m w0^2 with w0 = w0_dt / dt (m the relative mass). One bounce
    # lasts about 1.4 pi / w0_dt steps (R = 0.5: 150 steps at 0.03); above 1 the explicit spring nears its limit, 2.
    w0_dt: float = 0.03
    # factor on the damping kd that gives the scene's R (1: R exactly, in continuous time), >= 0; 0: undamped (e = 1)
    kd_scale: float = 1.0
    plastic_zeta_w0_dt: float = 0.5  # for R = 0 (infinite damping): zeta w0 dt, (0, 1], about one step to stop
    gravity_in_model: bool = True  # the scene's gravity in Newton's model (the contact law does not read it)
    device: str = "auto"  # warp device: "auto" (cuda where present, else cpu), "cpu" or "cuda"

    def __post_init__(self) -> None:
        check_dt("newton_semi", self.dt)
        check_number("newton_semi.w0_dt", self.w0_dt, lo=0.0, hi=1.0, lo_open=True)
        check_number("newton_semi.kd_scale", self.kd_scale, lo=0.0, hi=100.0)
        check_number("newton_semi.plastic_zeta_w0_dt", self.plastic_zeta_w0_dt, lo=0.0, hi=1.0, lo_open=True)
        _check_bool("newton_semi.gravity_in_model", self.gravity_in_model)
        check_choice("newton_semi.device", self.device, DEVICES)

    @property
    def w0(self) -> float:
        """The contact's natural frequency [rad/s]."""
        return self.w0_dt / self.dt

    def zeta(self, restitution: float) -> float:
        """The damping ratio for R, times ``kd_scale`` (R = 0: ``plastic_zeta_w0_dt / w0_dt``)."""
        from .penalty import damping_ratio_for

        base = self.plastic_zeta_w0_dt / self.w0_dt if restitution == 0.0 else damping_ratio_for(restitution)
        return base * self.kd_scale
