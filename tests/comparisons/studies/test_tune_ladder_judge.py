"""The ladder's judge (issue 42, item 2): one run prepared once and judged at every point of tune's tolerance ladder
gives, value for value, what judging each point on its own with ``judge_run`` / ``judge`` gives."""

from __future__ import annotations

import pytest

from chatterbench.comparisons.pipeline.compare import judge_run
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.tune.ladder import Ladder, judge_levels, reference_levels
from chatterbench.engines.registry import make_settings
from chatterbench.reference import load_scene

ASKED = Tolerances(stick=0.05, exit=0.05, first_impact=0.05)  # tune's asked point, as tune's own tests ask it
# (engine, scene, dt [s], settings, verdicts the run gets somewhere on the ladder): passing runs and failing ones
CASES = [
    ("mujoco", "bouncing-ball", 1e-3, {"mujoco.w0_dt": 0.3, "mujoco.impedance": 0.9}, {"late", "rebound", "match"}),
    ("pybullet", "bouncing-ball", 0.00255657, {"pybullet.restitution_velocity_threshold": 0.1}, {"match"}),
    ("pybullet", "bouncing-ball", 1e-4, {}, {"buzz"}),  # threshold 0: it keeps bouncing after the stick
    ("pybullet", "feigin-pair", 2e-3, {"pybullet.restitution_velocity_threshold": 0.01}, {"late", "match"}),
    ("mujoco", "feigin-pair", 1e-3, {"mujoco.w0_dt": 0.1}, {"late"}),
    ("mujoco", "impact-damper", 1e-3, {}, {"penetrated"}),
    ("pybullet", "impact-damper", 1e-3, {}, {"late", "missed", "buzz"}),
]
_SOLUTIONS: dict[str, object] = {}


def _run(engine: str, scene: str, dt: float, settings: dict):
    if scene not in _SOLUTIONS:  # feigin-pair over two forcing periods: its episodes of both walls, in seconds
        _SOLUTIONS[scene] = solve(load_scene(scene, ["duration=12.6"] if scene == "feigin-pair" else []))
    ref = _SOLUTIONS[scene]
    s = make_settings(engine, dt, settings)
    points = Ladder().points(ASKED)
    return ref, s, points, judge_run(ref, engine, s, ASKED)


@pytest.mark.parametrize("engine, scene, dt, settings, seen", CASES, ids=[f"{c[0]}-{c[1]}-{c[2]:g}" for c in CASES])
def test_the_ladder_judge_equals_judging_each_point_on_its_own(engine, scene, dt, settings, seen):
    ref, s, points, (run, table, impacts) = _run(engine, scene, dt, settings)
    known = {points.index(ASKED): (run, table, impacts)}  # as tune's _evaluate has it
    for given in (None, known):
        for shortcut in (True, False):
            new = judge_levels(ref, engine, s, run.trajectory, points, known=given, shortcut=shortcut)
            old = reference_levels(ref, engine, s, run.trajectory, points, known=given, shortcut=shortcut)
            assert new == old  # exact: the same points pass, with the same margins, limits and rests, float for float
    only = range(0, len(points), 3)  # tune's search leaves out the points where the run cannot matter
    assert (judge_levels(ref, engine, s, run.trajectory, points, known=known, only=only)
            == reference_levels(ref, engine, s, run.trajectory, points, known=known, only=only))
    # the verdicts the case stands for are there on the ladder (the comparison covers them), judged one at a time
    verdicts = {v for tol in points for v in judge_run(ref, engine, s, tol, trajectory=run.trajectory)[1]["verdict"]}
    assert seen <= verdicts, verdicts


def test_bench_ladder_hashes_the_same_outputs_before_and_after():
    # the benchmark's own check (no timing asserted): both paths hashed, equal on a passing run
    from chatterbench.comparisons.studies.bench_tune import LADDER_CASES, bench_ladder

    figures, table = bench_ladder(cases=LADDER_CASES[:1], repeats=1)
    assert figures["same"] == 1.0 and figures["hash_before"] == figures["hash_after"]
    assert table["passes"].tolist() == [figures["points"]]  # PyBullet at threshold 0.1 passes every point
