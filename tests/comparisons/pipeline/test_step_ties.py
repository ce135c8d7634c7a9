"""The judge's tie at the sampling step (issue 43): once the run carries its dt, a flight read from sample times that
shrank by one step to the samples' rounding is one step, not more (``sticking.more_than_a_step``).

Reproduction: PyBullet on bouncing-ball at dt 0.02 s lands with flights 0.05 s then 0.03 s, a shrink of
0.020000000000000018 s. With the samples' median spacing as the step (the code before) that was not more than a step,
so the sticking start came from Feigin's ladder (1.4536 s, unresolved at 5%); carrying dt = 0.02 exactly made it
more, the engine's own ladder extrapolated to 1.6231 s, and the verdict flipped to ``late``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from chatterbench.comparisons.pipeline.compare import judge_run
from chatterbench.comparisons.pipeline.extract import extract
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.sample_grid import at_least_steps, more_than_a_step
from chatterbench.comparisons.pipeline.sticking import sticking_start
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.registry import make_settings
from chatterbench.reference.scene import load_scene

BALL = load_scene("bouncing-ball")
TOL = Tolerances(stick=0.05, exit=0.05, first_impact=0.05, restitution=0.05, persistence=1.0)


def test_a_shrink_of_one_step_read_from_sample_times_is_not_more_than_a_step():
    assert not more_than_a_step(0.05 - 0.03, 0.02)  # 0.020000000000000018: one step, rounded
    assert not more_than_a_step(0.02, 0.02) and not more_than_a_step(0.0199, 0.02)
    # the other way: a shrink that is more than a step by anything the samples can show
    assert more_than_a_step(0.0200001, 0.02) and more_than_a_step(0.04, 0.02)


@pytest.fixture(scope="module")
def pybullet_coarse():
    ref = solve(BALL)
    run, table, _ = judge_run(ref, "pybullet", make_settings("pybullet", 0.02, {}), TOL)
    return ref, run.trajectory, table


def test_the_carried_dt_and_the_median_spacing_give_one_sticking_start(pybullet_coarse):
    ref, traj, table = pybullet_coarse
    median = float(np.median(np.diff(traj.t)))
    assert traj.step == 0.02 and median != 0.02  # the run carries dt; its samples' spacing is dt rounded
    starts = [extract(dataclasses.replace(traj, step=step), BALL, ref.stick_tolerance(TOL.stick)).sticks
              for step in (0.02, median)]
    assert [s["stick_from"].tolist() for s in starts] == [["feigin"], ["feigin"]]
    assert starts[0]["t_stick"].tolist() == starts[1]["t_stick"].tolist() == [pytest.approx(1.45355, abs=1e-5)]
    assert table["verdict"].tolist() == ["unresolved"]


def _ladder(flights: list[float]) -> dict:
    """The impacts of one stuck stretch under g = 9.81 m/s^2: contacts of zero length, then the given flights [s]."""
    t = np.concatenate([[1.30], 1.30 + np.cumsum(flights[:-1])])
    return {"t": t, "t_release": t.copy(), "flight": np.array(flights, float), "a_release": np.full(len(t), -9.81),
            "v_plus": 9.81 * np.array(flights) / 2.0, "t_bound": np.zeros(len(t))}


def test_the_engines_own_ladder_is_taken_where_its_flights_shrink_by_more_than_a_step():
    one_step = _ladder([0.05, 0.03])  # PyBullet's at dt 0.02: a shrink of one step, rounded
    assert sticking_start(one_step, 0, 1, 0.5, 0.02).source == "feigin"
    # the other way: flights that shrink by more than a step give their own ratio, rho = 0.025 / 0.05, and its tail
    more = _ladder([0.05, 0.025])
    stick = sticking_start(more, 0, 1, 0.5, 0.02)
    assert stick.source == "ladder" and stick.ratio == pytest.approx(0.5)
    assert stick.t == pytest.approx(1.35 + 0.025 + 0.025)  # t_release[K] + f_K + f_K rho / (1 - rho)


def test_a_flight_of_exactly_the_resolved_steps_read_from_sample_times_is_resolved():
    # MuJoCo at dt 1e-3 s: a flight of ten steps reads 0.009999999999999787 s; with dt carried exactly it fell under
    # resolved_steps x dt = 0.01 s and feigin-pair's visit counted one resolved impact fewer than the reference's
    # ("resolved impacts differ by 2 > 1" in tune's checks, which the median spacing had not said)
    assert at_least_steps(0.009999999999999787, 10, 1e-3) and at_least_steps(np.array([0.01, 0.02]), 10, 1e-3).all()
    assert not at_least_steps(0.0099, 10, 1e-3) and not at_least_steps(np.nan, 10, 1e-3)  # the other way
    ref = solve(load_scene("feigin-pair", ["duration=12.6"]))
    tol = Tolerances(stick=0.01, exit=0.01, first_impact=0.01)
    _, table, impacts = judge_run(ref, "mujoco", make_settings("mujoco", 1e-3, ["mujoco.w0_dt=0.1"]), tol)
    assert (table["resolved_impacts"] - table["ref_resolved_impacts"]).abs().max() <= tol.impact_count


def test_two_flights_of_the_same_steps_are_equal_not_a_shrinking_ladder():
    # PyBullet at dt 0.00472236 s, started a quarter step late (tune's band): after the onset two flights of 2.5 steps
    # read 0.011805900000000147 and 0.011805899999999925 s, then 1.5 steps; the rounding alone made a "shrinking"
    # ladder of a one-step shrink, extrapolated past the rest (the code before: ``rest``, 1.4509 s, 10.7% late, with
    # the median spacing 0.004722359999999981 s as the step) where Feigin's ladder gives 1.4058 s
    equal = _ladder([0.011805900000000147, 0.011805899999999925, 0.007083539999999999])
    assert sticking_start(equal, 0, 2, 0.5, 0.00472236).source == "feigin"
    # the other way: the same flights with a real shrink between the first two are the engine's own ladder
    shrinking = _ladder([0.0165283, 0.0118059, 0.00708354])
    assert sticking_start(shrinking, 0, 2, 0.5, 0.00472236).source == "ladder"
