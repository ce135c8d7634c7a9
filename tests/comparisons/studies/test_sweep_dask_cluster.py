"""A sweep on a real Dask cluster, as a user runs one: `dask scheduler` and two `dask worker` processes on
127.0.0.1, `chatterbench sweep --dask tcp://...` in a process of its own, one worker killed mid-sweep.

docs/how-to/sweeps.md ("A Dask cluster of your own") shows the same commands. Every row must come back, identical
to a local sweep's: a worker's death loses its runs in flight, which the scheduler hands to the other worker.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from chatterbench.comparisons.studies.sweep import load_sweep, read_rows, run_sweep, sweep_runs
from helpers import wait_until

pytest.importorskip("distributed")

KEY = ["point_id", "engine"]
COMPARED = KEY + ["verdict", "status", "n_episodes", "exit_error_max", "stick_error_max", "first_impact_error_max",
                  "restitution_error_max"]
# 20 restitutions x 2 engines = 40 runs of ~0.1-0.3 s: the kill lands while runs are in flight
SPEC = """
scene = "bouncing-ball"
engines = ["mujoco", "pybullet"]
timeout = 120

[set]
duration = 0.8
dt = 5e-4

[grid]
restitution = [{values}]
"""


@pytest.mark.slow
def test_a_sweep_on_a_real_cluster_survives_a_killed_worker_with_every_row(tmp_path, cluster):
    address, workers = cluster
    values = ", ".join(repr(float(r)) for r in np.linspace(0.2, 0.8, 20))
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC.format(values=values))
    out = tmp_path / "on-cluster"
    sweep = subprocess.Popen([sys.executable, "-m", "chatterbench.comparisons.cli", "sweep", str(spec), "--out",
                              str(out), "--dask", address], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    total = len(sweep_runs(load_sweep(spec)))
    rows = out / "rows"
    wait_until(lambda: sweep.poll() is not None or (rows.is_dir() and any(rows.glob("part-*.parquet"))),
               "the sweep wrote no row")
    assert sweep.poll() is None, sweep.communicate()
    os.killpg(workers[0].pid, signal.SIGKILL)  # worker 1 and its nanny die with whatever runs they held
    done_at_kill = len(read_rows(out, dedupe=False))
    assert done_at_kill < total, "the kill must land mid-sweep for this test to mean anything"
    stdout, stderr = sweep.communicate(timeout=600)
    assert sweep.returncode == 0, stderr
    raw = read_rows(out, dedupe=False)
    assert len(raw) == total and not raw.duplicated(KEY).any(), (len(raw), total)
    log = (tmp_path / "scheduler.log").read_text(encoding="utf-8")
    assert "Remove worker" in log and "name: w1" in log, "the scheduler never saw worker 1 go"

    local = run_sweep(load_sweep(spec), tmp_path / "local", workers=2, progress=False)
    on_cluster = pd.read_parquet(out / "rows.parquet")
    # the same inputs on the same engines: every verdict and error agrees exactly
    pd.testing.assert_frame_equal(on_cluster[COMPARED].sort_values(KEY).reset_index(drop=True),
                                  local[COMPARED].sort_values(KEY).reset_index(drop=True))
