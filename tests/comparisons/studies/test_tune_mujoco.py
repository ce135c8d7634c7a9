"""MuJoCo under tune (issue 26): no robust setting passes the judge's restitution check at T = 0.05, and why.

A brute-force grid through the judge (issue 26's closing note: dt 1e-2 .. 5.9e-5, 1.25x apart; w0_dt
0.055 .. 0.95 on tune's lattice; impedance 0.9 / 0.99 / 0.9999) found no MuJoCo setting on feigin-pair
that passes at T = 0.05 (0 of 720), and on bouncing-ball and spring-pair only isolated passes whose dt x 0.8
or x 1.25 fails: the check that fails is restitution at the slowest impacts the judge measures. The judge
measures an impact when its sampling uncertainty is within the restitution tolerance, so a looser tolerance
admits slower impacts, where MuJoCo's spring-damper loses more of R to the scene's own forces during the
contact: the worst error follows the tolerance up instead of falling under it.
"""

from __future__ import annotations

import pytest

from chatterbench.comparisons import reference_trajectory
from chatterbench.comparisons.pipeline.compare import compare, judge_run
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.tune import recommended, tune
from chatterbench.comparisons.studies.tune_search import agrees
from chatterbench.engines.registry import make_settings
from chatterbench.reference import load_scene

T = 0.05


def _tol(restitution: float) -> Tolerances:
    return Tolerances(stick=T, exit=T, first_impact=T, restitution=restitution)


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
        # the other way: the exact motion sampled at the same dt passes the same check (its error is the
        # reference's own, zero to rounding), so the check itself is not out of reach
        _, exact_table, exact_impacts = judge_run(ref, "mujoco", None, _tol(r), trajectory=exact)
        assert exact_table["verdict"].map(agrees).all() and float(exact_impacts["excess"].max()) < 1e-6
    # a looser tolerance measures more (slower) impacts, and the worst error grows with it
    assert measured[0] < measured[1] < measured[2] and worst[0] < worst[1] < worst[2], (measured, worst)


@pytest.mark.slow  # a tune of the bouncing ball within 100 runs and one compare (about 10 s)
def test_mujoco_bouncing_ball_at_t_0_05_is_reported_not_robust_with_the_reason():
    # before the brute force it was open whether tune missed a robust MuJoCo setting here; the grid has none
    # (6 isolated passes in 936 settings, each failing at dt x 0.8 or x 1.25), nor does tune with 2000 runs
    scene = load_scene("bouncing-ball")
    result = tune(scene, "mujoco", T, workers=1, max_runs=100, repeats=1)
    rec = recommended(result)
    assert result.best is None and rec["robust"] is False
    assert rec["failed"] or rec["neighbourhood_fails"]  # the check that fails: its own, or its neighbours'
    # the JSON's setting, through compare, gives the verdict the JSON says
    sets = [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in rec["settings"].items()]
    verdicts = compare(scene, engines=("mujoco",), dt=rec["dt"], overrides=sets, tol=_tol(0.05)).table["verdict"]
    assert verdicts.map(agrees).all() == agrees(rec["verdict"]), (verdicts.tolist(), rec["verdict"])
