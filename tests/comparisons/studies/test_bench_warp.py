"""``bench_warp``: MuJoCo Warp's world-steps per second beside MuJoCo C's, per number of worlds (no timing asserted)."""

import pytest

pytest.importorskip("mujoco_warp")

from chatterbench.comparisons.studies.bench import bench_warp  # noqa: E402


@pytest.mark.slow
def test_world_steps_per_second_for_each_number_of_worlds():
    figures = bench_warp(worlds=(1, 3), steps=20)
    assert figures["nworld"].tolist() == [1, 3] and set(figures["precision"]) == {"float32"}
    assert set(figures["device"]) <= {"cpu", "cuda"}
    for column in ("warp_world_steps_per_s", "warp_bare_world_steps_per_s", "mujoco_world_steps_per_s"):
        assert (figures[column] > 0).all()  # measured, whatever the machine: speeds are benchmarks, not tests
