"""``bench_warp``: MuJoCo Warp's world-steps per second beside MuJoCo C's, per number of worlds (no timing asserted)."""

import math

import pytest

pytest.importorskip("mujoco_warp", reason="the warp extra is not installed: pip install \".[warp]\"")

from chatterbench.comparisons.studies.bench import bench_warp  # noqa: E402


@pytest.mark.slow
def test_world_steps_per_second_for_each_number_of_worlds():
    figures = bench_warp(worlds=(1, 3), steps=20, threads=2)
    assert figures["nworld"].tolist() == [1, 3] and set(figures["precision"]) == {"float32"}
    assert set(figures["device"]) <= {"cpu", "cuda"}
    assert figures["statuses"].tolist() == ["ok 1", "ok 3"]  # every run of the batch recorded, none failed
    for column in ("warp_world_steps_per_s", "warp_bare_world_steps_per_s", "mujoco_c_steps_per_s",
                   "mujoco_c_threaded_steps_per_s", "adapter_s", "host_peak_gib"):
        assert (figures[column] > 0).all()  # measured, whatever the machine: speeds are benchmarks, not tests
    captured = figures["warp_bare_captured_world_steps_per_s"]
    assert ((captured > 0) | captured.isna()).all()  # NaN where warp cannot capture a graph on the device
    assert figures["adapter_over_bare"].tolist() == pytest.approx(
        (figures["warp_world_steps_per_s"] / figures["warp_bare_world_steps_per_s"]).tolist())
    assert set(figures["kernels"]) <= {"compiled", "cached"} and (figures["warmup_s"] >= 0).all()  # the warm-up, apart
    assert figures["blocks"].tolist() == [1, 1] and (figures["threads"] == 2).all()
    assert not math.isnan(figures["warp_over_mujoco_c"].iloc[-1])
