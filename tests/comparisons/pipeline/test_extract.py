"""Event extraction: fed the reference's own samples it must give back the reference's episodes and impacts;
fed an engine's, it must find what the engine did, by the same rule for every engine."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from chatterbench.comparisons.pipeline.extract import IMPACT_COLUMNS, extract, impact_table
from chatterbench.comparisons.pipeline.extract_options import ExtractionOptions
from chatterbench.comparisons.pipeline.sampling import reference_trajectory, sample_grid
from chatterbench.comparisons.pipeline.tolerances import Tolerances, ToleranceError
from chatterbench.comparisons.pipeline.wall_impacts import contact_runs
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.dense import sample
from chatterbench.reference.log import EPISODE_COLUMNS, LOG_COLUMNS
from chatterbench.reference.scene import load_scene

from helpers import solution
from shared_engine_runs import engine_run

SCENES = ("bouncing-ball", "feigin-pair", "impact-damper", "spring-pair")
CASES = [(name, dt) for name in SCENES for dt in (1e-3, 1e-4)]


@functools.cache
def _sampled(name: str, dt: float):
    ref = solution(name)
    traj = reference_trajectory(ref.scene, dt, ref.exhaustive)
    return ref, traj, extract(traj, ref.scene, ref.stick_tolerance(Tolerances().stick))


# -- the key check: the reference's own samples give back its episodes ----------------

@pytest.mark.parametrize("name, dt", CASES)
def test_reference_samples_reproduce_reference_episodes(name, dt):
    ref, traj, found = _sampled(name, dt)
    want, got = ref.episodes, found.episodes
    assert list(got.columns) == EPISODE_COLUMNS
    assert len(got) == len(want) > 0 and got["wall"].tolist() == want["wall"].tolist()
    # The first impact of a visit follows a long free flight, so it is resolved and located by
    # the free parabola to O(|y'''| dt^3 / |v|): far below dt (1e-3 dt is generous).
    np.testing.assert_allclose(got["t_first_impact"], want["t_first_impact"], rtol=0, atol=1e-3 * dt)
    # Sticking: the first slow impact plus the chatter Feigin's ladder predicts from its rebound
    # is the Zeno point but for the change of |y''| over that rest: measured <= 0.11 of the
    # tolerance (impact-damper at 1e-3 s); 0.2 of the tolerance is this check's bar.
    stick_tol = Tolerances().stick * want["stick_scale"]
    assert (np.abs(got["t_stick"] - want["t_stick"]) <= 0.2 * stick_tol + 1e-12).all()
    # The exit is where the constraint force (linear in t near the exit) extrapolates to zero:
    # O(dt^2) (measured <= 0.1 of the 2% exit tolerance); never worse than one step.
    assert np.array_equal(np.isnan(got["t_exit"]), np.isnan(want["t_exit"]))
    assert (np.abs(got["t_exit"] - want["t_exit"]).dropna() <= dt).all()
    assert (got["stick_rule"] == "contact").all()
    assert got["t_plate_entry"].isna().all()  # engines cannot know Feigin's plate


@pytest.mark.parametrize("name, dt", CASES)
def test_resolved_impacts_match_reference_impacts(name, dt):
    ref, traj, found = _sampled(name, dt)
    want = ref.impacts
    got = found.impacts
    assert list(found.log.columns) == LOG_COLUMNS
    assert set(found.log["kind"]) <= {"impact", "stick", "exit"}
    # Every impact whose flights before and after span a few steps is found, at its instant,
    # with its speeds: the parabola's root O(dt^3), speeds O(|jerk| dt^2) with |jerk| at most
    # ~100 m/s^3 in these scenes (impact-damper's forcing, 5 N at 10 rad/s, and its spring),
    # hence 100 dt^2 absolute beside 1e-3 relative. A stick's own impact (v+ = 0) is left out:
    # its rebound is the exit's.
    want = want[want["v_plus"] != 0]
    t_ref = want["t"].to_numpy()
    gaps = np.diff(t_ref)
    clear = np.concatenate(([True], gaps > 3 * dt)) & np.concatenate((gaps > 3 * dt, [True]))
    assert clear.sum() >= 8
    t_got = got["t"].to_numpy()
    for _, r in want[clear].iterrows():
        j = int(np.argmin(np.abs(t_got - r["t"])))
        assert abs(t_got[j] - r["t"]) <= 1e-3 * dt
        assert got["v_minus"].iloc[j] == pytest.approx(r["v_minus"], rel=1e-3, abs=100 * dt**2)
        assert got["v_plus"].iloc[j] == pytest.approx(r["v_plus"], rel=1e-3, abs=100 * dt**2)


def test_bouncing_ball_first_impact():
    ref, traj, found = _sampled("bouncing-ball", 1e-3)
    first = found.impacts.iloc[0]
    # Dropped from 1 m under g: t1 = sqrt(2/g) = 0.4515 s, v = -sqrt(2 g) = -4.43 m/s; the
    # rebound is R times that, Feigin (1.3)
    assert first["t"] == pytest.approx(math.sqrt(2.0 / 9.81), abs=1e-6)
    assert first["v_minus"] == pytest.approx(-math.sqrt(2 * 9.81), rel=1e-4)
    assert first["v_plus"] == pytest.approx(-0.5 * first["v_minus"], rel=1e-4)


# -- the reference as a trajectory ----------------------------------------------------

def test_reference_trajectory_is_the_dense_reference():
    ref = solution("spring-pair")
    scene = ref.scene
    traj = reference_trajectory(scene, 1e-3)
    assert traj.engine == "reference" and traj.status == "ok"
    np.testing.assert_array_equal(traj.t, sample_grid(scene, 1e-3))
    pick = np.arange(0, len(traj.t), 37)
    dense = sample(scene, ref.exhaustive.log, traj.t[pick])
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

def test_contact_runs():
    c = np.array([0, 1, 1, 0, 1, 0, 0, 0, 0, 1, 0, 1], dtype=bool)
    starts, stops = contact_runs(c)
    assert starts.tolist() == [1, 4, 9, 11] and stops.tolist() == [3, 5, 10, 12]  # the data end in contact


@pytest.mark.parametrize("field, value", [("band", 0.0), ("floor_steps", -1.0), ("jump_factor", math.nan),
                                          ("jump_atol", -1e-3)])
def test_options_refuse_bad_values(field, value):
    with pytest.raises(ToleranceError, match=field):
        ExtractionOptions(**{field: value})


def _micro_chatter(dt: float, t_rest: float, t_exit: float, n: int, a: float = -9.81, lift: float = 0.0) -> Trajectory:
    """A rigid engine's resting on a wall, as PyBullet does it: every third step a contact step
    gives back the speed a dt, so the body hops a |a| dt^2 high and returns; from ``t_exit`` on
    the wall lets go and the body rises with acceleration ``lift``. Free flight before t_rest."""
    t = np.arange(n) * dt
    y, vy, contact = np.zeros(n), np.zeros(n), np.zeros(n, bool)
    y[0], vy[0] = 0.05, 0.0
    for k in range(1, n):
        acc = a if t[k] < t_exit else lift
        v = vy[k - 1] + acc * dt
        p = y[k - 1] + v * dt
        if p < 0.0 and t[k] < t_exit:  # contact step: the impulse leaves the body moving up at |a| dt
            p, v, contact[k] = 0.0, -a * dt, True
        y[k], vy[k] = p, v
    zero = np.zeros(n)
    return Trajectory(engine="synthetic", t=t, x1=zero, x2=y, v1=zero, v2=vy, contact={"lower": contact},
                      normal_force={"lower": np.where(contact, 1.0, 0.0)}, wall_time=0.0)


def test_a_rigid_engines_micro_bounces_are_sticking_not_impacts():
    # 3-step micro-chatter, flights of about 2 steps: below the sampling floor (4 steps), so
    # from the moment the hops begin the body is stuck; it leaves where the wall lets go.
    scene = load_scene("bouncing-ball", ["duration=0.5"])
    dt = 1e-3
    traj = _micro_chatter(dt, 0.1, 0.35, 500, lift=5.0)
    found = extract(traj, scene)
    eps = found.episodes
    assert len(eps) == 1
    assert eps["t_stick"].iloc[0] == pytest.approx(0.1009, abs=2 * dt)  # the first touch of the wall
    assert eps["t_exit"].iloc[0] == pytest.approx(0.35, abs=2 * dt)
    stuck = found.impacts[found.impacts["stuck"]]
    assert len(stuck) > 50  # the micro-bounces are kept, marked, and not in the log
    assert (found.log["kind"] == "impact").sum() == 1


# -- real engines -----------------------------------------------------------------------

@pytest.mark.parametrize("engine, name", [("mujoco", "bouncing-ball"), ("mujoco", "spring-pair"),
                                          ("mujoco", "feigin-pair"), ("pybullet", "bouncing-ball")])
def test_extraction_on_engine_trajectory(engine, name, tmp_path_factory):
    dt = 1e-4
    ref = solution(name)
    traj = engine_run(tmp_path_factory, engine, ref.scene, dt)  # the judge tests' run too (shared_engine_runs.py)
    assert traj.status == "ok", traj.message
    got = extract(traj, ref.scene, ref.stick_tolerance(Tolerances().stick)).episodes
    want = ref.episodes
    assert len(got) == len(want) and got["wall"].tolist() == want["wall"].tolist()
    # The first impact follows free flight, which the engines integrate to O(dt) (MuJoCo's soft
    # contact also starts pushing a little before touch): within 10 dt.
    np.testing.assert_allclose(got["t_first_impact"], want["t_first_impact"], rtol=0, atol=10 * dt)
    # Sticking: the engines end the chatter their own way (MuJoCo's soft contact absorbs the last
    # bounces late: 2.6 stick tolerances on spring-pair; PyBullet within a tenth of one). This
    # checks that the extraction finds it, not the engine's accuracy: within half the chatter.
    assert (np.abs(got["t_stick"] - want["t_stick"]) <= 0.5 * want["stick_scale"]).all()
    # Exits are set by the forcing, where the contact force lets go: within 2 dt.
    assert np.array_equal(np.isnan(got["t_exit"]), np.isnan(want["t_exit"]))
    np.testing.assert_allclose(got["t_exit"], want["t_exit"], rtol=0, atol=2 * dt)


def test_mujoco_exit_on_feigin_pair_is_where_the_force_lets_go(tmp_path_factory):
    # The lower wall's exit is at t = pi (mod 2 pi), the upper's at 0. MuJoCo's limit force
    # falls linearly to zero at the exit (the impedance d = 0.99 leaves a quasi-static sink of
    # (1 - d) |y''| / w0^2, gone at the exit); "d <= 0 is contact" would wait ~9 dt longer.
    dt = 1e-4
    scene = load_scene("feigin-pair")
    traj = engine_run(tmp_path_factory, "mujoco", scene, dt)
    eps = extract(traj, scene, solution("feigin-pair").stick_tolerance(Tolerances().stick)).episodes.dropna(subset=["t_exit"])
    assert len(eps) == 12
    phase = np.where(eps["wall"] == "lower", math.pi, 0.0)
    off = np.mod(eps["t_exit"] - phase + math.pi, 2 * math.pi) - math.pi
    assert np.abs(off).max() <= 2 * dt


def _wall(wall: str, t: list[float], flight: list[float], exits: list[bool]) -> dict:
    n = len(t)
    cols = {c: np.arange(n, dtype=float) for c in IMPACT_COLUMNS}
    cols.update(t=np.array(t), wall=np.full(n, wall, dtype=object), flight=np.array(flight),
                flight_seen=np.array(flight), exits=np.array(exits), slow=np.zeros(n, bool), stuck=np.zeros(n, bool),
                onset=np.zeros(n, bool))
    return cols


def test_the_impact_table_is_by_time_and_drops_the_flights_no_bounce_made():
    # two walls interleaved: a flight that ends on the other wall, or that an exit starts, is no bounce's flight; the
    # last impact keeps its own; a tie in time keeps the walls' order (lower first, as extract lists them)
    lower = _wall("lower", [0.1, 0.2, 0.5], [0.1, 0.3, 0.4], [False, True, False])
    upper = _wall("upper", [0.3, 0.5, 0.6], [0.2, 0.1, 0.7], [False, False, False])
    table = impact_table([lower, upper])
    assert table["t"].tolist() == [0.1, 0.2, 0.3, 0.5, 0.5, 0.6]
    assert table["wall"].tolist() == ["lower", "lower", "upper", "lower", "upper", "upper"]
    flight = table["flight"].tolist()
    assert flight[0] == 0.1 and flight[4] == 0.1 and flight[5] == 0.7  # bounces on one wall, and the last impact
    assert all(math.isnan(f) for f in (flight[1], flight[2], flight[3]))  # an exit's; two that end on the other wall
    assert table["flight_seen"].isna().tolist() == table["flight"].isna().tolist()
    assert list(table.columns) == IMPACT_COLUMNS and table.index.tolist() == list(range(6))
    assert impact_table([]).empty and list(impact_table([]).columns) == IMPACT_COLUMNS
