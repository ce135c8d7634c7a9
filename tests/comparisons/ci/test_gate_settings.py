"""A gate makes each check's settings object once, from its TOML values, and runs that object."""

from helpers import count_settings_made, measured

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.ci.checks import run_gate
from chatterbench.comparisons.ci.gate import parse_gate
from chatterbench.comparisons.pipeline.budget import Budget
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.summary import summarize
from chatterbench.reference import load_scene


def test_a_gate_makes_each_checks_settings_once_and_runs_them(monkeypatch):
    made = count_settings_made(monkeypatch)
    gate = parse_gate({"defaults": {"dt": 1e-3, "scene_overrides": {"duration": 1.6}}, "check": [
        {"scene": "bouncing-ball", "engine": "pybullet", "settings": {"restitution_velocity_threshold": 0.5},
         "limits": ["verdict == early"]},
        {"scene": "bouncing-ball", "engine": "mujoco", "settings": {"w0_dt": 0.1}, "limits": ["verdict == late"]}]})
    assert made == ["pybullet", "mujoco"]  # reading the file: one object per check
    result = run_gate(gate, budget=Budget())
    assert made == ["pybullet", "mujoco"]  # running it (the budget's estimate, each run) makes none again
    assert [r.passed for r in result.results] == [True, True]
    # what ran is what the TOML said: the same numbers as the text --set would give
    scene = load_scene("bouncing-ball", ["duration=1.6"])
    for r, text in zip(result.results, ("pybullet.restitution_velocity_threshold=0.5", "mujoco.w0_dt=0.1")):
        engine = r.check.engine
        assert measured(r.row) == measured(summarize(compare(scene, settings=settings_for((engine,), 1e-3, [text])),
                                                      engine, {})), engine
