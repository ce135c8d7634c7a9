"""Same inputs, same machine, same versions: bit-identical trajectories and event logs."""

import numpy as np
import pytest

from chatterbench.comparisons.pipeline.extract import extract_events
from chatterbench.engines.registry import make_settings, run_engine
from chatterbench.reference import load_scene, simulate


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_engine_runs_are_bit_identical(engine):
    scene = load_scene("feigin-pair", ["duration=4"])
    settings = make_settings(engine, 1e-4)
    a, b = run_engine(engine, scene, settings), run_engine(engine, scene, settings)
    for name in ("t", "x1", "x2", "v1", "v2"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name  # exact: no tolerance
    for wall in scene.gap.walls:
        assert np.array_equal(a.normal_force[wall], b.normal_force[wall])
    assert extract_events(a, scene).equals(extract_events(b, scene))


@pytest.mark.parametrize("chatter", ["feigin", "exhaustive"])
def test_reference_logs_are_bit_identical(chatter):
    scene = load_scene("impact-damper")
    assert simulate(scene, chatter).log.equals(simulate(scene, chatter).log)
