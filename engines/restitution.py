"""Exact restitution of a force-only (unilateral) linear spring-damper contact, and its inverse.

    >>> from chatterbench.engines.restitution import (
    ...     damping_ratio_from_restitution, restitution_from_damping_ratio, contact_duration)
    >>> zeta = damping_ratio_from_restitution(0.5)
    >>> round(zeta, 4), round(restitution_from_damping_ratio(zeta), 12), round(contact_duration(zeta, w0=1000.0), 6)
    (0.2553, 0.5, 0.002715)

A penalty contact (MuJoCo's soft constraint in direct ``solref`` form, PyBullet's
ERP/CFM springs) is the relative-motion oscillator, x the penetration [m]::

    x'' + 2 zeta w0 x' + w0^2 x = 0,      x(0) = 0,  x'(0) = v0 > 0

The contact can only push, so it ends when the spring-damper force
``w0^2 x + 2 zeta w0 x'`` (= -x'') falls to zero, **not** when x returns to 0: the
damper's pull near the end is cut off, and the body leaves while still slightly
inside (x_end = 2 zeta R v0 / w0). With s = sqrt(1 - zeta^2) and wd = w0 s the force
vanishes at wd t_c = pi - 2 arcsin(zeta), where x' = -v0 exp(-zeta w0 t_c), hence

    R(zeta) = exp(-zeta (pi - 2 arcsin zeta) / sqrt(1 - zeta^2))        (zeta < 1)
    R(1)    = exp(-2)                                                    (critical)
    R(zeta) = exp(-2 zeta g / sinh g),  g = arccosh(zeta)                (zeta > 1)

(the three forms are one analytic function: zeta = cos b gives 2 b / sin b, and
b = i g continues it past zeta = 1). R falls monotonically from 1 at zeta = 0 to 0
as zeta -> inf (R ~ 1 / (4 zeta^2)), so every R in (0, 1) has exactly one zeta,
and R = 0 has none: ``damping_ratio_from_restitution(0)`` returns ``math.inf``
(a perfectly plastic contact needs infinite damping); engines must refuse or clamp it.
The textbook exp(-pi zeta / s) is the ratio at x = 0 of the two-sided oscillator and
overestimates the damping needed (R = 0.5 needs zeta = 0.2553, not 0.2155).

Promises: the inverse is found by bisection on the monotone map, to 1e-12 in zeta;
near zeta = 1 the two branches use a series for (pi - 2 arcsin z) / sqrt(1 - z^2)
so no digits are lost to 0/0.
"""

from __future__ import annotations

import math

CRITICAL_RESTITUTION = math.exp(-2.0)  # R at zeta = 1 [-]
ZETA_TOLERANCE = 1e-12  # absolute tolerance of the inverse in zeta [-]
_NEAR_CRITICAL = 1e-6  # |zeta - 1| below which the series form is used [-]


def contact_phase(zeta: float) -> float:
    """The contact's duration in units of 1 / w0 [-]: w0 t_c = (pi - 2 arcsin zeta) / sqrt(1 - zeta^2) for a
    spring-damper whose damping acts in both directions, continued to zeta >= 1 (the Newton penalty law, damped
    only while compressing, builds its own from it: ``newton_engine.penalty``).

    Near zeta = 1 both forms are 0/0: with e = 1 - zeta, 2b / sin b where cos b = zeta
    expands as 2 + 2e/3 + ... (b^2 = 2e + e^2/3 + ...), used for |e| < 1e-6 (error ~ e^2).
    """
    e = 1.0 - zeta
    if abs(e) < _NEAR_CRITICAL:
        return 2.0 + 2.0 * e / 3.0
    if zeta < 1.0:
        return (math.pi - 2.0 * math.asin(zeta)) / math.sqrt((1.0 - zeta) * (1.0 + zeta))
    g = math.acosh(zeta)
    return 2.0 * g / math.sinh(g)


def _check_zeta(zeta: float) -> float:
    if isinstance(zeta, bool) or not isinstance(zeta, (int, float)) or math.isnan(zeta) or zeta < 0.0:
        raise ValueError(f"zeta = {zeta!r}: damping ratio must be a number >= 0")
    return float(zeta)


def restitution_from_damping_ratio(zeta: float) -> float:
    """Newton's R of a unilateral spring-damper contact with damping ratio ``zeta`` (>= 0).

    Works for under-, critically and over-damped contacts (see the module docstring);
    ``zeta = inf`` gives 0. Independent of w0 and of the masses (zeta and w0 are those of
    the relative coordinate).
    """
    zeta = _check_zeta(zeta)
    if math.isinf(zeta):
        return 0.0
    return math.exp(-zeta * contact_phase(zeta))


def damping_ratio_from_restitution(restitution: float) -> float:
    """The damping ratio zeta whose unilateral contact rebounds with ``restitution`` R.

    R in (0, 1); R < exp(-2) = 0.135 gives an over-damped contact (zeta > 1).
    R = 0 returns ``math.inf`` (no finite damping is perfectly plastic). Accurate to 1e-12
    in zeta (bisection on the monotone R(zeta)).
    """
    r = restitution
    if isinstance(r, bool) or not isinstance(r, (int, float)) or math.isnan(r) or not 0.0 <= r < 1.0:
        raise ValueError(f"restitution = {r!r}: must be in [0, 1)")
    if r == 0.0:
        return math.inf
    # R(zeta) is decreasing; bracket it: R ~ 1 / (4 zeta^2) for large zeta
    lo, hi = 0.0, 1.0
    while restitution_from_damping_ratio(hi) > r:
        lo, hi = hi, 2.0 * hi
    while hi - lo > ZETA_TOLERANCE * max(1.0, hi):
        mid = 0.5 * (lo + hi)
        if restitution_from_damping_ratio(mid) > r:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def contact_duration(zeta: float, w0: float) -> float:
    """Time [s] from first touch to the force reaching zero, for damping ratio ``zeta`` and
    natural frequency ``w0`` [rad/s]: t_c = (pi - 2 arcsin zeta) / (w0 sqrt(1 - zeta^2))
    (continued past zeta = 1). Equals pi / w0 for zeta = 0 and 2 / w0 at zeta = 1.
    """
    zeta = _check_zeta(zeta)
    if isinstance(w0, bool) or not isinstance(w0, (int, float)) or not (w0 > 0.0 and math.isfinite(w0)):
        raise ValueError(f"w0 = {w0!r}: natural frequency must be a finite number > 0 [rad/s]")
    if math.isinf(zeta):
        return math.inf
    return contact_phase(zeta) / w0


def exit_penetration(zeta: float, restitution: float, v0: float, w0: float) -> float:
    """Penetration [m] when the force-only contact lets go: x_end = 2 zeta R v0 / w0.

    The force w0^2 x + 2 zeta w0 x' is zero there and x' = -R v0.
    """
    return 2.0 * zeta * restitution * v0 / w0
