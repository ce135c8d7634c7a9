"""Benchmarks say PASS or FAIL against their goals (the figures are measured, never asserted in tests)."""

from __future__ import annotations

import pandas as pd
import pytest

from chatterbench.comparisons.cli.bench import GOALS, REPEAT, goal_lines

from helpers import cli


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
    # bench platemap reports the best repeat's time for --strikes strikes: 100,000 in 30 s is 300 us a strike
    assert goal_lines("platemap", {"us_per_strike": 290.0, "seconds": 29.0})[1]
    assert not goal_lines("platemap", {"us_per_strike": 310.0, "seconds": 31.0})[1]
    assert set(REPEAT) == set(GOALS)


def test_bench_platemap_names_a_per_strike_time_per_strike():
    # issue 33: "PASS: seconds = 9.266e-05 (goal <= 0.0003: seconds per strike ...)" called a time per strike "seconds"
    done = cli(["bench", "platemap", "--strikes", "200", "--repeats", "1"])
    assert done.code in (0, 1), done.err
    goal = next(line for line in done.out.splitlines() if line.startswith(("PASS", "FAIL")))
    name, value = goal.split(": ", 1)[1].split(" (goal")[0].split(" = ")
    table = done.out.splitlines()
    header = next(i for i, line in enumerate(table) if "us_per_strike" in line)
    columns, cells = table[header].split(), table[header + 1].split()
    assert name == "us_per_strike" and "microseconds per strike" in goal
    assert float(value) == pytest.approx(float(cells[columns.index("us_per_strike")]), rel=1e-3)  # the table's figure
    assert float(cells[columns.index("seconds")]) == pytest.approx(float(value) * 200 * 1e-6, rel=1e-3)
