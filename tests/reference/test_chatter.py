"""The compiled strike follower (reference/chatter.py) against the event loop and closed forms."""

import math

import numpy as np
import pytest

from chatterbench.reference import load_scene, simulate
from chatterbench.reference.chatter import LEAVES, SLIDES, strike_fates
from chatterbench.reference.simulate import in_plate

G = 9.81


@pytest.mark.parametrize("R", [0.3, 0.5, 0.8])
def test_ball_strike_accumulates_at_the_closed_form_zeno_point(R):
    # constant y'' = -g: flights 2 R^k v / g sum to 2 R v / (g (1 - R)) exactly; the
    # follower sums the tail in closed form too, so only rounding separates them (1e-12 s)
    scene = load_scene("bouncing-ball", [f"restitution={R}", "duration=20"])
    v = np.array([0.5, 2.0, 4.43])
    fates = strike_fates(scene, "lower", t=np.full(3, 0.1), v=-v)
    assert fates.slides.all()
    np.testing.assert_allclose(fates.t_stick, 0.1 + 2 * R * v / (G * (1 - R)), rtol=0, atol=1e-12)


def test_follower_matches_the_event_loop_in_exhaustive_mode():
    # the same flow, root finder and impact law: the same fate, Zeno times equal to
    # rounding (1e-12 s) and the same impact counts
    scene = load_scene("feigin-pair")
    for tau, v in [(1.0, 0.05), (2.0, 0.05), (2.5, 0.12), (0.5, 0.3)]:
        start = load_scene("feigin-pair", [f"initial.t={tau}", "initial.y=-0.1", f"initial.vy={-v}", "duration=4"])
        ep = simulate(start, "exhaustive").episodes
        fate = strike_fates(scene, "lower", t=[tau], v=[-v])
        first = ep.iloc[0]
        if fate.outcome[0] == SLIDES:
            assert first["wall"] == "lower" and first["t_first_impact"] == tau
            assert abs(fate.t_stick[0] - first["t_stick"]) <= 1e-12
            assert fate.n_impacts[0] == first["n_impacts"]
        else:
            # (2.5, 0.12): the chatter reaches the edge at pi before it accumulates, so the
            # event loop's first sticking is elsewhere (the upper wall, later)
            assert fate.outcome[0] == LEAVES
            assert not (first["wall"] == "lower" and first["t_first_impact"] == tau)
    assert strike_fates(scene, "lower", t=[2.5], v=[-0.12]).outcome[0] == LEAVES


def test_every_strike_in_feigins_plate_slides():
    # (2.1)-(2.2) are sufficient: on a 40 x 20 grid around the R = 0.5 plate, no strike
    # inside it may leave (exact comparison of booleans)
    scene = load_scene("feigin-pair")
    tau, speed = np.meshgrid(np.linspace(0.05, 2 * math.pi - 0.05, 40), np.linspace(0.005, 0.25, 20), indexing="ij")
    inside = in_plate(scene, "lower", tau, -speed)
    fates = strike_fates(scene, "lower", tau, -speed)
    assert inside.sum() > 20  # the grid really samples the plate
    assert not (inside & ~fates.slides).any()
    # and the true region is strictly larger: the conditions are not necessary
    assert (fates.slides & ~inside).sum() > inside.sum()


def test_strike_where_the_acceleration_points_away_leaves():
    # phase 4.5 on the lower wall: y'' = -sin(4.5) > 0, nothing presses the mass back soon
    scene = load_scene("feigin-pair")
    fate = strike_fates(scene, "lower", t=[4.5], v=[-0.2])
    assert fate.outcome[0] == LEAVES and not fate.slides[0]
