"""Restitution under the scene's own forces: known answers both ways, the guide's claim, and tune counting a miss."""

import math

import numpy as np
import pandas as pd
import pytest

from chatterbench.comparisons.outputs.guide import guide_markdown
from chatterbench.comparisons.outputs.restitution_curve import restitution_curve_figure
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.studies.restitution_curve import STRIKES, restitution_band, restitution_curve
from chatterbench.comparisons.studies.scene_restitution import miss_summary, scene_restitution
from chatterbench.comparisons.studies.tune import tune
from chatterbench.comparisons.studies.tune.choice import choose
from chatterbench.comparisons.studies.tune.evidence import evidence
from chatterbench.engines.registry import make_settings
from chatterbench.reference import load_scene

BALL = solve(load_scene("bouncing-ball"))
TOL = 0.05  # the default restitution tolerance


def test_a_newton_impulse_meets_r_under_gravity_at_every_place_in_a_step():
    # PyBullet's impulse is Newton's law: within 2% of R where the judge holds it to R (gravity's g dt / v over the
    # step: e = 0.4995 to 0.5005 at 4.43 m/s, 0.492 to 0.508 at 0.277 m/s), whatever the phase
    m = miss_summary(scene_restitution("pybullet", make_settings("pybullet", 3e-4), BALL), TOL)
    assert len(m.held) == 5 * STRIKES and m.held["speed"].max() == pytest.approx(math.sqrt(2 * 9.81), rel=1e-3)
    assert abs(m.value) <= 0.02 and m.held.groupby("impact").size().eq(STRIKES).all()


def test_a_stiff_soft_contact_is_caught_at_some_place_in_every_step():
    # the case: MuJoCo at w0 dt = 0.3 (dt = 3e-4) struck halfway through a step gave e within 3% at 4.43 m/s;
    # over the step it gives 0.453 to 0.536 (-9.3%..+7.1%), its ends included (the user measured 0.452 and
    # 0.533): the claim now says so, and no impact is within 5% at every phase
    m = miss_summary(scene_restitution("mujoco", make_settings("mujoco", 3e-4, ["mujoco.w0_dt=0.3"]), BALL), TOL)
    assert m.holds_from == math.inf and m.value < -TOL
    assert m.describe().startswith("e = 0.453-0.536 (-9.3%..+7.1%) at 4.43 m/s (impact 1)")
    fastest = m.strikes[m.strikes["impact"] == 1]
    assert len(fastest) == STRIKES and fastest["restitution_effective"].max() - fastest["restitution_effective"].min() > 0.08
    # the two ends of the step, where e jumps: aimed at 0.002 of a step after a sample and before the next
    ends = sorted(fastest["phase"])
    assert ends[0] == pytest.approx(0.002, abs=1e-3) and ends[-1] == pytest.approx(0.998, abs=1e-3)


def test_the_guide_setting_misses_at_slow_impacts_with_numbers():
    settings = make_settings("mujoco", 3e-4, ["mujoco.w0_dt=0.1"])
    strikes = scene_restitution("mujoco", settings, BALL)
    m = miss_summary(strikes, TOL)
    # held to R (u <= 5%) down to the ball's 5th impact, 0.277 m/s, where the spring-damper lifting the
    # ball loses 6.7% to 12.8% over the step (measured; the from-scratch model: 0.458 at 0.3 m/s)
    assert m.held_from == pytest.approx(0.2768, rel=1e-3)
    assert m.value < -0.12 and m.speed == pytest.approx(0.2768, rel=1e-3)
    assert "e = 0.436-0.467 (-12.8%..-6.7%) at 0.277 m/s (impact 5)" in m.describe()
    # R holds at every phase from 2.21 m/s: the first miss is impact 3 at some place in the step (-6.0%)
    assert m.holds_from == pytest.approx(2.2147, rel=1e-3) and m.describe().startswith("e = 0.470-0.497")
    # the same setting force-free: the contact law alone gives R within 3.5% at every speed and phase (0.484 to 0.510)
    free = restitution_curve("mujoco", settings, 0.5, strikes["speed"].unique(), BALL.scene)
    assert (free["restitution_error"].abs() < 0.035).all() and len(free) == 8 * STRIKES


def test_tune_counts_the_miss_and_the_guide_says_so():
    space = {"dt": (3e-4,), "mujoco.w0_dt": (0.1,), "mujoco.integrator": ("euler",)}
    result = tune(BALL.scene, "mujoco", 0.2, space=space, workers=1, refine_steps=0)
    c = result.chosen
    # the check strikes the impacts the judge holds to R (u <= the restitution tolerance 0.05: impacts 1 to 5), at 10
    # places in a step each; the worst is impact 5 at its worst place in the step (struck halfway: -9.1%)
    assert c["scene_restitution_ratio"] > 1.0 and "restitution under the scene's forces -0.128 at 0.277 m/s" in c["failed"]
    assert c["r_struck"] == "5 impacts, 4.43 to 0.277 m/s, each at 10 places in a step"
    ev = evidence(result, speeds=[0.5, 4.0])
    text = guide_markdown(result, ev=ev)
    assert "**Restitution under the scene's forces:**" in text and "8 impacts, 4.43 to 0.0346 m/s, each at 10 places" in text
    assert "e = 0.415-0.447 (-17.1%..-10.5%) at 0.138 m/s (impact 6)" in text and "to R at 0.277 m/s and faster" in text
    # and the run's own impacts as the judge measures them, which mujoco/run.py prints
    assert "**The run's impacts:**" in text and "(`mujoco/run.py` prints each of them, the same e)" in text
    assert "#5 at t = 1.3126 s, 0.249 m/s: e = 0.4521" in text


def test_choose_prefers_a_passing_candidate_that_meets_r():
    base = {"verdict": "match", "n_non_default": 0, "cost_per_sim_s": 1.0}
    table = pd.DataFrame([{**base, "dt": 3e-4, "steps_per_sim_s": 3333.0, "scene_restitution_ratio": 1.8},
                          {**base, "dt": 1e-4, "steps_per_sim_s": 10000.0, "scene_restitution_ratio": 0.8}])
    assert choose(table)["dt"] == 1e-4  # dearer, but it meets R where the judge holds it
    table.loc[1, "scene_restitution_ratio"] = 1.5
    assert choose(table)["dt"] == 3e-4  # none meets R: the cheapest pass, and the guide says where it misses


def test_figure_labels_every_marker_without_overlap_and_draws_the_band():
    settings = make_settings("mujoco", 3e-4, ["mujoco.w0_dt=0.1"])
    from chatterbench.comparisons.studies.restitution_curve import impact_restitutions

    strikes = scene_restitution("mujoco", settings, BALL)
    impacts = impact_restitutions("mujoco", settings, BALL.scene, BALL)
    curve = restitution_curve("mujoco", settings, 0.5, [0.05, 5.0], BALL.scene)
    fig = restitution_curve_figure(curve, impacts, "bouncing-ball", strikes, TOL)
    ax = fig.axes[0]
    texts = [t for t in ax.texts]
    numbered = {t.get_text() for t in texts if t.get_text().startswith("#")}
    assert numbered == {f"#{k}" for k in impacts["impact"]}  # every run impact numbered, the slow ones too
    band = restitution_band(strikes)
    # one label per struck impact: the range of e over the 10 places in a step, as the band says it
    ranges = [t.get_text() for t in texts if not t.get_text().startswith("#")]
    assert sorted(ranges) == sorted(f"{lo:.3f}-{hi:.3f}" for lo, hi in zip(band["e_min"], band["e_max"]))
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in texts]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not a.overlaps(b), (a, b)
    tol_band = ax.patches[0].get_window_extent(renderer).transformed(ax.transData.inverted())
    assert tol_band.y0 == pytest.approx(0.5 * (1 - TOL), abs=1e-6) and tol_band.y1 == pytest.approx(0.5 * (1 + TOL), abs=1e-6)
    # the strikes' error bars span each impact's min to max, the force-free curve's band its phases' spread
    bars = [c for c in ax.collections if c.__class__.__name__ == "LineCollection"]
    spans = sorted((round(float(s[:, 1].min()), 9), round(float(s[:, 1].max()), 9)) for s in bars[0].get_segments())
    assert spans == sorted((round(lo, 9), round(hi, 9)) for lo, hi in zip(band["e_min"], band["e_max"]))
    free = restitution_band(curve)
    filled = [c for c in ax.collections if c.__class__.__name__ in ("PolyCollection", "FillBetweenPolyCollection")][0]
    ys = filled.get_paths()[0].vertices[:, 1]
    assert ys.min() == pytest.approx(free["e_min"].min(), abs=1e-12) and ys.max() == pytest.approx(free["e_max"].max(), abs=1e-12)


def test_guide_html_shows_the_restitution_figure_at_full_width():
    import re

    from chatterbench.comparisons.outputs.guide import guide_figures, guide_html
    from chatterbench.comparisons.studies.tune.evidence import evidence

    result = tune(BALL.scene, "pybullet", 0.2, space={"dt": (1e-3,)}, workers=1, refine_steps=0)
    page = guide_html(result, guide_figures(result, evidence(result, speeds=[0.5, 4.0])))
    # an HTML reader's view of it: the R(v) image is not in a narrow flex column, it spans the page
    img = re.search(r'<img alt="restitution_curve"([^>]*)>', page).group(1)
    assert 'style="width: 100%"' in img and "flex: 1 1 45%" not in page


def test_the_strikes_of_every_impact_go_to_the_engine_together_with_the_same_rows(monkeypatch):
    # before: one batch per impact and try, and one for each impact's step ends (26 for the ball at dt = 3e-4, each
    # compiling MuJoCo's model anew); now one per try for all impacts, one for every impact's ends, one for re-aims
    from chatterbench.comparisons.studies import restitution_curve as rc
    from chatterbench.comparisons.studies.restitution_curve import Target, strike, strike_all
    from chatterbench.comparisons.studies.scene_restitution import strike_starts, struck_impacts

    batches = []
    real = rc.run_engine_batch
    monkeypatch.setattr(rc, "run_engine_batch", lambda engine, jobs: batches.append(len(jobs)) or real(engine, jobs))
    settings = make_settings("mujoco", 3e-4, ["mujoco.w0_dt=0.1"])
    impacts = struck_impacts(BALL, 3e-4, 10.0, most=3)
    targets = [Target(lambda steps, phase, imp=imp: strike_starts(BALL, imp.t, imp.t_before, 3e-4, [phase])[phase](steps),
                      imp.wall, imp.speed) for imp in impacts.itertuples()]
    together = strike_all("mujoco", settings, targets, [0.25, 0.75], ends=True)
    n_together = len(batches)
    assert batches[0] == 2 * len(targets)  # the first try: every impact's strikes at once
    one_by_one = [strike("mujoco", settings, t.make_scene, t.wall, t.speed, [0.25, 0.75], ends=True) for t in targets]
    assert len(batches) - n_together >= 2 * len(targets) > n_together  # alone: at least two batches per impact
    assert [[r["restitution_effective"] for r in rows] for rows in together] == \
        [[r["restitution_effective"] for r in rows] for rows in one_by_one]  # bit for bit: MuJoCo's runs are
    assert pd.DataFrame([r for rows in together for r in rows]).equals(pd.DataFrame([r for rows in one_by_one for r in rows]))
