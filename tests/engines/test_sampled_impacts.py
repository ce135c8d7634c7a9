"""The exported scripts' copy of the judge's impact rule (``engines/sampled_impacts.py``) finds what the judge finds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.comparisons import reference_trajectory
from chatterbench.comparisons.outputs.engine_files import flight_band
from chatterbench.comparisons.pipeline.extract import extract, free_relative_acceleration
from chatterbench.comparisons.pipeline.extract_options import ExtractionOptions
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines import sampled_impacts
from chatterbench.engines.registry import make_settings, run_engine
from chatterbench.reference import load_scene

from helpers import solution

# every built-in scene, short, each engine at a step where it chatters and rests (both walls, both bodies free)
RUNS = [("bouncing-ball", [], "pybullet", 3.1e-3, []), ("bouncing-ball", [], "mujoco", 3e-4, ["mujoco.w0_dt=0.3"]),
        ("feigin-pair", ["duration=4"], "mujoco", 1e-3, []), ("feigin-pair", ["duration=4"], "pybullet", 1e-3, []),
        ("impact-damper", ["duration=1.2"], "mujoco", 1e-4, ["mujoco.gap_model=geom"]),
        ("spring-pair", ["duration=4"], "pybullet", 1e-3, [])]


def _script_view(traj, scene, band: float) -> list[tuple[float, str, float, float]]:
    """What a script hands ``judged_impacts``: its samples as plain lists."""
    a = free_relative_acceleration(scene, traj.t, traj.x1, traj.v1, traj.y, traj.vy)
    return sampled_impacts.judged_impacts(traj.t.tolist(), traj.y.tolist(), traj.vy.tolist(), a.tolist(),
                                          {w: traj.normal_force[w].tolist() for w in scene.gap.walls},
                                          {w: scene.gap.position(w) for w in scene.gap.walls}, scene.restitution, band)


@pytest.mark.parametrize("name, over, engine, dt, settings", RUNS, ids=[f"{r[0]}-{r[2]}" for r in RUNS])
def test_the_scripts_rule_gives_the_judges_log_impacts(name, over, engine, dt, settings):
    scene = load_scene(name, over)
    ref, tol = solve(scene), Tolerances()
    traj = run_engine(engine, scene, make_settings(engine, dt, settings))
    assert not traj.compact  # the scripts see every sample; the judge's compact view gives the same impacts
    log = extract(traj, scene, ref.stick_tolerance(tol.stick)).log
    judged = log[log["kind"] == "impact"]
    got = _script_view(traj, scene, flight_band(ref, tol))
    assert len(got) == len(judged) >= 5
    # the same impacts, walls and speeds to the last bit: one rule, written twice (numpy and plain Python)
    assert [w for _, w, _, _ in got] == judged["wall"].tolist()
    np.testing.assert_array_equal([t for t, _, _, _ in got], judged["t"].to_numpy())
    np.testing.assert_array_equal([v for _, _, v, _ in got], judged["v_minus"].to_numpy())
    np.testing.assert_array_equal([v for _, _, _, v in got], judged["v_plus"].to_numpy())


def test_without_the_judges_band_late_bounces_count_as_impacts():
    # known answer the other way: the flight band is what makes the ball's last micro-bounces a rest (the judge at
    # the default 5% sticking tolerance); with the sampling floor alone the script counts more impacts than the run
    scene = load_scene("bouncing-ball")
    traj = run_engine("pybullet", scene, make_settings("pybullet", 1e-4))
    band = flight_band(solution("bouncing-ball"), Tolerances())
    assert band == pytest.approx(0.1 * 0.05 * (solution("bouncing-ball").episodes["t_stick"].iloc[0] - 0.4515) * 0.5,
                                 rel=1e-3)
    assert len(_script_view(traj, scene, band)) == 9 < len(_script_view(traj, scene, 0.0))


def test_the_exact_ball_is_measured_exactly_and_a_wrong_r_is_caught():
    # samples of the exact reference: every impact of the log gives e = R to rounding (the free parabola is exact);
    # the same ball with R = 0.45 is measured at 0.45
    for r in (0.5, 0.45):
        scene = load_scene("bouncing-ball", [f"restitution={r}"])
        got = _script_view(reference_trajectory(scene, 1e-4), scene, flight_band(solution("bouncing-ball"), Tolerances()))
        e = [-v_out / v_in for _, _, v_in, v_out in got if math.isfinite(v_out)]
        assert len(e) >= 5 and np.allclose(e, r, rtol=1e-6)


def test_the_scripts_constants_are_the_extractions():
    options = ExtractionOptions()
    assert (sampled_impacts.FLOOR_STEPS, sampled_impacts.JUMP_FACTOR, sampled_impacts.JUMP_ATOL) == \
        (options.floor_steps, options.jump_factor, options.jump_atol)


def _wall_view(traj, scene, wall: str) -> tuple[list, ...]:
    """One wall's normal coordinates of a run as ``wall_impacts`` takes them: t, d, u, a, contact, force."""
    n = 1.0 if wall == "lower" else -1.0
    a = n * free_relative_acceleration(scene, traj.t, traj.x1, traj.v1, traj.y, traj.vy)
    force = np.asarray(traj.normal_force[wall], dtype=float)
    return (traj.t.tolist(), (n * (traj.y - scene.gap.position(wall))).tolist(), (n * traj.vy).tolist(), a.tolist(),
            (force > 0.0).tolist(), force.tolist())


@pytest.mark.parametrize("name, over, engine, dt, settings", RUNS, ids=[f"{r[0]}-{r[2]}" for r in RUNS])
def test_the_first_impact_read_up_to_it_is_the_first_of_all(name, over, engine, dt, settings):
    """``first_impact`` (a strike's, read only up to it) is ``wall_impacts``' first, field for field, on every wall
    of real runs, from every start: those where a contact run comes first and those where a jump does."""
    scene = load_scene(name, over)
    traj = run_engine(engine, scene, make_settings(engine, dt, settings))
    kinds = set()
    for wall in scene.gap.walls:
        view = _wall_view(traj, scene, wall)
        every = sampled_impacts.wall_impacts(*view)
        for start in sorted({0, *(imp["first"] - 1 for imp in every[:40])}):
            cut = [c[max(start, 0):] for c in view]
            full = sampled_impacts.wall_impacts(*cut)
            first = sampled_impacts.first_impact(*cut)
            assert (first is None) == (not full)
            if first is not None:
                assert first == {k: full[0][k] for k in first}
                kinds.add(first["contact"])
    assert True in kinds  # a contact run's onset was a first impact somewhere


def test_a_jump_before_the_contact_comes_first_and_no_impact_is_none():
    """Known answers both ways: a velocity jump between free samples before the first contact run is the first impact
    (its first sample is the jump's second), and motion with neither gives None."""
    t = [0.0, 1e-3, 2e-3, 3e-3, 4e-3]
    d = [1e-4, 1e-5, 2e-5, 0.0, 0.0]
    u = [-0.1, -0.1, 0.1, 0.0, 0.0]  # +0.2 m/s in one free step near the wall: a jump at k = 1
    a = [-9.81] * 5
    contact = [False, False, False, True, True]
    first = sampled_impacts.first_impact(t, d, u, a, contact, [0.0, 0.0, 0.0, 1.0, 1.0])
    assert first["first"] == 2 and first["contact"] is False
    every = sampled_impacts.wall_impacts(t, d, u, a, contact, [0.0, 0.0, 0.0, 1.0, 1.0])
    assert [imp["contact"] for imp in every] == [False, True] and first == {k: every[0][k] for k in first}
    flight = [0.1 - 0.5 * 9.81 * s * s for s in t]
    assert sampled_impacts.first_impact(t, flight, [-9.81 * s for s in t], a, [False] * 5, [0.0] * 5) is None
