"""Benchmarks say PASS or FAIL against their goals (the figures are measured, never asserted in tests)."""

from __future__ import annotations

import pandas as pd

from chatterbench.comparisons.cli.bench import GOALS, REPEAT, goal_lines


def test_goals_pass_and_fail_by_their_bounds():
    lines, ok = goal_lines("sweep", {"overhead_ratio": 1.03, "engine_ratio": 1.2, "speedup": 1.9})
    assert not ok
    assert lines[0].startswith("PASS: overhead_ratio = 1.03 (goal <= 1.15")
    assert lines[1].startswith("FAIL: engine_ratio = 1.2 (goal <= 1.15")
    assert lines[2].startswith("PASS: speedup = 1.9 (goal >= 1.7")
    table = pd.DataFrame({"engine": ["mujoco", "pybullet"], "ratio": [0.95, 0.85]})
    assert goal_lines("engines", table)[1]  # every engine must hold it
    assert not goal_lines("engines", table.assign(ratio=[0.95, 0.5]))[1]


def test_the_plate_map_goal_is_per_strike_of_one_repeat():
    # bench platemap reports the best repeat's time for --strikes strikes: 100,000 in 30 s
    assert goal_lines("platemap", {"seconds": 29.0}, strikes=100_000)[1]
    assert not goal_lines("platemap", {"seconds": 31.0}, strikes=100_000)[1]
    assert set(REPEAT) == set(GOALS)
