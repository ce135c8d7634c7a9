"""Newton's impact law, Feigin (1967) (1.3): momentum kept, relative velocity scaled by -R."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.reference.impact import Impact, impact

RNG_SEED = 20240611
N_CASES = 2000


def _cases():
    rng = np.random.default_rng(RNG_SEED)
    # masses over 6 decades, velocities of both signs over 4 decades, R in [0, 1)
    m1 = 10.0 ** rng.uniform(-3, 3, N_CASES)
    m2 = 10.0 ** rng.uniform(-3, 3, N_CASES)
    vy = -(10.0 ** rng.uniform(-2, 2, N_CASES))  # incoming: y' < 0 at the lower wall
    vy[::5] *= -1.0  # the law itself does not care about the wall; keep some positive
    v1 = rng.normal(0.0, 10.0, N_CASES)
    R = rng.uniform(0.0, 1.0, N_CASES)
    return zip(m1, m2, vy, v1, R)


def test_docstring_example():
    # exact in binary: 0.5 and 0.75 are representable
    assert impact(vy=-1.0, v1=0.0, restitution=0.5, mass1=1.0, mass2=1.0) == Impact(vy=0.5, v1=-0.75)


def test_momentum_conserved_and_relative_energy_scaled_by_R2():
    for m1, m2, vy, v1, R in _cases():
        out = impact(vy, v1, R, m1, m2)
        v2, v2p = v1 + vy, out.v1 + out.vy
        p_before = m1 * v1 + m2 * v2
        p_after = m1 * out.v1 + m2 * v2p
        # 1e-12 of the momentum scale |m1 v1| + |m2 v2|: a handful of roundings of the
        # largest term, not of the (possibly cancelling) total
        scale = abs(m1 * v1) + abs(m2 * v2) + abs(m2 * vy)
        assert abs(p_after - p_before) <= 1e-12 * scale
        # y'+ = -R y'- exactly (one multiplication)
        assert out.vy == -R * vy
        m_red = m1 * m2 / (m1 + m2)
        e_rel_before = 0.5 * m_red * vy**2
        e_rel_after = 0.5 * m_red * out.vy**2
        assert e_rel_after == pytest.approx(R**2 * e_rel_before, rel=1e-12, abs=0.0)
        # the kinetic energy lost is exactly the relative part (1 - R^2) (1/2) m_red vy^2
        ke_before = 0.5 * m1 * v1**2 + 0.5 * m2 * v2**2
        ke_after = 0.5 * m1 * out.v1**2 + 0.5 * m2 * v2p**2
        # absolute tolerance relative to the total KE: the difference of two KEs cancels
        assert ke_before - ke_after == pytest.approx(
            (1.0 - R**2) * e_rel_before, abs=1e-12 * (ke_before + ke_after + e_rel_before)
        )


def test_infinite_mass1_keeps_its_velocity():
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(500):
        vy, v1, R, m2 = rng.normal(0, 5), rng.normal(0, 5), rng.uniform(0, 1), 10 ** rng.uniform(-3, 3)
        out = impact(vy, v1, R, math.inf, m2)
        # a fixed or prescribed body is not kicked at all: exact
        assert out.v1 == v1
        assert out.vy == -R * vy
        # body 2 alone reverses with R: v2+ - v1 = -R (v2- - v1); forming v2 = v1 + vy and
        # subtracting v1 again costs two roundings of the larger of |v1|, |vy|
        assert (out.v1 + out.vy) - v1 == pytest.approx(-R * vy, rel=0.0, abs=4e-16 * (abs(v1) + abs(vy)))


def test_inelastic_impact_gives_common_velocity():
    # R = 0 is the entry into kinematic constraint (1.4): both bodies end at the
    # centre-of-mass velocity; 1e-14 relative covers the roundings of the share
    m1, m2, v1, vy = 2.0, 0.3, 1.25, -0.7
    out = impact(vy, v1, 0.0, m1, m2)
    v_cm = (m1 * v1 + m2 * (v1 + vy)) / (m1 + m2)
    assert out.vy == 0.0
    assert out.v1 == pytest.approx(v_cm, rel=1e-14)
