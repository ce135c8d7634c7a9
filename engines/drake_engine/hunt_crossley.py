"""Restitution of Drake's Hunt-Crossley point contact, f = k x (1 + d x'), as a function of d times the impact speed.

    >>> from chatterbench.engines.drake_engine.hunt_crossley import dissipation_speed, restitution_at
    >>> c = dissipation_speed(0.5)                 # d v at which an impact at speed v rebounds with 0.5
    >>> round(c, 6), round(restitution_at(c), 12), round(restitution_at(c / 2), 4)   # half the speed: livelier
    (1.432751, 0.5, 0.6734)

Drake's compliant point contact (continuous plants, and the TAMSI / similar / lagged discrete
approximations) pushes with f = k x (1 + d x')+ for a penetration x > 0 [m] growing at x' [m/s]
(d [s/m] is ``hunt_crossley_dissipation``). For the relative coordinate, with w0^2 = k / m
(m the reduced mass) and v = x'::

    v dv / dx = -w0^2 x (1 + d v)    =>    v dv / (1 + d v) = -w0^2 x dx

Integrated from the touch (x = 0, v = v0) to the release (x = 0, v = -e v0), with c = d v0
and u = v / v0, the right side vanishes and [u / c - ln(1 + c u) / c^2] from 1 to -e = 0:

    c (1 + e) = ln((1 + c) / (1 - c e))                                       (HC)

so the rebound e depends on d and the impact speed only through c = d v0 (not on k nor the
masses): a slower impact is livelier, which is why one d cannot give one R at every speed
(the bouncing ball's rebounds climb as it slows). The force cannot vanish inside the
body (1 + d v > 0 holds up to the release, since ln(1 - c u) -> -inf as u -> -1/c), so
release is at x = 0. ``impact`` integrates the ODE itself (fixed-step RK4), the check of
(HC) in the tests and the contact's duration.

Promises: ``restitution_at`` and ``dissipation_speed`` are inverses, found by bisection on
the monotone map (HC) to 1e-13 in e and relative 1e-13 in c; ln(1 + .) is ``log1p`` so
that c near 0 (e near 1) loses no digits to 1 - 1.
"""

from __future__ import annotations

import math
from typing import NamedTuple

TOLERANCE = 1e-13  # bisection tolerance: absolute in e [-], relative in c [-]
ODE_STEPS_PER_RADIAN = 200  # RK4 steps per unit of w0 t in ``impact`` [-]


def _gap(c: float, e: float) -> float:
    """ln((1 + c) / (1 - c e)) - c (1 + e): zero at the (HC) rebound, increasing in e."""
    return math.log1p(c) - math.log1p(-c * e) - c * (1.0 + e)


def _bisect(f, lo: float, hi: float, tol: float) -> float:
    """The root of an increasing f on [lo, hi] (f(lo) <= 0 < f(hi)), to ``tol``."""
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) <= 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


def restitution_at(c: float) -> float:
    """The rebound e of an impact with d v0 = ``c`` >= 0 (module docstring, (HC)); 1 at c = 0."""
    if isinstance(c, bool) or not isinstance(c, (int, float)) or not (c >= 0.0 and math.isfinite(c)):
        raise ValueError(f"c = {c!r}: d v0 must be a finite number >= 0")
    if c == 0.0:
        return 1.0
    hi = min(1.0, (1.0 - 1e-16) / c)  # e < 1 / c keeps 1 - c e > 0
    return _bisect(lambda e: _gap(c, e), 0.0, hi, TOLERANCE)


def dissipation_speed(restitution: float) -> float:
    """The c = d v0 whose impact rebounds with ``restitution`` e in (0, 1): d = c / v0 [s/m].

    e -> 0 needs c -> inf (c ~ ln(c) / e): no finite dissipation is perfectly plastic.
    """
    e = restitution
    if isinstance(e, bool) or not isinstance(e, (int, float)) or not 0.0 < e < 1.0:
        raise ValueError(f"restitution = {e!r}: must be in (0, 1) for a Hunt-Crossley contact")
    # _gap(c, e) as a function of c: 0 at c = 0, negative just after, +inf at c = 1 / e
    lo, hi = 0.0, 1.0 / e
    while hi - lo > TOLERANCE * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _gap(mid, e) <= 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


class Impact(NamedTuple):
    """One Hunt-Crossley impact in units of the contact: speeds / v0, times * w0."""

    restitution: float  # e = rebound speed / impact speed [-]
    duration: float  # w0 t from touch to release [-]
    depth: float  # largest penetration w0 x / v0 [-]


def impact(c: float) -> Impact:
    """Integrate xi'' = -xi (1 + c xi') from xi = 0, xi' = 1 until xi returns to 0 (RK4).

    The release is located by linear interpolation inside the last step (error ~ h^2: below
    1e-5 in e and in the time at ``ODE_STEPS_PER_RADIAN``); e is read there.
    """
    h = 1.0 / ODE_STEPS_PER_RADIAN

    def acc(x: float, v: float) -> float:
        return -x * max(0.0, 1.0 + c * v)

    x, v, t, deepest = 0.0, 1.0, 0.0, 0.0
    while True:
        k1x, k1v = v, acc(x, v)
        k2x, k2v = v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v)
        k3x, k3v = v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v)
        k4x, k4v = v + h * k3v, acc(x + h * k3x, v + h * k3v)
        x1 = x + h * (k1x + 2 * k2x + 2 * k3x + k4x) / 6.0
        v1 = v + h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6.0
        if x1 <= 0.0 and t > 0.0:
            s = x / (x - x1)  # the fraction of the step at which xi = 0
            return Impact(restitution=-(v + s * (v1 - v)), duration=t + s * h, depth=deepest)
        x, v, t = x1, v1, t + h
        deepest = max(deepest, x)
