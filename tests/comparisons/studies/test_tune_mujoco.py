"""MuJoCo under tune (issue 26): no robust setting passes the judge's restitution check at T = 0.05, and why.

A brute-force grid through the judge (issue 26's closing note: dt 1e-2 .. 5.9e-5, 1.25x apart; w0_dt
0.055 .. 0.95 on tune's lattice; impedance 0.9 / 0.99 / 0.9999) found no MuJoCo setting on feigin-pair
that passes at T = 0.05 (0 of 720), and on bouncing-ball and spring-pair only isolated passes whose dt x 0.8
or x 1.25 fails: the check that fails is restitution at the slowest impacts the judge measures. The judge
measures an impact when its sampling uncertainty is within the restitution tolerance, so a looser tolerance
admits slower impacts, where MuJoCo's spring-damper loses more of R to the scene's own forces during the
contact: the worst error follows the tolerance up instead of falling under it. At the restitution
tolerance 0.2 (0.25 on feigin-pair) tune then found an answer on each (``ISSUE_26_ANSWERS``), robust at dt x 0.8
and x 1.25; issue 41 found that their contact flickers after every stick at MuJoCo's impedance d = 0.99 and
0.9999 (``buzz``), and that d = 0.9 holds it closed.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from chatterbench.comparisons import reference_trajectory
from chatterbench.comparisons.pipeline.compare import compare, judge_run
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.tune import tune
from chatterbench.comparisons.studies.tune.answer import recommended
from chatterbench.comparisons.studies.tune.checks import check_ratios, describe_failures
from chatterbench.comparisons.studies.tune.passes import agrees
from chatterbench.engines.registry import make_settings, settings_for
from chatterbench.reference import load_scene

T = 0.05


def _tol(restitution: float) -> Tolerances:
    return Tolerances(stick=T, exit=T, first_impact=T, restitution=restitution)


# tune's answers for MuJoCo before issue 41 (robust at dt x 0.8 and x 1.25 then, measured with `chatterbench tune
# SCENE --engines mujoco --tolerance T --tolerance restitution=R --workers 1`): scene -> (T, R, dt [s], settings)
ISSUE_26_ANSWERS = {
    "bouncing-ball": (0.05, 0.2, 0.000333, {"mujoco.w0_dt": 0.228, "mujoco.impedance": 0.99}),
    "spring-pair": (0.1, 0.2, 0.000431, {"mujoco.w0_dt": 0.1732, "mujoco.impedance": 0.9999}),
    "feigin-pair": (0.05, 0.25, 0.00015, {"mujoco.w0_dt": 0.1, "mujoco.impedance": 0.99}),
}


def _table(scene, t: float, r: float, dt: float, settings: dict):
    """``compare``'s table with ``settings`` as ``--set K=V`` items, at ``dt`` [s]."""
    tol = Tolerances(stick=t, exit=t, first_impact=t, restitution=r)
    return compare(scene, settings=settings_for(("mujoco",), dt, [f"{k}={v}" for k, v in settings.items()]), tol=tol).table


def _verdicts(scene, t: float, r: float, dt: float, settings: dict) -> list[str]:
    return _table(scene, t, r, dt, settings)["verdict"].tolist()


@pytest.mark.parametrize("name", ISSUE_26_ANSWERS)
def test_the_old_answers_flicker_after_the_stick_and_a_softer_impedance_holds_the_contact(name):
    # issue 41: these passed the old judge, which counted flights shorter than its floor as rest. Measured: after
    # every stick the contact opens for a step at 120-200 onsets per second (open 2.6-6.7% of the rest), the force
    # swinging by its whole load: `buzz` on every episode that sticks (feigin-pair: 11 of 13; two rest)
    t, r, dt, settings = ISSUE_26_ANSWERS[name]
    scene = load_scene(name)
    table = _table(scene, t, r, dt, settings)
    buzz = table[table["verdict"] == "buzz"]
    assert len(buzz) >= len(table) - 2 and len(buzz) > 0, table["verdict"].tolist()
    assert (buzz["onset_rate"] > 100).all() and (buzz["open_fraction"] > 0.02).all() and (buzz["force_swing"] > 0.9).all()
    assert all("contact onsets" in why and "per second" in why for why in buzz["reason"])
    # the other way: the same dt and w0_dt at impedance 0.9 (d = 0.9) keep the contact closed: no onset, no opening
    soft = _table(scene, t, r, dt, {**settings, "mujoco.impedance": 0.9})
    assert "buzz" not in soft["verdict"].tolist()
    assert (soft["open_fraction"].dropna() == 0).all() and (soft["contact_onsets"] == 0).all()


def test_mujoco_restitution_error_follows_the_tolerance_up_on_feigin_pair():
    # a setting near the grid's best on feigin-pair (dt 6.87e-4, w0 dt 0.228, impedance 0.9999: 0.7 s a run).
    # Measured: the worst measured restitution error is 0.123 at the tolerance 0.05 (52 impacts measured),
    # 0.165 at 0.1 (65) and 0.212 at 0.15 (75): above the tolerance each time, by 2.5x to 1.4x
    scene = load_scene("feigin-pair")
    ref = solve(scene)
    settings = make_settings("mujoco", 0.000687195, {"mujoco.w0_dt": 0.228, "mujoco.impedance": 0.9999})
    exact = reference_trajectory(scene, settings.dt, ref.exhaustive)
    worst, measured = [], []
    for r in (0.05, 0.1, 0.15):
        _, table, impacts = judge_run(ref, "mujoco", settings, _tol(r))
        worst.append(float(impacts["excess"].max()))
        measured.append(int(impacts["excess"].notna().sum()))
        assert worst[-1] > r and not table["verdict"].map(agrees).all(), (r, worst)
        # the other way: the exact motion sampled at the same dt passes the same check (measured: 3e-5 at worst,
        # the wall-surface measurement's own error on samples of the exact motion), so the check is within reach
        _, exact_table, exact_impacts = judge_run(ref, "mujoco", None, _tol(r), trajectory=exact)
        assert exact_table["verdict"].map(agrees).all() and float(exact_impacts["excess"].max()) < 1e-3
    # a looser tolerance measures more (slower) impacts, and the worst error grows with it
    assert measured[0] < measured[1] < measured[2] and worst[0] < worst[1] < worst[2], (measured, worst)


def test_mujoco_bouncing_ball_at_t_0_05_is_reported_not_robust_with_the_reason():
    # before the brute force it was open whether tune missed a robust MuJoCo setting here; the grid has none
    # (6 isolated passes in 936 settings, each failing at dt x 0.8 or x 1.25), nor does tune with 2000 runs.
    # A tune within 100 runs of the bouncing ball at the asked tolerances alone (no frontier ladder: the answer is
    # the asked point's; measured, the same best reachable as with the ladder, at a quarter of the CPU) and one compare
    scene = load_scene("bouncing-ball")
    result = tune(scene, "mujoco", T, workers=1, max_runs=100, repeats=1, ladder=None)
    rec = recommended(result)
    assert result.best is None and rec["robust"] is False
    assert rec["failed"] or rec["neighbourhood_fails"]  # the check that fails: its own, or its neighbours'
    # the JSON's setting, through compare, gives the verdict the JSON says
    sets = [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in rec["settings"].items()]
    verdicts = compare(scene, settings=settings_for(("mujoco",), rec["dt"], sets), tol=_tol(0.05)).table["verdict"]
    assert verdicts.map(agrees).all() == agrees(rec["verdict"]), (verdicts.tolist(), rec["verdict"])


def test_an_unmeasured_run_has_no_error_to_measure_and_says_so():
    # before: a run whose every resolved impact the step cannot measure to the restitution tolerance
    # (``unmeasured``: bouncing-ball, MuJoCo at dt 8e-3, w0 dt 0.4408) had a worst ratio of 0.47 (under 1, as
    # if it passed) and no failure named, so tune's best reachable at a small budget was such a run, with an
    # empty reason in recommended.json
    # (its contact also flickers after the stick at impedance 0.99, open 12% of the rest: ``buzz``, which decides
    # first; the persistence check is left out here, tolerance 1, so that the restitution check is what is tested)
    ref, tol = solve(load_scene("bouncing-ball")), dataclasses.replace(_tol(0.05), persistence=1.0)
    allowance = tol.penetration * ref.length_scale
    settings = make_settings("mujoco", 8e-3, {"mujoco.w0_dt": 0.4408})
    _, table, impacts = judge_run(ref, "mujoco", settings, tol)
    assert table["verdict"].tolist() == ["unmeasured"]
    ratios = check_ratios(table, impacts, tol, allowance)
    assert ratios["worst_ratio"] == float("inf")  # no tolerance of the others makes it pass
    assert "1 episode unmeasured (" in describe_failures(table, ratios, tol)
    # the other way: a measured match (dt 4.39804e-4, w0 dt 0.3, impedance 0.9999: worst error 0.785 of its
    # tolerance, measured) keeps its finite ratio and names nothing
    settings = make_settings("mujoco", 0.000439804, {"mujoco.w0_dt": 0.3, "mujoco.impedance": 0.9999})
    _, table, impacts = judge_run(ref, "mujoco", settings, tol)
    ratios = check_ratios(table, impacts, tol, allowance)
    assert table["verdict"].tolist() == ["match"] and ratios["worst_ratio"] == pytest.approx(0.785, abs=0.005)
    assert describe_failures(table, ratios, tol) == ""


def test_an_unresolved_run_is_not_ranked_as_a_near_pass():
    # before: ``unresolved`` (the samples place the sticking start only to more than its tolerance) counted as a
    # measured timing verdict, so its worst ratio was the measured errors' (here 2.19; an unresolved run of small
    # measured errors ranked under 1, as if it passed) and tune's best reachable could be one
    # (PyBullet's default threshold 0 bounces at g dt after the stick, ``buzz``, which decides first: the
    # persistence check is left out here, tolerance 1, so that the timing check is what is tested)
    ref, tol = solve(load_scene("bouncing-ball")), dataclasses.replace(_tol(0.05), persistence=1.0)
    allowance = tol.penetration * ref.length_scale
    _, table, impacts = judge_run(ref, "pybullet", make_settings("pybullet", 0.02, {}), tol)
    assert table["verdict"].tolist() == ["unresolved"]
    ratios = check_ratios(table, impacts, tol, allowance)
    assert ratios["worst_ratio"] == float("inf")
    assert "1 episode unresolved (" in describe_failures(table, ratios, tol)
    # the other way: the same engine at a step that pins the times is measured, its ratio finite
    _, table, impacts = judge_run(ref, "pybullet", make_settings("pybullet", 1e-3, {}), tol)
    assert "unresolved" not in table["verdict"].tolist()
    assert math.isfinite(check_ratios(table, impacts, tol, allowance)["worst_ratio"])
