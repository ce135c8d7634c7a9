"""Full runs of the four catalogue scenes: every impact row, event order, and the dense path in the gap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.reference import load_scene, simulate
from chatterbench.reference.dense import Motion, sample, sample_states
from chatterbench.reference.flow import Flow
from chatterbench.reference.linear import V1, VY, Y, LinearSystem

from helpers import reference_run as run


def test_runs_complete(scene_name, mode):
    result = run(scene_name, mode)
    assert result.status == "ok"
    assert len(result.log) > 0


def test_event_times_non_decreasing(scene_name, mode):
    t = run(scene_name, mode).log.t.to_numpy()
    assert np.all(np.diff(t) >= 0.0)
    scene = run(scene_name, mode).scene
    assert t[0] >= scene.initial.t and t[-1] <= scene.t_end


def test_impacts_lose_speed(scene_name, mode):
    # Newton's law with R < 1: |v+| = R |v-| <= |v-|; exact (one multiplication by R)
    log = run(scene_name, mode).log
    imp = log[log.kind == "impact"]
    assert (imp.v_plus.abs() <= imp.v_minus.abs()).all()
    R = run(scene_name, mode).scene.restitution
    elastic = imp[imp.rule != "plate"]
    np.testing.assert_array_equal(elastic.v_plus.to_numpy(), -R * elastic.v_minus.to_numpy())
    # perfectly inelastic plate strikes stop the relative motion
    assert (imp[imp.rule == "plate"].v_plus == 0.0).all()


def test_impact_rows_conserve_momentum_along_the_flight(scene_name, mode):
    """Rebuild the state before every impact from the row and check it against the flight.

    From the row: v1_before = v1 + m2/(m1+m2) (v_plus - v_minus), the inverse of (1.3)
    ((m1 + m2) dv1 + m2 dvy = 0; note the sign: the kick on body 1 opposes the change of
    y'). Momentum m1 v1 + m2 v2 before and after then agrees to rounding. The check with teeth: the
    free flight from the previous event (impact or exit, or the initial state) must arrive
    with y' = v_minus and x1' = v1_before. Tolerance 1e-12 of the velocity scale of the
    scene (max |v|, at least 1 m/s), absolute: near a Zeno point v_minus is itself ~1e-9,
    so a relative test would demand more than the O(1) state carries; the flights are
    closed-form flows at ~1e-14 relative (measured worst 1.2e-13 m/s, spring-pair, whose
    stiff coupling spring means longer series walks).
    """
    result = run(scene_name, mode)
    scene, log = result.scene, result.log
    m1, m2 = scene.mass1, scene.mass2
    share = 0.0 if math.isinf(m1) else m2 / (m1 + m2)
    system = LinearSystem.from_scene(scene)
    flow = Flow(system.free, horizon=scene.time_scale / 4.0)
    scale = max(1.0, log.v_minus.abs().max(), log.v1.abs().max())

    init = scene.initial
    prev = (init.t, init.x1, init.v1, init.y, init.vy)
    checked = 0
    for row in log.itertuples():
        if row.kind == "impact":
            v1_before = row.v1 + share * (row.v_plus - row.v_minus)
            # momentum: m1 v1 + m2 (v1 + vy) before == after, to rounding of the terms
            if not math.isinf(m1):
                p_before = m1 * v1_before + m2 * (v1_before + row.v_minus)
                p_after = m1 * row.v1 + m2 * (row.v1 + row.v_plus)
                assert abs(p_after - p_before) <= 1e-12 * (m1 + m2) * scale
            else:
                assert row.v1 == 0.0  # a fixed body 1 is never kicked (catalogue: not prescribed)
            t0, x1, v1, y, vy = prev
            s = flow.advance(system.state(t0, x1, v1, y, vy), row.t - t0)
            wall_y = scene.gap.position(row.wall)
            assert abs(s[Y] - wall_y) <= 1e-12 * max(1.0, abs(wall_y)) + 1e-12  # arrived on the wall
            assert abs(s[VY] - row.v_minus) <= 1e-12 * scale, (row.Index, s[VY], row.v_minus)
            assert abs(s[V1] - v1_before) <= 1e-12 * scale, (row.Index, s[V1], v1_before)
            checked += 1
        if row.kind in ("impact", "exit"):
            # free flight starts after an impact (vy = v_plus) and after an exit (vy = 0)
            prev = (row.t, row.x1, row.v1, scene.gap.position(row.wall), row.v_plus)
    assert checked == result.n_impacts


def _sample_times(result, n=20001):
    """A uniform grid plus points 1e-12 .. 1e-3 s either side of every event."""
    scene, t = result.scene, result.log.t.to_numpy()
    offsets = np.concatenate([-np.logspace(-12, -3, 4), [0.0], np.logspace(-12, -3, 4)])
    near = (t[:, None] + offsets[None, :]).ravel()
    times = np.concatenate([np.linspace(scene.initial.t, scene.t_end, n), near])
    return np.clip(times, scene.initial.t, scene.t_end)


def test_dense_trajectory_stays_in_the_gap(scene_name, mode):
    """The dense path never leaves [lower, upper] by more than 1e-12 m.

    Every impact puts y exactly on the wall, and between events y comes from the
    closed-form flow, whose error (~1e-15 relative per step) is far below 1e-12 m for
    the gaps of the catalogue (0.02 m to 1 m).
    """
    result = run(scene_name, mode)
    scene = result.scene
    traj = sample(scene, result.log, _sample_times(result))
    y = traj.y.to_numpy()
    assert np.all(y >= scene.gap.lower - 1e-12), y.min() - scene.gap.lower
    if scene.gap.upper is not None:
        assert np.all(y <= scene.gap.upper + 1e-12), y.max() - scene.gap.upper


def test_dense_constrained_motion_is_on_the_wall(scene_name, mode):
    # between a stick and its exit the masses move together: y on the wall, y' = 0 (exact)
    result = run(scene_name, mode)
    scene, eps = result.scene, result.episodes
    for ep in eps.itertuples():
        end = ep.t_exit if not math.isnan(ep.t_exit) else scene.t_end
        traj = sample(scene, result.log, np.linspace(ep.t_stick, end, 50)[1:-1])
        assert (traj.y == scene.gap.position(ep.wall)).all()
        assert (traj.vy == 0.0).all()


def test_dense_matches_log_at_events(scene_name, mode):
    # sampled exactly at an impact, the dense path returns the state just after it (the
    # last event at that time): x1, v1 as logged, vy = v_plus; exact, nothing is propagated
    result = run(scene_name, mode)
    log = result.log
    last_at_time = log.groupby("t").tail(1)
    imp = last_at_time[last_at_time.kind == "impact"]
    traj = sample(result.scene, log, imp.t.to_numpy())
    np.testing.assert_array_equal(traj.x1.to_numpy(), imp.x1.to_numpy())
    np.testing.assert_array_equal(traj.v1.to_numpy(), imp.v1.to_numpy())
    np.testing.assert_array_equal(traj.vy.to_numpy(), imp.v_plus.to_numpy())


@pytest.mark.parametrize("mode", ["feigin", "exhaustive"])
def test_prescribed_body_follows_its_path(mode):
    """A ball on a shaker (mass1 = inf, x1 = A sin(w t + phi)): impacts never kick body 1.

    Every logged x1, v1 and the dense x1 lie on the prescribed path to 1e-12 (m, m/s;
    measured 1.6e-15: the sin/cos generators are reseeded at every event), and y stays
    in the gap to 1e-12 m. A w^2 = 9 m/s^2 < g: once stuck, the ball never leaves.
    """
    from chatterbench.reference import scene_from_dict, simulate
    from test_scene import PRESCRIBED

    scene = scene_from_dict(PRESCRIBED)
    result = simulate(scene, mode)
    p = scene.prescribed
    for row in result.log.itertuples():
        assert abs(row.x1 - p.position(row.t)) <= 1e-12
        assert abs(row.v1 - p.velocity(row.t)) <= 1e-12
    eps = result.episodes
    assert len(eps) == 1 and math.isnan(eps.t_exit.iloc[0])
    traj = sample(scene, result.log, _sample_times(result, 5001))
    assert traj.y.min() >= -1e-12
    assert max(abs(x - p.position(t)) for t, x in zip(traj.t, traj.x1)) <= 1e-12


def test_a_kept_motion_samples_as_each_call_does_in_any_order():
    """``Motion`` made once (a strike samples a few times before each impact from it) gives each call's states bit for
    bit, in any order of the times, and the kinematic constraint's wall where the masses are stuck."""
    scene = load_scene("feigin-pair")
    log = simulate(scene).log
    motion = Motion(scene, log)
    times = np.random.default_rng(7).uniform(scene.initial.t, scene.t_end, 300)
    frame = sample(scene, log, times)
    assert np.array_equal(motion.at(times), frame[["x1", "v1", "y", "vy"]].to_numpy())
    ordered = np.sort(times)
    states, stuck_y = motion.states(ordered)
    again, again_y = sample_states(scene, log, ordered)
    assert np.array_equal(states, again) and np.array_equal(stuck_y, again_y, equal_nan=True)
    assert np.isfinite(stuck_y).any() and np.isnan(stuck_y).any()  # stuck stretches and free flight both sampled
