"""``examples/gpu/check.sh``: the GPU session's one script; its map is a valid sweep, and its lines are read as a user
reads them (PASS/FAIL with a number, a JSON record), checked here on warp's CPU device (``--dry-run``)."""

import importlib.util
import json
import os
import subprocess
from pathlib import Path

import pytest

from chatterbench.comparisons.studies.sweep import load_sweep, sweep_runs, work_units

ROOT = Path(__file__).resolve().parents[1]


def _check_module():
    spec = importlib.util.spec_from_file_location("gpu_check", ROOT / "examples" / "gpu" / "check.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_map_is_a_valid_64_by_64_sweep_in_64_gpu_units(tmp_path):
    pytest.importorskip("mujoco_warp", reason="the warp extra is not installed: pip install \".[warp]\"")
    path = tmp_path / "map.toml"
    path.write_text(_check_module().map_spec(64))
    sweep = load_sweep(path)  # every point's settings checked: w0 dt within Euler's limit for R = 0.5, the budget
    runs = sweep_runs(sweep)
    assert len(runs) == 64 * 64 and {r.engine for r in runs} == {"mujoco_warp"}
    dts = sorted({r.dt for r in runs})
    assert len(dts) == 64 and dts[0] == pytest.approx(2e-4) and dts[-1] == pytest.approx(2e-3)
    # on a GPU MuJoCo Warp takes a whole step count's worlds at once: one unit per dt
    units = work_units(runs, None, slots=16, unit_runs=lambda r: 4096)
    assert len(units) == 64 and {len(u) for u in units} == {64}


@pytest.mark.slow
def test_the_script_says_pass_or_fail_with_its_number_and_keeps_it(tmp_path):
    pytest.importorskip("mujoco_warp", reason="the warp extra is not installed: pip install \".[warp]\"")
    env = {**os.environ, "OUT": str(tmp_path)}
    proc = subprocess.run([str(ROOT / "examples" / "gpu" / "check.sh"), "env", "one_world", "--dry-run"], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:]
    lines = (tmp_path / "check.txt").read_text().splitlines()
    assert lines and all(line.split(":")[0] in ("PASS", "FAIL", "INFO") for line in lines)
    one = [line for line in lines if "one world through the adapter" in line]
    assert len(one) == 1 and one[0].startswith("PASS: ") and "steps/s (target >= 1000)" in one[0]
    assert one[0].endswith("(dry run, cpu)")
    records = json.loads((tmp_path / "check.json").read_text())
    judged = [r for r in records if r["kind"] in ("PASS", "FAIL")]
    assert judged and all(isinstance(r["value"], float) and r["target"] and r["dry_run"] for r in judged)
    bad = subprocess.run([str(ROOT / "examples" / "gpu" / "check.sh"), "nonsense"], env=env, capture_output=True,
                         text=True, timeout=120)
    assert bad.returncode == 2 and "unknown step 'nonsense'" in bad.stdout
