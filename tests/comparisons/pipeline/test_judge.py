"""The judge against the real engines and the exact reference: known answers both ways.

The exact reference, sampled like an engine, must be a match everywhere; an engine given the
wrong restitution must be caught; nothing may depend on the run's length or on the
extraction's internal thresholds beyond the cases named (with their physical reason) below.
"""

from __future__ import annotations

import dataclasses
import functools

import pytest

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons import Tolerances, compare, reference_trajectory
from chatterbench.comparisons.ci.checks import run_check
from chatterbench.comparisons.ci.gate import limits_from_keywords, make_check
from chatterbench.comparisons.pipeline.extract_options import ExtractionOptions
from chatterbench.comparisons.pipeline.judge import ERROR_COLUMNS
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.vocabulary import combine
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import load_scene

from helpers import solution
from shared_engine_runs import engine_run

SCENES = tuple(CATALOGUE)
DTS = (1e-3, 3e-4, 1e-4)


@functools.cache
def sampled(name: str, dt: float):
    """The exact reference of built-in scene ``name`` sampled like an engine at ``dt`` [s], made once per process
    (the known answer below, and the reference's row of the thresholds' robustness test)."""
    ref = solution(name)
    return reference_trajectory(ref.scene, dt, ref.exhaustive)


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("dt", DTS)
def test_the_exact_reference_sampled_like_an_engine_matches_everywhere(name, dt):
    ref = solution(name)
    known = sampled(name, dt)
    c = compare(ref.scene, engines=("mujoco", "pybullet"), trajectories={"mujoco": known, "pybullet": known},
                solution=ref)
    assert len(c.table) == 2 * len(ref.episodes) > 0
    assert (c.table["verdict"] == "match").all(), c.table[["engine", "wall", "verdict", *ERROR_COLUMNS]]
    # and it is judged the same whichever engine it is labelled as: nothing engine-specific is read
    a, b = (c.table[c.table["engine"] == e].drop(columns="engine").reset_index(drop=True) for e in ("mujoco", "pybullet"))
    assert a.drop(columns="cost_per_sim_s").equals(b.drop(columns="cost_per_sim_s"))


# Feigin's pair over its first 8 s in the wrong-R test: one sliding episode on each wall (its whole 40 s run is
# 400,000 PyBullet steps). Measured there: at R both match (restitution errors -0.004, -0.005), at 0.9 R both early
# (-0.113, -0.100), at 1.1 R both late (+0.101, +0.105)
SHORTER = {"feigin-pair": ["duration=8"]}


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_pybullet_with_the_wrong_restitution_is_caught(name, factor, tmp_path_factory):
    # PyBullet applies R exactly at every impact; run with R x 0.9 or x 1.1 and judged against
    # the scene's R, its resolved impacts are 10% off and its chatter ends early or late
    # (the runs at 0.9 R of the ball and of Feigin's pair's 8 s are tests/engines/test_window.py's too: shared_engine_runs.py)
    ref = solve(load_scene(name, SHORTER[name])) if name in SHORTER else solution(name)
    wrong = dataclasses.replace(ref.scene, restitution=ref.scene.restitution * factor)
    traj = engine_run(tmp_path_factory, "pybullet", wrong, 1e-4)
    c = compare(ref.scene, engines=("pybullet",), trajectories={"pybullet": traj}, solution=ref)
    assert not (c.table["verdict"] == "match").all(), c.table[["wall", "verdict"]]
    judged = c.table.dropna(subset=["restitution_error"])
    assert len(judged) and ((judged["restitution_error"] - (factor - 1)).abs() < 0.02).all()


def test_nothing_depends_on_the_runs_duration():
    # the tolerances come from each visit (chatter 0.903 s), not from the run (2 s or 3 s)
    rows = []
    for duration in (2.0, 3.0):
        c = compare(load_scene("bouncing-ball", [f"duration={duration}"]), settings=settings_for(("mujoco",), 1e-4))
        assert len(c.table) == 1
        rows.append(c.table.iloc[0])
    for col in ("verdict", "resolved_impacts", "ref_resolved_impacts"):
        assert rows[0][col] == rows[1][col], col
    # the same engine samples give the same numbers; the reference's Zeno point may differ in
    # its last bit between the two runs (its chase is a sum over ~30 impacts)
    for col in ("t_stick", "stick_error_zeno", "stick_error_rel", "restitution_error", "penetration_max"):
        assert rows[0][col] == pytest.approx(rows[1][col], rel=1e-12, abs=1e-15), col


def test_a_failed_run_never_agrees_and_fails_a_gate(monkeypatch):
    # 0.3 s of the ball: it has not reached the floor, the reference has no episode to judge
    scene = load_scene("bouncing-ball", ["duration=0.3"])
    ok = compare(scene, settings=settings_for(("pybullet",), 1e-3))
    assert ok.summary()["verdict"].tolist() == ["none"]
    monkeypatch.setenv("CHATTERBENCH_FAULT", "raise:pybullet")  # the test-only fault hook, engines/faults.py
    failed = compare(scene, settings=settings_for(("pybullet",), 1e-3))
    assert failed.runs["pybullet"].status == "error"
    assert failed.table["verdict"].tolist() == ["error"] and failed.summary()["verdict"].tolist() == ["error"]
    # a gate that accepts "no sliding" does not accept a run that failed to say anything ...
    check = make_check(scene, "pybullet", limits_from_keywords(verdict=["match", "none"]), dt=1e-3)
    assert not run_check(check).passed
    # ... nor does a gate without any verdict limit; only naming the failure accepts it
    check = make_check(scene, "pybullet", limits_from_keywords(n_episodes=0), dt=1e-3)
    assert not run_check(check).passed
    check = make_check(scene, "pybullet", limits_from_keywords(verdict=["none", "error"]), dt=1e-3)
    assert run_check(check).passed


@pytest.fixture(scope="module")
def damper_mujoco():
    """MuJoCo at its defaults on the impact damper, dt = 1e-4 s, compared (read by two tests)."""
    return compare(load_scene("impact-damper"), settings=settings_for(("mujoco",), 1e-4))


def test_a_missed_episode_still_counts_the_engines_impacts(damper_mujoco):
    # MuJoCo at its defaults on the impact damper: the soft contact bounces through the first
    # visits without sticking; the impacts it made there are counted all the same
    c = damper_mujoco
    missed = c.table[c.table["verdict"] == "missed"]
    assert len(missed) >= 2
    assert (missed["n_impacts"] >= 3).all()


def test_penetration_is_judged_against_the_scene_not_the_engine():
    # at dt = 1e-3 MuJoCo's default contact is w0 = 30 rad/s: a 1.2 m/s strike sinks about
    # v / w0 = 35 mm into the 40 mm cavity; the allowance is 10% of the gap for every engine
    c = compare(load_scene("impact-damper"), settings=settings_for(("mujoco", "pybullet"), 1e-3))
    mj, pb = (c.table[c.table["engine"] == e] for e in ("mujoco", "pybullet"))
    assert c.runs["mujoco"].t_penetrated == c.runs["mujoco"].t_penetrated  # measured, not NaN
    assert "penetrated" in set(mj["verdict"]) and mj["penetration_max"].max() > 0.004
    assert "penetrated" not in set(pb["verdict"]) and pb["penetration_max"].max() < 0.004


def test_the_summary_combines_by_severity(damper_mujoco):
    c = damper_mujoco
    assert c.summary()["verdict"].iloc[0] == combine(c.table["verdict"])


# -- robustness: every internal threshold of the extraction x 10 and / 10 ------------------

# Where a verdict flips, and why (measured on this code; the closing note of the judge issue
# lists the same cases):
#   floor/10  the sampling floor (4 steps -> 0.4) falls below a rigid engine's resting hops
#             (one impulse every third step, flights of ~2 steps): they count as bounces again
#   soft      a soft or coarse engine sticks gradually, one shrinking bounce after another with
#             a long contact between, so its sticking start moves with the band that says
#             "stuck" (x 10 in band is x 100 in height): where it is within about one tolerance
#             of the limit, the verdict follows the band
#   floor x10 a 40-step floor is 40 ms at dt = 1e-3, longer than the impact damper's last
#             flights that matter (its chatter lasts 0.1 s)
#   resolved  resolved_steps x 10 leaves only MuJoCo's fast impacts to judge, which follow R
#   shown     a 40-step floor shows no sliding shorter than 3.5 floors (f_min past a sticking start placed
#             to f_min / (1 - R), R = 0.6): 140 ms at dt = 1e-3, 42 ms at 3e-4, so the impact damper's
#             21 ms sliding that PyBullet misses is unresolved, not missed (issue 34: never a confident
#             verdict the extraction cannot support)
#   rest      a wider band (or floor) ends MuJoCo's bouncing earlier at dt = 3e-4 (w0 dt = 0.3): its sticking
#             start comes in time, and the last bounces fall into the rest after it, where the persistence
#             check sees the contact open (buzz instead of late; the bounces are the same). Both fail.
#   end       MuJoCo at dt = 1e-3 (w0 = 30 rad/s) sticks 0.86 s late: in the run's last visit it
#             is still bouncing when the data end (missed); a wider band ends its bouncing in
#             time (late). Both fail.
ALLOWED_FLIPS = {
    ("bouncing-ball", "mujoco", 3e-4, "band x10"): "rest",
    ("feigin-pair", "mujoco", 3e-4, "band x10"): "rest",
    ("feigin-pair", "mujoco", 3e-4, "floor_steps x10"): "rest",
    ("feigin-pair", "mujoco", 1e-3, "band x10"): "end",
    ("impact-damper", "mujoco", 1e-4, "band x10"): "soft",
    ("spring-pair", "mujoco", 1e-4, "band x10"): "soft",
    ("spring-pair", "pybullet", 1e-3, "band x10"): "soft",
    ("bouncing-ball", "mujoco", 1e-4, "band/10"): "soft",
    ("feigin-pair", "mujoco", 1e-4, "band/10"): "soft",
    ("feigin-pair", "mujoco", 1e-3, "floor_steps x10"): "end",
    ("impact-damper", "mujoco", 1e-3, "floor_steps x10"): "floor x10",
    ("impact-damper", "mujoco", 1e-4, "floor_steps x10"): "soft",
    ("spring-pair", "mujoco", 3e-4, "floor_steps x10"): "soft",
    ("spring-pair", "mujoco", 1e-4, "floor_steps x10"): "soft",
    ("spring-pair", "pybullet", 1e-3, "floor_steps x10"): "soft",
    ("impact-damper", "reference", 1e-3, "floor_steps x10"): "floor x10",
    ("impact-damper", "pybullet", 1e-3, "floor_steps x10"): "shown",
    ("impact-damper", "pybullet", 3e-4, "floor_steps x10"): "shown",
    ("feigin-pair", "mujoco", 1e-3, "floor_steps/10"): "floor/10",
    ("impact-damper", "mujoco", 1e-4, "floor_steps/10"): "floor/10",
    ("feigin-pair", "pybullet", 1e-3, "floor_steps/10"): "floor/10",
    ("impact-damper", "pybullet", 1e-3, "floor_steps/10"): "floor/10",
    ("impact-damper", "pybullet", 3e-4, "floor_steps/10"): "floor/10",
    ("impact-damper", "pybullet", 1e-4, "floor_steps/10"): "floor/10",
    ("spring-pair", "pybullet", 1e-3, "floor_steps/10"): "floor/10",
    ("spring-pair", "pybullet", 3e-4, "floor_steps/10"): "floor/10",
    ("bouncing-ball", "mujoco", 1e-4, "resolved_steps x10"): "resolved",
}


def _variants():
    base = ExtractionOptions()
    for f in dataclasses.fields(ExtractionOptions):
        if getattr(base, f.name) == 0:  # position_rounding: 0 x 10 = 0 / 10 = 0 is the base itself, nothing varied
            continue
        for k, label in ((10.0, "x10"), (0.1, "/10")):
            yield f"{f.name}{' ' if label == 'x10' else ''}{label}", dataclasses.replace(base, **{f.name: getattr(base, f.name) * k}), Tolerances()
    for k, label in ((10.0, " x10"), (0.1, "/10")):
        steps = Tolerances().resolved_steps * k
        if steps > 1:
            yield f"resolved_steps{label}", base, Tolerances(resolved_steps=steps)


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_verdicts_do_not_follow_the_extractions_internal_thresholds(name, tmp_path_factory):
    ref = solution(name)
    flips = []
    for dt in DTS:
        runs = {"reference": sampled(name, dt)}
        for engine in ("mujoco", "pybullet"):  # the runs at 1e-4 s are test_window.py's and test_compare.py's too
            runs[engine] = engine_run(tmp_path_factory, engine, ref.scene, dt)
        for label_engine, traj in runs.items():
            base = compare(ref.scene, engines=("mujoco",), trajectories={"mujoco": traj}, solution=ref)
            for label, options, tol in _variants():
                varied = compare(ref.scene, engines=("mujoco",), trajectories={"mujoco": traj}, solution=ref,
                                 options=options, tol=tol)
                if varied.table["verdict"].tolist() != base.table["verdict"].tolist():
                    flips.append((name, label_engine, dt, label))
    unexpected = [f for f in flips if f not in ALLOWED_FLIPS]
    assert not unexpected, unexpected


def test_a_run_that_ends_in_the_middle_of_a_bounce_is_not_a_stick():
    # 0.455 s of the ball: MuJoCo's soft contact is in the middle of the first bounce (it began
    # at 0.4515 s and lasts ~10 ms) when the data end. Found while building the judge: a
    # contact the data end in was taken for sticking, a spurious episode at the end of the run.
    c = compare(load_scene("bouncing-ball", ["duration=0.455"]), settings=settings_for(("mujoco",), 1e-4))
    assert c.runs["mujoco"].trajectory.contact["lower"][-1]  # the data do end in contact
    assert c.table.empty and c.summary()["verdict"].tolist() == ["none"]


def test_rows_of_gives_what_itertuples_gives_and_errors_what_pandas_gives():
    # the judge's row iteration and error columns (faster forms of pandas' own): the same values, types and dtypes,
    # on a reference's episodes (strings, ints, floats, NaN) and on an empty table
    import math

    import numpy as np
    import pandas as pd

    from chatterbench.comparisons.pipeline.judge import TABLE_COLUMNS, errors, rows_of

    episodes = solution("feigin-pair").episodes
    fast, slow = list(rows_of(episodes)), [tuple(r)[1:] for r in episodes.itertuples()]
    assert repr([tuple(r) for r in fast]) == repr(slow) and fast[0]._fields == tuple(episodes.columns)  # NaN too
    assert [type(v) for v in fast[0]] == [type(v) for v in slow[0]]
    assert list(rows_of(episodes.iloc[:0])) == []

    def pandas_errors(table: pd.DataFrame, dt: float) -> None:  # errors() as it was written with pandas
        table["first_impact_error"] = table["t_first_impact"] - table["ref_t_first_impact"]
        table["stick_error_plate"] = table["t_stick"] - table["ref_t_plate_entry"]
        table["stick_error_zeno"] = table["t_stick"] - table["ref_t_stick"]
        table["exit_error"] = table["t_exit"] - table["ref_t_exit"]
        scale = table["stick_scale"].where(table["stick_scale"] > 0)
        table["first_impact_error_rel"] = table["first_impact_error"] / scale
        table["stick_error_rel"] = table["stick_error_zeno"] / scale
        table["exit_error_rel"] = table["exit_error"] / table["sliding_duration"].where(table["sliding_duration"] > 0)
        table["stick_error_steps"] = table["stick_error_zeno"] / dt
        table["exit_error_steps"] = table["exit_error"] / dt

    nan = math.nan
    filled = pd.DataFrame({"t_first_impact": [1.0, nan, 2.5], "ref_t_first_impact": [0.9, 1.0, nan],
                           "t_stick": [1.5, nan, 3.0], "ref_t_plate_entry": [1.4, 1.2, nan], "ref_t_stick": [1.45, 1.3, 2.9],
                           "t_exit": [2.0, nan, nan], "ref_t_exit": [2.1, 2.0, nan], "stick_scale": [0.5, 0.0, nan],
                           "sliding_duration": [0.6, -1.0, 0.0]})
    for table in (filled, pd.DataFrame(columns=[*TABLE_COLUMNS, "stick_scale"])):
        a, b = table.copy(), table.copy()
        errors(a, 1e-3)
        pandas_errors(b, 1e-3)
        pd.testing.assert_frame_equal(a, b, check_exact=True)
    errors(filled, 1e-3)  # a known answer: 0.05 s late of a 0.5 s scale; no scale, no relative error
    assert repr(filled["stick_error_rel"].tolist()) == repr([(1.5 - 1.45) / 0.5, nan, nan])
    assert np.isnan(filled["exit_error_rel"].to_numpy()[1:]).all()


def test_a_judged_table_has_one_type_per_column_with_episodes_with_a_run_row_and_with_neither():
    # judge makes its table once from columns (not a pandas assignment per column): the types a reader gets stay those
    # of the table pandas made from the rows (counts int64, times and errors float64, words strings), with episodes,
    # with the row of a failed run whose episodes do not say so, and with no row at all
    import numpy as np

    from chatterbench.comparisons.pipeline.extract import extract
    from chatterbench.comparisons.pipeline.judge import TABLE_COLUMNS, judge

    counts = {"n_impacts", "ref_n_impacts", "resolved_impacts", "ref_resolved_impacts", "unmeasured_impacts",
              "contact_onsets"}
    words = {"wall", "verdict", "reason"}
    ref = solution("impact-damper")
    traj = reference_trajectory(ref.scene, 1e-3, ref.exhaustive)
    found = extract(traj, ref.scene, ref.stick_tolerance(Tolerances().stick))
    failed = dataclasses.replace(traj, status="error")
    short = solve(load_scene("bouncing-ball", ["duration=0.3"]))  # no episode on either side
    short_traj = reference_trajectory(short.scene, 1e-3, short.exhaustive)
    short_found = extract(short_traj, short.scene, short.stick_tolerance(Tolerances().stick))
    tables = {"episodes": judge(ref, found, traj).table, "run row": judge(ref, found, failed).table,
              "none": judge(short, short_found, short_traj).table,
              "none, failed": judge(short, short_found, dataclasses.replace(short_traj, status="error")).table}
    assert len(tables["episodes"]) == 9 and set(tables["episodes"]["verdict"]) == {"match"}
    assert tables["run row"]["wall"].tolist()[-1] == "" and tables["run row"]["verdict"].tolist()[-1] == "error"
    assert tables["none"].empty and tables["none, failed"]["verdict"].tolist() == ["error"]
    for name in ("episodes", "run row", "none, failed"):
        table = tables[name]
        assert list(table.columns) == TABLE_COLUMNS
        for c in TABLE_COLUMNS:
            kind = table[c].dtype
            if c in counts:
                assert kind == np.int64, (name, c, kind)
            elif c in words:
                assert kind.kind in "OUT" or str(kind) == "str", (name, c, kind)
                assert all(isinstance(v, str) for v in table[c]), (name, c)
            else:
                assert kind == np.float64, (name, c, kind)
