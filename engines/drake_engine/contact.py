"""The Drake contact of a scene: stiffness from the scene's scales, dissipation calibrated so one impact gives R.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.drake_engine.contact import contact_law
    >>> from chatterbench.engines.drake_engine.settings import DrakeSettings
    >>> law = contact_law(load_scene("bouncing-ball"), DrakeSettings())
    >>> law.law, round(law.w0), round(law.calibration_speed, 4), round(law.dissipation, 4)   # v = sqrt(2 g), d = c / v
    ('hunt_crossley', 994, 4.4294, 0.3235)

**Calibration impact.** The speed v [m/s] and the free relative acceleration a [m/s^2] of
the scene's first impact (a strike, not a resting start) in the reference (``reference.simulate``, Feigin mode, first
events only; a from Feigin (1.2) at the wall). ``DrakeSettings.calibration_speed`` > 0
replaces v. A scene whose reference never strikes uses v = 1 m/s.

**Stiffness rule.** The contact lasts a fixed fraction ``contact_time_ratio`` of the flight
a perfectly elastic rebound of the calibration impact would make, 2 v / |a|: the contact's
natural frequency of the relative motion is w0 = pi |a| / (2 ratio v) (pi / w0 is the
undamped contact time), so that a chatter ladder is resolved down to the same fraction of
its first flight in every scene. Where a = 0 (no force at the wall) the flight is
replaced by the scene's ``time_scale``. ``DrakeSettings.w0`` > 0 sets w0 directly. The
point stiffness is k = m w0^2 with m the reduced mass (m2 for an infinite body 1).

**Dissipation.** Hunt-Crossley (continuous plants; TAMSI, similar, lagged):
d = c(R) / v with c from ``hunt_crossley.dissipation_speed`` (exact for the contact law, so
an impact at v rebounds with R; faster ones less, slower ones more). Kelvin-Voigt (SAP):
f = k (x + tau x'), a linear spring-damper with damping ratio zeta = w0 tau / 2, so
tau = 2 zeta / w0 with zeta = ``restitution.damping_ratio_from_restitution(R)``, the same
for every speed. R = 0 is run as ``plastic_restitution`` (no finite dissipation is plastic).
Either way the law is what is calibrated: the time discretisation (``dt``, ``accuracy``)
adds its own error, which is what the comparisons measure.

Drake combines two geometries' properties (``contact_properties.cc``): k = k1 k2 / (k1 + k2),
d = (k2 d1 + k1 d2) / (k1 + k2), tau = tau1 + tau2. Each wall and the ball get 2 k, d and
tau / 2, so every pair has exactly k, d and tau (an infinite stiffness on one side would make
Drake's contact point 0 / 0 in discrete mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chatterbench.reference.forces import relative_acceleration
from chatterbench.reference.scene import Scene

from ..restitution import contact_duration, damping_ratio_from_restitution
from .hunt_crossley import dissipation_speed, impact
from .settings import DrakeSettings

FALLBACK_SPEED = 1.0  # [m/s] calibration speed of a scene whose reference never strikes
CALIBRATION_EVENTS = 16  # reference events run to find the first impact [-]


@dataclass(frozen=True)
class CalibrationImpact:
    """The impact the contact is calibrated at: its speed and the free acceleration there."""

    speed: float  # [m/s], > 0
    acceleration: float  # |y''| of the free motion at the wall [m/s^2], >= 0
    source: str  # "reference", "settings" or "fallback"


@dataclass(frozen=True)
class ContactLaw:
    """The contact Drake runs (module docstring): per wall pair, in the relative coordinate."""

    law: str  # "hunt_crossley" or "kelvin_voigt"
    restitution: float  # the R calibrated for [-] (the scene's, or plastic_restitution for R = 0)
    calibration_speed: float  # [m/s]
    w0: float  # natural frequency of the relative motion [rad/s]
    mass: float  # reduced mass [kg]
    dissipation: float  # Hunt-Crossley d [s/m] (0 for kelvin_voigt)
    relaxation_time: float  # SAP's tau [s] (0 for hunt_crossley)
    contact_time: float  # [s] touch to release of the calibration impact

    @property
    def stiffness(self) -> float:
        """Point contact stiffness k = m w0^2 [N/m] of a wall-ball pair."""
        return self.mass * self.w0**2

    def normal_force(self, depth: np.ndarray, rate: np.ndarray) -> np.ndarray:
        """Hunt-Crossley force k x (1 + d x')+ [N] for penetration ``depth`` x [m] (> 0 inside)
        growing at ``rate`` x' [m/s]; 0 where x <= 0. Drake's continuous point contact law."""
        push = self.stiffness * depth * np.maximum(0.0, 1.0 + self.dissipation * rate)
        return np.where(depth > 0.0, push, 0.0)


def reduced_mass(scene: Scene) -> float:
    """m1 m2 / (m1 + m2) [kg]; m2 when body 1 is infinite."""
    return scene.mass2 if scene.body1_infinite else scene.mass1 * scene.mass2 / (scene.mass1 + scene.mass2)


def calibration_impact(scene: Scene, settings: DrakeSettings) -> CalibrationImpact:
    """The first impact of the reference (speed, free acceleration), or the settings' speed (the
    reference is not run when the settings give both the speed and w0)."""
    from chatterbench.reference.simulate import Options, simulate

    if settings.calibration_speed > 0.0 and settings.w0 > 0.0:
        return CalibrationImpact(speed=settings.calibration_speed, acceleration=0.0, source="settings")

    log = simulate(scene, options=Options(max_events=CALIBRATION_EVENTS)).log
    hits = log[(log["kind"] == "impact") & (log["v_minus"] != 0.0)]  # not a resting start
    acc = 0.0
    speed, source = FALLBACK_SPEED, "fallback"
    if len(hits):
        first = hits.iloc[0]
        y = scene.gap.position(first["wall"])
        acc = abs(float(relative_acceleration(scene, first["t"], first["x1"], first["v1"], y, first["v_minus"])))
        speed, source = abs(float(first["v_minus"])), "reference"
    if settings.calibration_speed > 0.0:
        speed, source = settings.calibration_speed, "settings"
    return CalibrationImpact(speed=speed, acceleration=acc, source=source)


def contact_law(scene: Scene, settings: DrakeSettings, impact_at: CalibrationImpact | None = None) -> ContactLaw:
    """The contact for ``scene`` under ``settings`` (module docstring for the rules)."""
    cal = impact_at or calibration_impact(scene, settings)
    if settings.w0 > 0.0:
        w0 = settings.w0
    else:
        flight = 2.0 * cal.speed / cal.acceleration if cal.acceleration > 0.0 else scene.time_scale
        w0 = math.pi / (settings.contact_time_ratio * flight)
    r = scene.restitution if scene.restitution > 0.0 else settings.plastic_restitution
    if settings.law == "kelvin_voigt":
        zeta = damping_ratio_from_restitution(r)
        d, tau, t_c = 0.0, 2.0 * zeta / w0, contact_duration(zeta, w0)
    else:
        c = dissipation_speed(r)
        d, tau, t_c = c / cal.speed, 0.0, impact(c).duration / w0
    return ContactLaw(law=settings.law, restitution=r, calibration_speed=cal.speed, w0=w0, mass=reduced_mass(scene),
                      dissipation=d, relaxation_time=tau, contact_time=t_c)
