"""The event-time root finder: first root of a local Taylor polynomial, to full relative precision."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.reference.roots import GRID, first_root


def test_docstring_example():
    # y = 0.2 h - g/2 h^2 lands at h = 0.2 / 4.905; rtol 1e-14 of the finder, with room
    h = first_root([0.0, 0.2, -4.905], deflate=1, hmax=1.0)
    assert h == pytest.approx(0.2 / 4.905, rel=1e-14)


@pytest.mark.parametrize("root", [1e-15, 1e-12, 3.7e-12, 1e-9, 1e-6, 1e-3, 0.5])
@pytest.mark.parametrize("hmax", [1.0, 10.0])
def test_tiny_roots_keep_relative_precision(root, hmax):
    """q(h) = c1 h + c2 h^2 with root -c1/c2; c0 is deflated.

    The deflated polynomial is c1 + c2 h, so its root keeps full relative precision
    however small: 1e-12 relative, well above the finder's 1e-14 target.
    """
    c2 = -4.905
    c1 = -c2 * root
    for deflate in (0, 1):  # exact leading zeros are divided out anyway
        h = first_root([0.0, c1, c2], hmax=hmax, deflate=deflate)
        assert h == pytest.approx(root, rel=1e-12)


def test_deflate_ignores_rounding_leftovers():
    # after an exit y, y', y'' vanish up to rounding; deflate=3 throws those away and
    # q = 1/6 - 1e-3 h has its root at h = 166 s > hmax: no event
    c = [0.0, -1e-18, -1e-17, 1.0 / 6.0, -1e-3]
    assert first_root(c, hmax=1.0, deflate=3) is None
    # without deflation the rounding leftover y' = -1e-18 reads as "moving into the wall"
    assert first_root(c, hmax=1.0, deflate=0) == 0.0


def test_returned_root_is_never_before_the_crossing():
    # the promise: q(h) <= 0 at the returned h (an event never placed before its root)
    rng = np.random.default_rng(3)
    for _ in range(2000):
        r = 10 ** rng.uniform(-12, -2)  # 4 c3 r < a: the root exists
        a = rng.uniform(0.1, 10.0)
        c = np.array([0.0, a * r, -a, rng.normal(0, 1.0)])
        h = first_root(c, hmax=2.0, deflate=1)
        assert h is not None
        q = np.polyval(c[1:][::-1], h)
        assert q <= 0.0
        # deflated: a r - a h + c3 h^2 = 0, smallest root in the cancellation-free form;
        # 1e-12 relative, the precision for event times
        c3 = c[3]
        exact = 2.0 * a * r / (a + math.sqrt(a * a - 4.0 * c3 * a * r))
        assert h == pytest.approx(exact, rel=1e-12)


@pytest.mark.parametrize("center", [0.53, 0.1 / GRID, 1.0 - 0.5 / GRID])
def test_grazing_dip_between_samples(center):
    """q = (h - c)^2 - eps dips below zero only within 1e-4 of c, between two grid points.

    The first root c - sqrt(eps) is well conditioned (q' = -2 sqrt(eps)), so 1e-12 relative.
    """
    eps = 1e-8
    assert all(abs(i / GRID - center) > 1e-3 for i in range(GRID + 1))
    c = [center**2 - eps, -2 * center, 1.0]
    h = first_root(c, hmax=1.0)
    assert h == pytest.approx(center - math.sqrt(eps), rel=1e-12)
    # the same dip scaled to a longer window (hmax = 7 s)
    c7 = [(7 * center) ** 2 - 49 * eps, -2 * 7 * center, 1.0]
    assert first_root(c7, hmax=7.0) == pytest.approx(7 * (center - math.sqrt(eps)), rel=1e-12)


def test_no_root():
    # the same dip lifted above zero, and a polynomial that stays positive
    assert first_root([0.53**2 + 1e-8, -2 * 0.53, 1.0], hmax=1.0) is None
    assert first_root([0.0, 1.0, 0.5], hmax=1.0, deflate=1) is None
    # the root is beyond hmax
    assert first_root([0.0, 1.0, -1.0], hmax=0.999, deflate=1) is None
    assert first_root([0.0, 1.0, -1.0], hmax=1.001, deflate=1) == pytest.approx(1.0, rel=1e-14)


def test_not_positive_at_start_returns_zero():
    assert first_root([0.0, -1.0, 1.0], hmax=1.0, deflate=1) == 0.0
    assert first_root([-1e-3, 1.0], hmax=1.0) == 0.0


def test_double_root_touch():
    # q = (h - 0.3)^2 touches zero: q <= 0 only at 0.3; found to sqrt(rounding) ~ 1e-8
    h = first_root([0.09, -0.6, 1.0], hmax=1.0)
    assert h is not None and h == pytest.approx(0.3, abs=1e-7)


def test_a_dip_from_rest_within_the_first_grid_step_is_found():
    # q = 1e-6 - h^2 + 100 h^3: at rest at h = 0 (q'(0) = 0) and curving down, below 0 on (1.05e-3, 0.0099), back above
    # 0 long before the first grid point (1/16): the dip's minimum must be looked for although q'(0) is not < 0
    # (before: None, and the reference's y went through a wall from a start at rest; tests/reference/test_properties.py)
    c = [1e-6, 0.0, -1.0, 100.0]
    h = first_root(c, hmax=1.0)
    roots = np.roots(c[::-1])
    exact = min(r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0)
    assert h is not None and h == pytest.approx(exact, rel=1e-12)
    assert first_root([1e-6, 0.0, -1.0, 1000.0], hmax=1.0) is None  # q > 0 throughout: min 1e-6 - 1.5e-7 at h = 6.7e-4
