"""The exact flow s' = A s (truncated Taylor series of expm on short steps) against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.reference import load_scene
from chatterbench.reference.flow import Flow
from chatterbench.reference.linear import VY, X1, V1, Y, LinearSystem


def _oscillator(w: float) -> np.ndarray:
    return np.array([[0.0, 1.0], [-w * w, 0.0]])


@pytest.mark.parametrize("w", [0.5, 3.0, 40.0])
def test_harmonic_oscillator_over_many_steps(w):
    """x'' = -w^2 x from (1, 0): x = cos w t, x' = -w sin w t, in the energy norm (x, x'/w).

    Tolerance: within 60 whole steps, 1e-13 of the amplitude. Each step multiplies by the
    same rounded step matrix, whose eigenvalues are off by a few ulps, so the phase
    error grows linearly with the number of steps N (not like sqrt N); beyond 60 steps
    the bound is 3e-15 per step (measured ~2e-15 at w step = 1.5: a few ulps of the step
    matrix times the e^1.5 by which the series terms may exceed the result, so no step
    loses more than a digit). The reference cos(w t) is exact
    to rounding (w t is exact to 1 ulp, |w t| < 1e4).
    """
    flow = Flow(_oscillator(w), horizon=2 * math.pi / w)
    assert flow.growth * flow.step <= 1.5 + 1e-12
    s0 = np.array([1.0, 0.0])
    period = 2 * math.pi / w
    n_checked_beyond_60 = 0
    for t in np.linspace(0.0, 20 * period, 401):
        x, v = flow.advance(s0, t)
        steps = t / flow.step
        tol = 1e-13 if steps <= 60 else 3e-15 * steps
        n_checked_beyond_60 += steps > 60
        assert abs(x - math.cos(w * t)) <= tol, (t, steps)
        assert abs(v / w + math.sin(w * t)) <= tol, (t, steps)
    assert n_checked_beyond_60 > 0  # "many steps" really exercised


def test_harmonic_oscillator_chained_advances():
    # 10 000 short hops (as the event loop does) match one long advance: each hop
    # truncates at order 28, far below rounding; error grows like sqrt(N) eps ~ 1e-14
    w = 3.0
    flow = Flow(_oscillator(w), horizon=2 * math.pi / w)
    s = np.array([1.0, 0.0])
    h = 1e-3
    for _ in range(10_000):
        s = flow.advance(s, h)
    t = 10_000 * h
    assert abs(s[0] - math.cos(w * t)) <= 1e-13
    assert abs(s[1] / w + math.sin(w * t)) <= 1e-13


def test_free_fall_polynomial_exact():
    """s = [y, vy, 1] with y'' = -g: A is nilpotent, so the series ends at h^2.

    y = y0 + v0 t - g t^2 / 2: 1e-13 relative to the largest term (rounding only).
    """
    g = 9.81
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -g], [0.0, 0.0, 0.0]])
    flow = Flow(A, horizon=0.5)
    assert flow.step <= 0.5
    s0 = np.array([1.0, 2.0, 1.0])
    for t in np.linspace(0.0, 30.0, 301):
        y, vy, one = flow.advance(s0, t)
        scale = 1.0 + 2.0 * t + 0.5 * g * t * t
        assert abs(y - (1.0 + 2.0 * t - 0.5 * g * t * t)) <= 1e-13 * scale
        assert abs(vy - (2.0 - g * t)) <= 1e-13 * (2.0 + g * t)
        assert one == 1.0


def test_feigin_pair_free_flight_closed_form():
    """The feigin-pair generator: y'' = -sin t, body 1 x1'' = sin t (P = m1 = 1, omega = 1).

    From y(0) = 0, y'(0) = 0: y = sin t - t, x1 = t - sin t. Over 10 periods the
    secular term reaches 63, so 1e-13 relative to |t| + 1.
    """
    scene = load_scene("feigin-pair")
    system = LinearSystem.from_scene(scene)
    flow = Flow(system.free, horizon=scene.time_scale / 4.0)
    s0 = system.state(0.0, 0.0, 0.0, 0.0, 0.0)
    for t in np.linspace(0.0, 20 * math.pi, 157):
        s = flow.advance(s0, t)
        scale = 1.0 + t
        assert abs(s[Y] - (math.sin(t) - t)) <= 1e-13 * scale
        assert abs(s[VY] - (math.cos(t) - 1.0)) <= 1e-13 * scale
        assert abs(s[X1] - (t - math.sin(t))) <= 1e-13 * scale
        assert abs(s[V1] - (1.0 - math.cos(t))) <= 1e-13 * scale
        # the forcing generators stay on the unit circle: sin t, cos t
        assert abs(s[5] - math.sin(t)) <= 1e-13 * scale and abs(s[6] - math.cos(t)) <= 1e-13 * scale


def test_taylor_coefficients_are_derivatives():
    # row k of taylor() is s^(k)(t0)/k!: y'' = -sin t, y''' = -cos t at t0 = 1 (exact forms)
    scene = load_scene("feigin-pair")
    system = LinearSystem.from_scene(scene)
    flow = Flow(system.free, horizon=scene.time_scale / 4.0)
    t0 = 1.0
    coeffs = flow.taylor(system.state(t0, 0.0, 0.0, 0.0, 0.0))
    # 1e-15: a single matrix-vector product of O(1) entries
    assert coeffs[2, Y] == pytest.approx(-math.sin(t0) / 2, abs=1e-15)
    assert coeffs[3, Y] == pytest.approx(-math.cos(t0) / 6, abs=1e-15)
    assert coeffs[4, Y] == pytest.approx(math.sin(t0) / 24, abs=1e-15)
    # the free relative acceleration row gives y'' directly
    assert system.accel_row @ system.state(t0, 0.0, 0.0, 0.0, 0.0) == pytest.approx(-math.sin(t0), abs=1e-15)
