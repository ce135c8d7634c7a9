"""Feigin's sliding plate Pi_2, (2.1)-(2.2), and its reduction (4.2) for the section-4 example."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.reference.plate import (
    PlateVerdict,
    jerk_bounds,
    plate_bound_speed,
    plate_conditions,
    quick_reject,
)

SPEED_CONDITION = "0 < -y'/y''^2 < 5(1 - R)/(24 R Y) (2.2)"


def section4_strike(tau: float):
    """(acc, jerk_min, jerk_max, window) of a lower-wall strike at phase tau of y'' = -sin t.

    y'' = -sin tau, y''' = -cos t rises from -cos tau to 1 at the edge t = pi, so
    Y* = -cos tau, Y = 1 and the window to the edge is pi - tau.
    """
    return -math.sin(tau), -math.cos(tau), 1.0, math.pi - tau


def test_paper_constant():
    # 5 (1 - R) / (24 R) at R = 0.5 is 5/24 = 0.208333..., printed 0.21 in the paper;
    # 1e-15: one rounding of a handful of operations
    assert plate_bound_speed(0.5, acc=-1.0, jerk_max=1.0) == pytest.approx(5.0 / 24.0, rel=1e-15)
    assert round(plate_bound_speed(0.5, acc=-1.0, jerk_max=1.0), 4) == 0.2083
    assert round(plate_bound_speed(0.5, acc=-1.0, jerk_max=1.0), 2) == 0.21


def test_docstring_example():
    assert plate_conditions(0.5, v=-0.01, acc=-0.8, jerk_min=0.6, jerk_max=1.0, window=1.0) == PlateVerdict(True, "")


@pytest.mark.parametrize("R", [0.1, 0.3, 0.5])
def test_reduction_4_2(R):
    """Inside iff speed < 5 (1 - R) / (24 R) sin^2 tau for tau in (pi/2, pi), R <= 5/9.

    For R <= 5/9 the ratio condition (9R - 5)/(12R) <= 0 < Y*/Y holds for every tau, and
    sin tau <= pi - tau keeps the window condition true, so only the speed bound remains.
    Speeds are taken 1e-9 relative inside and outside the bound: far above the few
    roundings (1e-15) in computing it, so the verdict on each side is unambiguous.
    """
    k = 5.0 * (1.0 - R) / (24.0 * R)
    for tau in np.linspace(math.pi / 2, math.pi, 41)[1:-1]:
        acc, jmin, jmax, window = section4_strike(tau)
        bound = k * math.sin(tau) ** 2
        for frac in (1e-6, 0.1, 0.5, 0.95, 1.0 - 1e-9):
            assert plate_conditions(R, -frac * bound, acc, jmin, jmax, window).inside, (tau, frac)
        for frac in (1.0 + 1e-9, 1.5, 10.0):
            verdict = plate_conditions(R, -frac * bound, acc, jmin, jmax, window)
            assert verdict == PlateVerdict(False, SPEED_CONDITION), (tau, frac)
        # a strike moving away from the wall (y' >= 0) is not a strike into the plate
        assert plate_conditions(R, 0.0, acc, jmin, jmax, window).failed == SPEED_CONDITION


def test_reduction_fails_outside_the_phase_window():
    R = 0.5
    # tau in (0, pi/2): y''' = -cos tau < 0 at the strike, Y* <= 0
    for tau in (0.3, 1.0, 1.5):
        acc, jmin, jmax, window = section4_strike(tau)
        assert plate_conditions(R, -1e-6, acc, jmin, jmax, window).failed == "0 < Y* (2.1)"
    # tau in (pi, 3pi/2): y'' = -sin tau > 0 pulls away from the wall
    for tau in (3.2, 4.0):
        acc = -math.sin(tau)
        assert plate_conditions(R, -1e-6, acc, 0.5, 1.0, 1.0).failed == "0 < -y'' < 2 Y t*/(3 - sqrt(4 + 5R)) (2.2)"


def test_each_failing_inequality_names_itself():
    good = dict(restitution=0.5, v=-0.01, acc=-0.8, jerk_min=0.6, jerk_max=1.0, window=1.0)
    assert plate_conditions(**good).inside
    cases = [
        (dict(restitution=0.0), "R > 0"),
        (dict(jerk_min=0.0), "0 < Y* (2.1)"),
        (dict(jerk_min=-0.2), "0 < Y* (2.1)"),
        # R = 0.9: (9R - 5)/(12R) = 0.287 > Y*/Y = 0.1
        (dict(restitution=0.9, jerk_min=0.1), "(9R - 5)/(12R) < Y*/Y (2.1)"),
        (dict(acc=0.1), "0 < -y'' < 2 Y t*/(3 - sqrt(4 + 5R)) (2.2)"),
        (dict(acc=0.0), "0 < -y'' < 2 Y t*/(3 - sqrt(4 + 5R)) (2.2)"),
        # 2 Y t* / (3 - sqrt(6.5)) = 0.444 for t* = 0.1: -y'' = 0.8 is too deep for the window
        (dict(window=0.1), "0 < -y'' < 2 Y t*/(3 - sqrt(4 + 5R)) (2.2)"),
        (dict(v=0.01), SPEED_CONDITION),
        (dict(v=-0.2), SPEED_CONDITION),
    ]
    for change, failed in cases:
        verdict = plate_conditions(**{**good, **change})
        assert verdict == PlateVerdict(False, failed), change


def test_plate_shrinks_to_nothing_as_R_to_1():
    # section 4 of the note: the size of Pi_2 shrinks to nothing as R -> 1
    bounds = [plate_bound_speed(R, -1.0, 1.0) for R in (0.5, 0.9, 0.99, 0.999999)]
    assert all(a > b for a, b in zip(bounds, bounds[1:]))
    # 5 (1 - R)/(24 R) ~ 5e-6/24 at R = 1 - 1e-6; 1e-5 relative covers the 1/R factor
    assert bounds[-1] == pytest.approx(5e-6 / 24.0, rel=1e-5)


def test_quick_reject_is_sound():
    """quick_reject never throws out a strike that plate_conditions would accept.

    With Y >= y'''(t0) >= Y* its speed bound (with y'''(t0) for Y) is the looser one.
    """
    rng = np.random.default_rng(7)
    accepted = 0
    for _ in range(20000):
        R = rng.uniform(0.01, 0.99)
        jerk = rng.uniform(-0.5, 2.0)
        jmin = jerk - rng.uniform(0.0, 0.5)
        jmax = jerk + rng.uniform(0.0, 0.5)
        acc = rng.uniform(-1.0, 0.2)
        v = -rng.uniform(-0.01, 0.2) * acc * acc
        window = rng.uniform(0.0, 3.0)
        inside = plate_conditions(R, v, acc, jmin, jmax, window).inside
        if quick_reject(R, v, acc, jerk):
            assert not inside
        accepted += inside
    assert accepted > 100  # the sample does reach inside the plate


def test_quick_reject_section4():
    # y' >= 0, y'' >= 0, y''' <= 0 or R = 0: always rejected
    assert quick_reject(0.5, 0.0, -1.0, 1.0)
    assert quick_reject(0.5, -0.01, 0.0, 1.0)
    assert quick_reject(0.5, -0.01, -1.0, 0.0)
    assert quick_reject(0.0, -0.01, -1.0, 1.0)
    # at the edge tau = pi: y'' = -sin(pi) ~ -1.2e-16, any incoming speed is above the bound
    assert quick_reject(0.5, -1e-12, -math.sin(math.pi), 1.0)
    # inside (4.2) with Y = y'''(t0) = -cos tau: not rejected
    tau = 2.5
    assert not quick_reject(0.5, -0.5 * 5 / 24 * math.sin(tau) ** 2, -math.sin(tau), -math.cos(tau))


def test_jerk_bounds_of_section4():
    """Y*, Y of y''' = -cos t over [tau, pi] from its Taylor coefficients about tau.

    The extremes are at the ends (monotone), where the samples are exact: 1e-14
    covers the series evaluation. A cubic with an interior maximum is found to
    third order in the sample spacing (span/64).
    """
    tau = 2.0
    span = math.pi - tau
    # -cos(tau + h) = sum_k c_k h^k, c_k = -cos^(k)(tau)/k!
    derivs = [-math.cos(tau), math.sin(tau), math.cos(tau), -math.sin(tau)]
    coeffs = np.array([derivs[k % 4] / math.factorial(k) for k in range(29)])
    lo, hi = jerk_bounds(coeffs, span)
    assert lo == pytest.approx(-math.cos(tau), abs=1e-14)
    assert hi == pytest.approx(1.0, abs=1e-14)

    # 1 - (h - 0.37)^2 on [0, 1]: max 1 at 0.37 (between samples)
    c = np.array([1.0 - 0.37**2, 2 * 0.37, -1.0])
    lo, hi = jerk_bounds(c, 1.0)
    assert hi == pytest.approx(1.0, abs=1e-12)  # the parabola refinement is exact on a parabola
    assert lo == pytest.approx(1.0 - 0.63**2, abs=1e-15)
