"""Newton's penalty contact (``SolverSemiImplicit``): its restitution, the ke and kd that give a scene's R, its time scale.

    >>> from chatterbench.engines.newton_engine.penalty import (
    ...     restitution_of, damping_ratio_for, contact_duration)
    >>> zeta = damping_ratio_for(0.5)
    >>> round(zeta, 4), round(restitution_of(zeta), 12), round(contact_duration(zeta, w0=1000.0), 6)
    (0.5973, 0.5, 0.002731)

Newton 1.8's rigid contact in ``SolverSemiImplicit`` (``newton/_src/solvers/semi_implicit/
kernels_contact.py``, ``_eval_body_contact``) pushes with ``fn = d ke`` (d < 0 the penetration
[m]) plus ``fd = min(vn, 0) kd``: the damper acts only while the bodies approach (vn < 0), never
while they separate. In the relative coordinate x = -d [m] with w0^2 = ke / m and 2 zeta w0 =
kd / m (m = m1 m2 / (m1 + m2) [kg], the relative motion's mass)::

    x'' + 2 zeta w0 x' + w0^2 x = 0    while x' > 0 (compression),   x'' + w0^2 x = 0 after

From x(0) = 0, x'(0) = v0 the compression ends at its deepest, x_max = (v0 / w0) exp(-zeta b /
sin b) with cos b = zeta, and the undamped spring returns the body at w0 x_max, so

    e(zeta) = exp(-zeta b / sin b),  b = arccos(zeta)           (zeta < 1; continued past 1 as
                                                                  chatterbench.engines.restitution does)

which is the square root of the force-only damper's R (``engines/restitution.py``: R(zeta) =
exp(-2 zeta b / sin b)). So the damping ratio for R is that module's for R^2, found the same way
(bisection, 1e-12 in zeta). R = 0 needs infinite damping: the adapter uses ``plastic_zeta_w0_dt``
instead (the approach stopped in about one step, as MuJoCo's adapter does). One bounce lasts the
compression b / (w0 sin b) plus a quarter period pi / (2 w0).

Newton averages ke and kd over the two shapes of a contact, so both shapes carry the same values
(``ke_kd``). Where digits could be lost: near zeta = 1 the module this wraps uses a series.
"""

from __future__ import annotations

import math

from ..restitution import contact_phase, damping_ratio_from_restitution


def restitution_of(zeta: float) -> float:
    """Newton's e of the compression-damped contact with damping ratio ``zeta`` >= 0 (module docstring); inf: 0."""
    if math.isinf(zeta):
        return 0.0
    if not zeta >= 0.0:
        raise ValueError(f"zeta = {zeta!r}: damping ratio must be a number >= 0")
    return math.exp(-0.5 * zeta * contact_phase(zeta))


def damping_ratio_for(restitution: float) -> float:
    """The damping ratio whose compression-damped contact rebounds with ``restitution`` R in [0, 1); R = 0: inf."""
    return damping_ratio_from_restitution(restitution * restitution)


def contact_duration(zeta: float, w0: float) -> float:
    """One bounce [s]: compression b / (w0 sin b) (cos b = zeta, continued past 1) and a quarter period pi / (2 w0)."""
    if not (w0 > 0.0 and math.isfinite(w0)):
        raise ValueError(f"w0 = {w0!r}: natural frequency must be a finite number > 0 [rad/s]")
    return (0.5 * contact_phase(zeta) + 0.5 * math.pi) / w0 if math.isfinite(zeta) else math.inf


def relative_mass(mass1: float, mass2: float) -> float:
    """The relative motion's mass m1 m2 / (m1 + m2) [kg] (m2 for an infinite body 1)."""
    return mass2 if math.isinf(mass1) else mass1 * mass2 / (mass1 + mass2)


def ke_kd(w0: float, zeta: float, mass: float) -> tuple[float, float]:
    """Per-shape stiffness ke = m w0^2 [N/m] and damping kd = 2 zeta m w0 [N s/m] for the relative mass ``mass``."""
    return mass * w0 * w0, 2.0 * zeta * mass * w0
