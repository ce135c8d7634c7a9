"""Feigin's sliding plate Pi_2: the sufficient conditions (2.1)-(2.2) for a strike to slide.

    >>> from chatterbench.reference.plate import plate_conditions
    >>> plate_conditions(restitution=0.5, v=-0.01, acc=-0.8, jerk_min=0.6, jerk_max=1.0, window=1.0)
    PlateVerdict(inside=True, failed='')

All quantities are in wall-normal form: for a strike at the lower wall that is y - lower,
for the upper wall upper - y, so the gap opens upwards, ``v = y'`` < 0 is the incoming
speed, ``acc = y''`` < 0 pushes into the wall and the edge of the plate is reached with
``jerk = y''' > 0``. Units: m/s, m/s^2, m/s^3, s.

The conditions, on a window [t0, t0 + t*] (Feigin 1967):

    0 < Y* <= y''' <= Y,    (9R - 5) / (12 R) < Y* / Y                      (2.1)
    0 < -y'' < 2 Y t* / (3 - sqrt(4 + 5R)),
    0 < -y' / y''^2 < 5 (1 - R) / (24 R Y)                                   (2.2)

The window runs from the strike to the edge of the plate, where the free relative
acceleration along the constrained motion returns to zero (y'' = 0, y''' > 0): the proof
applies one Y, Y* to every later impact of the sequence, and they all happen before the
edge. The second inequality of (2.2) then says that the bound (2.4) on the first free
flight, tau_1 < -y'' (3 - sqrt(4 + 5R)) / (2 Y), fits inside that window. Y and Y* are the
extremes of y''' over the window, found from the closed-form motion (see
``jerk_bounds``). The conditions are sufficient, not necessary: a strike that fails them
may still slide (the event loop's accumulation test catches those).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

SAMPLES = 64  # samples of y''' per flow step when bounding it over a window


class PlateVerdict(NamedTuple):
    """Whether a strike lies in Pi_2, and the first condition that failed if not."""

    inside: bool
    failed: str  # "" when inside; else which inequality of (2.1)-(2.2) failed


def plate_bound_speed(restitution: float, acc: float, jerk_max: float) -> float:
    """Largest incoming speed |y'| allowed by (2.2): 5 (1 - R) / (24 R Y) * y''^2 [m/s]."""
    r = restitution
    return 5.0 * (1.0 - r) / (24.0 * r * jerk_max) * acc * acc


def plate_conditions(
    restitution: float, v: float, acc: float, jerk_min: float, jerk_max: float, window: float
) -> PlateVerdict:
    """Check (2.1)-(2.2) for a strike (wall-normal form; see the module docstring).

    Parameters
    ----------
    restitution : float
        R, 0 < R < 1 (R = 0 always sticks when acc < 0 and needs no plate).
    v, acc : float
        Incoming relative velocity y' [m/s] and free relative acceleration y'' [m/s^2].
    jerk_min, jerk_max : float
        Y*, Y: bounds of y''' over the window [m/s^3].
    window : float
        t*, the window length [s].
    """
    r = restitution
    if not r > 0.0:
        return PlateVerdict(False, "R > 0")
    if not jerk_min > 0.0:
        return PlateVerdict(False, "0 < Y* (2.1)")
    if not jerk_min / jerk_max > (9.0 * r - 5.0) / (12.0 * r):
        return PlateVerdict(False, "(9R - 5)/(12R) < Y*/Y (2.1)")
    if not 0.0 < -acc < 2.0 * jerk_max * window / (3.0 - math.sqrt(4.0 + 5.0 * r)):
        return PlateVerdict(False, "0 < -y'' < 2 Y t*/(3 - sqrt(4 + 5R)) (2.2)")
    if not 0.0 < -v < plate_bound_speed(r, acc, jerk_max):
        return PlateVerdict(False, "0 < -y'/y''^2 < 5(1 - R)/(24 R Y) (2.2)")
    return PlateVerdict(True, "")


def quick_reject(restitution: float, v: float, acc: float, jerk: float) -> bool:
    """True when the strike certainly fails (2.1)-(2.2), judged from its own y''' alone.

    Y >= y'''(t0) >= Y*, so y''' <= 0, y'' >= 0, y' >= 0 or a speed above the (2.2) bound
    computed with Y = y'''(t0) rule the strike out without bounding y''' over a window.
    """
    if not (jerk > 0.0 and acc < 0.0 and v < 0.0 and restitution > 0.0):
        return True
    return -v >= plate_bound_speed(restitution, acc, jerk)


@numba.njit(cache=True)
def jerk_bounds(coeffs: np.ndarray, span: float) -> tuple[float, float]:
    """Min and max over [0, span] of a function given by Taylor coefficients about 0.

    ``coeffs`` (k = 0..order) must describe the function accurately on the whole span
    (the caller walks flow steps and calls this per step). The extremes are the best of
    ``SAMPLES`` + 1 samples, each refined by one parabola through its neighbours, so the
    error is third order in the sample spacing. Compiled with numba.
    """
    n = len(coeffs)
    vals = np.empty(SAMPLES + 1)
    du = span / SAMPLES
    for i in range(SAMPLES + 1):
        x = i * du
        p = 0.0
        for k in range(n - 1, -1, -1):
            p = p * x + coeffs[k]
        vals[i] = p
    lo_i = 0
    hi_i = 0
    for i in range(SAMPLES + 1):
        if vals[i] < vals[lo_i]:
            lo_i = i
        if vals[i] > vals[hi_i]:
            hi_i = i
    out_lo = vals[lo_i]
    out_hi = vals[hi_i]
    for j in range(2):
        i = lo_i if j == 0 else hi_i
        if 0 < i < SAMPLES:
            a, b, c = vals[i - 1], vals[i], vals[i + 1]
            denom = a - 2.0 * b + c
            if denom != 0.0:
                x = i * du + 0.5 * (a - c) / denom * du
                p = 0.0
                for k in range(n - 1, -1, -1):
                    p = p * x + coeffs[k]
                if j == 0:
                    out_lo = min(out_lo, p)
                else:
                    out_hi = max(out_hi, p)
    return out_lo, out_hi
