"""The force-only spring-damper restitution law against known values and a direct integration."""

import math

import numpy as np
import pytest

from chatterbench.engines.restitution import (
    CRITICAL_RESTITUTION,
    contact_duration,
    damping_ratio_from_restitution,
    exit_penetration,
    restitution_from_damping_ratio,
)


@pytest.mark.parametrize("r, zeta", [(0.5, 0.2553), (0.8, 0.0744)])
def test_known_damping_ratios(r, zeta):
    # the values are quoted to 4 decimals, so 1e-4 is their own rounding
    assert damping_ratio_from_restitution(r) == pytest.approx(zeta, abs=1e-4)


@pytest.mark.parametrize("r", [1e-6, 0.01, 0.1, CRITICAL_RESTITUTION, 0.3, 0.5, 0.8, 0.99, 0.999999])
def test_inverse_round_trip(r):
    # the inverse is a bisection to 1e-12 in zeta; R' is O(1) there, so R comes back to ~1e-11
    assert restitution_from_damping_ratio(damping_ratio_from_restitution(r)) == pytest.approx(r, rel=1e-9, abs=1e-11)


def _integrate(zeta, w0=1.0, v0=1.0, steps_per_unit=2000):
    """RK4 on x'' = -2 zeta w0 x' - w0^2 x until the force w0^2 x + 2 zeta w0 x' drops to 0."""
    h = 1.0 / (w0 * steps_per_unit)
    state = np.array([0.0, v0])

    def f(s):
        return np.array([s[1], -2 * zeta * w0 * s[1] - w0 * w0 * s[0]])

    t = 0.0
    while True:
        k1 = f(state)
        k2 = f(state + h / 2 * k1)
        k3 = f(state + h / 2 * k2)
        k4 = f(state + h * k3)
        new = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        force_old = w0 * w0 * state[0] + 2 * zeta * w0 * state[1]
        force_new = w0 * w0 * new[0] + 2 * zeta * w0 * new[1]
        if t > 0 and force_new <= 0.0:
            frac = force_old / (force_old - force_new)  # linear interpolation inside the last step
            return t + frac * h, -(state[1] + frac * (new[1] - state[1])) / v0
        state, t = new, t + h


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.2553, 0.7, 1.0, 1.5, 4.0])
def test_closed_form_matches_integration(zeta):
    # RK4 with 2000 steps per 1/w0 is accurate to ~1e-13; locating the end by linear
    # interpolation costs O(h^2) ~ 1e-7 at most, so 1e-6 is a safe margin for both R and t_c
    tc, r = _integrate(zeta)
    assert r == pytest.approx(restitution_from_damping_ratio(zeta), abs=1e-6)
    assert tc == pytest.approx(contact_duration(zeta, 1.0), abs=1e-6)


def test_not_the_two_sided_formula():
    # exp(-pi zeta / sqrt(1 - zeta^2)) is the ratio at x = 0 of the two-sided oscillator; the
    # force-only contact lets go earlier, so the same zeta gives a clearly larger R
    zeta = 0.2553
    assert restitution_from_damping_ratio(zeta) - math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)) > 0.05


def test_limits_and_choices():
    # exact special values of the closed form: R(0) = 1, R(1) = e^-2, t_c(0) = pi / w0, t_c(1) = 2 / w0
    assert restitution_from_damping_ratio(0.0) == 1.0
    assert restitution_from_damping_ratio(1.0) == pytest.approx(math.exp(-2.0), rel=1e-12)
    assert contact_duration(0.0, 10.0) == pytest.approx(math.pi / 10.0, rel=1e-15)
    assert contact_duration(1.0, 10.0) == pytest.approx(0.2, rel=1e-12)
    # continuity across the critical point (series branch vs closed forms), to the series' e^2
    for e in (2e-6, 5e-7):
        assert restitution_from_damping_ratio(1 - e) == pytest.approx(restitution_from_damping_ratio(1 + e), abs=1e-5)
    assert damping_ratio_from_restitution(0.0) == math.inf
    assert restitution_from_damping_ratio(math.inf) == 0.0
    # the penetration when the force hits zero: w0^2 x = -2 zeta w0 x' with x' = -R v0
    assert exit_penetration(0.25, 0.5, 2.0, 100.0) == pytest.approx(2 * 0.25 * 0.5 * 2.0 / 100.0)


@pytest.mark.parametrize("bad", [-0.1, 1.0, 1.5, float("nan")])
def test_bad_restitution_is_refused(bad):
    with pytest.raises(ValueError, match="restitution"):
        damping_ratio_from_restitution(bad)
