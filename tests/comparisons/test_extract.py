"""Event extraction: fed the reference's own samples it must give back the reference's episodes."""

from __future__ import annotations

import functools
import importlib.util
import math

import numpy as np
import pytest

from chatterbench.comparisons.extract import (
    ExtractionOptions,
    contact_intervals,
    extract_episodes,
    extract_events,
    stick_threshold,
)
from chatterbench.comparisons.reference_run import reference_trajectory, sample_grid
from chatterbench.reference.dense import sample
from chatterbench.reference.log import EPISODE_COLUMNS, LOG_COLUMNS
from chatterbench.reference.scene import SceneError, load_scene
from chatterbench.reference.simulate import simulate

CASES = [("feigin-pair", 1e-3), ("feigin-pair", 1e-4), ("bouncing-ball", 1e-3), ("bouncing-ball", 1e-4),
         ("spring-pair", 1e-3), ("spring-pair", 1e-4)]


@functools.cache
def _reference(name: str):
    scene = load_scene(name)
    return scene, simulate(scene, "exhaustive")


@functools.cache
def _sampled(name: str, dt: float):
    scene, result = _reference(name)
    traj = reference_trajectory(scene, result, dt)
    return scene, result, traj, extract_events(traj, scene)


# -- the key check: the reference's own samples give back its episodes ----------------

@pytest.mark.parametrize("name, dt", CASES)
def test_reference_samples_reproduce_reference_episodes(name, dt):
    scene, result, traj, log = _sampled(name, dt)
    ref = result.episodes
    got = extract_episodes(traj, scene)
    assert list(got.columns) == EPISODE_COLUMNS
    assert len(got) == len(ref) > 0
    assert got["wall"].tolist() == ref["wall"].tolist()
    # The first impact of a visit follows a long free flight, so it is resolved and located
    # by the free parabola to O(|y'''| dt^3 / |v|): far below dt (1e-3 dt is generous).
    np.testing.assert_allclose(got["t_first_impact"], ref["t_first_impact"], rtol=0, atol=1e-3 * dt)
    # Sticking starts at the first sample in constraint, at most one step after the Zeno
    # point, and is logged at the parabola's wall instant from the sample before: <= 1 dt
    # (measured: 0.4 to 0.8 dt); 2 dt leaves room for rounding on the grid.
    np.testing.assert_allclose(got["t_stick"], ref["t_stick"], rtol=0, atol=2 * dt)
    # The exit is the first sample off the wall: 0 to 1 dt after the true exit, one more when
    # the cubic departure y ~ y''' s^3 / 6 is still below the on-wall tolerance at that sample
    # (measured: up to 1.9 dt at dt = 1e-4). The run's last episode has no exit in both.
    assert np.array_equal(np.isnan(got["t_exit"]), np.isnan(ref["t_exit"]))
    late = got["t_exit"] - ref["t_exit"]
    assert (late.dropna() >= 0).all() and (late.dropna() <= 3 * dt).all()
    assert (got["stick_rule"] == "contact").all()
    assert got["t_plate_entry"].isna().all()  # engines cannot know Feigin's plate
    # Chatter impacts closer than a step apart fall between two samples and merge into one
    # detected impact, so fewer impacts are counted than the reference's (28-29 per visit):
    # between the resolved ones and all of them.
    iso = _isolated_reference_impacts(result.log, dt)
    for ep_got, ep_ref in zip(got.itertuples(), ref.itertuples()):
        t_hi = ep_ref.t_stick
        t_lo = ep_ref.t_first_impact
        n_iso = int(((iso >= t_lo) & (iso <= t_hi)).sum())
        assert n_iso <= ep_got.n_impacts <= ep_ref.n_impacts


def _isolated_reference_impacts(log, dt, spacing=3.0):
    """Times of reference impacts whose neighbours (any event) are more than ``spacing`` dt away."""
    t_all = np.sort(log["t"].to_numpy())
    t_imp = log.loc[log["kind"] == "impact", "t"].to_numpy()
    k = np.searchsorted(t_all, t_imp)
    before = np.where(k > 0, t_imp - t_all[np.maximum(k - 1, 0)], np.inf)
    after_idx = np.searchsorted(t_all, t_imp, side="right")
    after = np.where(after_idx < len(t_all), t_all[np.minimum(after_idx, len(t_all) - 1)] - t_imp, np.inf)
    return t_imp[(before > spacing * dt) & (after > spacing * dt)]


@pytest.mark.parametrize("name, dt", CASES)
def test_resolved_impacts_match_reference_impacts(name, dt):
    scene, result, traj, log = _sampled(name, dt)
    ref = result.log[result.log["kind"] == "impact"]
    got = log[log["kind"] == "impact"]
    assert list(log.columns) == LOG_COLUMNS
    assert set(log["kind"]) <= {"impact", "stick", "exit"}
    # Every detected impact is a real one: a reference impact at the same instant (the first
    # of a merged cluster). Root location error O(dt^3): 1e-3 dt is generous.
    t_ref = ref["t"].to_numpy()
    k = np.clip(np.searchsorted(t_ref, got["t"].to_numpy()), 1, len(t_ref) - 1)
    dist = np.minimum(np.abs(t_ref[k] - got["t"].to_numpy()), np.abs(t_ref[k - 1] - got["t"].to_numpy()))
    assert dist.max() <= 1e-3 * dt
    # Every reference impact more than 3 dt from its neighbours is found, with its velocities.
    iso = _isolated_reference_impacts(result.log, dt)
    assert len(iso) >= 8
    t_got = got["t"].to_numpy()
    for t in iso:
        j = int(np.argmin(np.abs(t_got - t)))
        assert abs(t_got[j] - t) <= 1e-3 * dt
        r = ref.iloc[int(np.argmin(np.abs(t_ref - t)))]
        g = got.iloc[j]
        # v -/+ are sampled velocities carried to the impact instant with y''_free: error
        # O(|y'''| dt^2) absolute; the slowest resolved impacts have |v| of a few |y''| dt, so
        # the relative error stays below ~1e-3 (measured <= 1.5e-4). The floor covers v = 0.
        assert g["v_minus"] == pytest.approx(r["v_minus"], rel=1e-3, abs=1e-9)
        assert g["v_plus"] == pytest.approx(r["v_plus"], rel=1e-3, abs=1e-9)


def test_bouncing_ball_first_impact():
    dt = 1e-3
    scene, result, traj, log = _sampled("bouncing-ball", dt)
    ref = result.log[result.log["kind"] == "impact"].iloc[0]
    got = log[log["kind"] == "impact"].iloc[0]
    # Dropped from 1 m under g: t1 = sqrt(2/g) = 0.4515 s, v = -sqrt(2 g) = -4.43 m/s. The
    # brief's bar: time within dt, v_minus within 1% (the estimators do far better).
    assert ref["t"] == pytest.approx(math.sqrt(2.0 / 9.81), rel=1e-12)
    assert abs(got["t"] - ref["t"]) <= dt
    assert got["v_minus"] == pytest.approx(ref["v_minus"], rel=0.01)
    assert got["v_plus"] == pytest.approx(-scene.restitution * ref["v_minus"], rel=0.01)  # Feigin (1.3)


# -- the reference as a trajectory ----------------------------------------------------

def test_reference_trajectory_is_the_dense_reference():
    scene, result = _reference("spring-pair")
    traj = reference_trajectory(scene, result, 1e-3)
    assert traj.engine == "reference" and traj.status == "ok"
    np.testing.assert_array_equal(traj.t, sample_grid(scene, 1e-3))
    pick = np.arange(0, len(traj.t), 37)
    dense = sample(scene, result.log, traj.t[pick])
    # Same closed-form flow, evaluated by Horner's rule instead of a power sum: rounding only.
    np.testing.assert_allclose(traj.y[pick], dense["y"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.vy[pick], dense["vy"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.x1[pick], dense["x1"], rtol=0, atol=1e-12)
    # In constraint the force is m_eff |y''_free| > 0 and y is on the wall; free, it is 0.
    stuck = traj.normal_force["lower"] > 0
    assert stuck.any() and (traj.contact["lower"][stuck]).all()
    assert np.abs(traj.y[stuck]).max() == 0.0
    assert (traj.normal_force["lower"][~traj.contact["lower"]] == 0).all()
    # Feigin (1.4) for spring-pair at rest on the wall at t = 0: y''_free = (F2 - F12)/m2 - F12/m1
    # with F12 = k (0 - rest) = 2.5 N, F2 = 0: y'' = -5 - 2.5 = -7.5; m_eff = 1/3 kg.
    assert traj.normal_force["lower"][0] == pytest.approx(7.5 / 3.0, rel=1e-12)


# -- pieces ---------------------------------------------------------------------------

def test_contact_intervals_bridge_unresolved_flights():
    c = np.array([0, 1, 1, 0, 1, 0, 0, 0, 0, 1, 0, 1], dtype=bool)
    starts, stops = contact_intervals(c, bridge_steps=0)
    assert starts.tolist() == [1, 4, 9, 11] and stops.tolist() == [3, 5, 10, 12]
    # gaps of 1 sample are bridged, the 4-sample gap is a real flight; the data end in contact
    starts, stops = contact_intervals(c, bridge_steps=3)
    assert starts.tolist() == [1, 9] and stops.tolist() == [5, 12]


def test_stick_threshold_uses_engine_contact_time():
    scene, result = _reference("bouncing-ball")
    traj = reference_trajectory(scene, result, 1e-3)
    assert stick_threshold(traj) == pytest.approx(20 * 1e-3)
    soft = type(traj)(**{**traj.__dict__, "settings": {"contact_duration": 0.009}})
    assert stick_threshold(soft) == pytest.approx(5 * 0.009)
    assert stick_threshold(traj, ExtractionOptions(stick_min_duration=0.5)) == 0.5


@pytest.mark.parametrize("field, value", [("stick_min_duration", -1.0), ("stick_min_steps", 0),
                                          ("bridge_steps", -1), ("jump_factor", math.nan), ("wall_tolerance", -1e-3)])
def test_options_refuse_bad_values(field, value):
    with pytest.raises(SceneError, match=field):
        ExtractionOptions(**{field: value})


# -- real engines -----------------------------------------------------------------------

def _engine_cases():
    cases = []
    if importlib.util.find_spec("mujoco") is not None:
        cases += [("mujoco", "bouncing-ball"), ("mujoco", "spring-pair"), ("mujoco", "feigin-pair")]
    if importlib.util.find_spec("pybullet") is not None:
        cases += [("pybullet", "bouncing-ball")]
    return cases


def _run_engine(engine: str, scene, dt: float):
    if engine == "mujoco":
        from chatterbench.engines.mujoco_engine import MujocoSettings, run
        return run(scene, MujocoSettings(dt=dt))
    from chatterbench.engines.pybullet_engine import PybulletSettings, run
    return run(scene, PybulletSettings(dt=dt))


@pytest.mark.parametrize("engine, name", _engine_cases())
def test_extraction_on_engine_trajectory(engine, name):
    dt = 1e-4
    scene = load_scene(name)
    ref = _reference(name)[1].episodes  # exhaustive: sticking starts at the Zeno point, as in an engine
    traj = _run_engine(engine, scene, dt)
    assert traj.status == "ok", traj.message
    got = extract_episodes(traj, scene)
    assert len(got) == len(ref) and got["wall"].tolist() == ref["wall"].tolist()
    # The first impact follows free flight, which the engines integrate to O(dt) (MuJoCo's soft
    # contact also starts pushing a little before touch): within 10 dt.
    np.testing.assert_allclose(got["t_first_impact"], ref["t_first_impact"], rtol=0, atol=10 * dt)
    # Sticking: the engines end the chatter their own way (MuJoCo's damped soft contact
    # absorbs the last bounces late, by 43-75 ms here; PyBullet within ~2 ms). This checks the
    # extraction finds it, not the engine's accuracy: within a quarter of the chatter's length.
    chatter = (ref["t_stick"] - ref["t_first_impact"]).clip(lower=0.1)
    assert (np.abs(got["t_stick"] - ref["t_stick"]) <= 0.25 * chatter).all()
    # Exits are set by the forcing, not by the contact model: within a few ms (<= 1 ms measured).
    assert np.array_equal(np.isnan(got["t_exit"]), np.isnan(ref["t_exit"]))
    np.testing.assert_allclose(got["t_exit"], ref["t_exit"], rtol=0, atol=5e-3)
