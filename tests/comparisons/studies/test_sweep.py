"""Sweeps: interrupted and resumed, on Dask, with crashing and hanging points, and bad specs.

Real engines on tiny scenes (the bouncing ball's first impact, dt = 1e-3): rows are
compared exactly, because the same inputs give bit-identical engine runs and verdicts.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.studies.sweep import Sweep, load_sweep, read_rows, run_sweep, sweep_runs

KEY = ["point_id", "engine"]
COMPARED = KEY + ["verdict", "status", "n_episodes", "exit_error_max", "stick_error_max", "first_impact_error_max"]


def _spec(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _rows(frame: pd.DataFrame) -> pd.DataFrame:
    return frame[COMPARED].sort_values(KEY).reset_index(drop=True)


# 8 restitutions x 2 engines = 16 runs of ~0.1 s: long enough to be killed halfway (the first part holds one run:
# measured 1 or 2 of the 16 done at the kill; before: 16 restitutions, 32 runs)
RESUME_SPEC = """
scene = "bouncing-ball"
engines = ["mujoco", "pybullet"]
timeout = 60

[set]
duration = 0.6
dt = 1e-3

[grid]
restitution = [{values}]
"""


@pytest.mark.slow
def test_killed_sweep_resumes_to_the_rows_of_an_uninterrupted_one(tmp_path, sweep_process):
    start, kill_when = sweep_process
    values = ", ".join(repr(float(r)) for r in np.linspace(0.2, 0.8, 8))
    spec = _spec(tmp_path, RESUME_SPEC.format(values=values))
    out = tmp_path / "killed"
    proc = start(str(spec), "--out", str(out), "--workers", "2")
    kill_when(proc, lambda: (out / "rows").exists() and bool(list((out / "rows").glob("part-*.parquet"))), "no rows")
    partial = read_rows(out, dedupe=False)
    total = len(sweep_runs(load_sweep(spec)))
    assert 0 < len(partial) < total, "the kill must land halfway for this test to mean anything"

    resumed = start(str(spec), "--out", str(out), "--workers", "2", "--resume")
    stdout, stderr = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, stderr
    raw = read_rows(out, dedupe=False)
    assert not raw.duplicated(KEY).any(), "resume re-ran a finished point"
    assert len(raw) == total

    whole = run_sweep(load_sweep(spec), tmp_path / "whole", workers=2, progress=False)
    # same inputs, same engines: the rows agree exactly, errors included
    pd.testing.assert_frame_equal(_rows(pd.read_parquet(out / "rows.parquet")), _rows(whole))


SMALL = Sweep(scene="bouncing-ball", engines=("mujoco", "pybullet"), fixed={"duration": 0.6},
              grid={"dt": (1e-3, 5e-4), "restitution": (0.3, 0.7)}, timeout=60)


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    """``SMALL`` swept by the local pool, every run alone (the rows that Dask and batches must give)."""
    return run_sweep(SMALL, tmp_path_factory.mktemp("single"), workers=2, progress=False, batch=1)


def test_dask_cluster_gives_the_rows_of_the_local_pool(tmp_path, single):
    distributed = pytest.importorskip("distributed")
    local = single
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = run_sweep(SMALL, tmp_path / "dask", executor=client, progress=False)
    assert len(local) == 8
    pd.testing.assert_frame_equal(_rows(remote), _rows(local))


def test_units_and_mujoco_batches_give_the_rows_of_single_runs(tmp_path, single):
    """Units of two runs (MuJoCo: one rollout call per unit) and single runs: the same rows."""
    batched = run_sweep(SMALL, tmp_path / "batched", workers=2, progress=False, batch=2)
    # 4 MuJoCo runs in 2 batches (one per dt: a batch shares the step count) + 4 PyBullet runs in 2 units
    assert single.attrs["sweep"]["units"] == 8 and batched.attrs["sweep"]["units"] == 4
    pd.testing.assert_frame_equal(_rows(batched), _rows(single))


# the test-only fault hook (engines/faults.py): MuJoCo runs at these restitutions segfault,
# hang or raise; the pool's processes inherit the variable
FAULTS = "segfault:mujoco:restitution=0.31;hang:mujoco:restitution=0.32;raise:mujoco:restitution=0.33"
FAULT_OF = {0.3: "", 0.31: "segfault", 0.32: "hang", 0.33: "raise"}


HANG_LIMIT = 1.0  # [s] the limit of the runs built to hang (0.32) alone: they are `timeout` whatever the load


def _hanging_runs_limited(monkeypatch) -> None:
    """The sweep's runs as ``sweep_runs`` makes them, but the MuJoCo runs built to hang get ``HANG_LIMIT``.

    A spec's ``timeout`` is one limit for every run, and a run that hangs waits all of it (a batch of four
    the sum of its runs' limits), so each hanging run would cost 10 s here. Any limit classifies a run that
    never returns as ``timeout``; every other run keeps the spec's 10 s, which a loaded machine cannot reach.
    """
    from chatterbench.comparisons.studies.sweep import runner

    real = runner.sweep_runs

    def runs(*args, **kwargs):
        return [dataclasses.replace(r, timeout=HANG_LIMIT)
                if r.engine == "mujoco" and FAULT_OF.get(dict(r.params)["restitution"]) == "hang" else r
                for r in real(*args, **kwargs)]

    monkeypatch.setattr(runner, "sweep_runs", runs)


@pytest.mark.slow
@pytest.mark.parametrize("batch", [1, 3])
def test_crashing_and_hanging_points_are_classified_and_the_rest_kept(tmp_path, batch, monkeypatch):
    monkeypatch.setenv("CHATTERBENCH_FAULT", FAULTS)
    _hanging_runs_limited(monkeypatch)
    spec = _spec(tmp_path, """
scene = "bouncing-ball"
engines = ["mujoco", "pybullet"]
timeout = 10

[set]
duration = 0.6
dt = 1e-3

[grid]
restitution = [0.3, 0.31, 0.33, 0.32]
mass2 = [1.0, 2.0]
""")
    # batch = 3: three MuJoCo batches, each with a fault, each rerun one run at a time: (0.3, 0.3, 0.31) crashes
    # with two good runs in it, (0.31, 0.33, 0.33) crashes and raises, (0.32, 0.32) hangs. The hanging runs' own
    # 1 s limit ends them (their batch: at the sum of its runs' limits, 1 + 1 s; the hanging runs listed last, so
    # that no run with the spec's limit shares their batch: with 10 s runs beside them it waited 1 + 1 + 10 + 10 s);
    # every other run has 10 s: a run of 600 steps takes well under a second, so a loaded machine cannot make it a
    # timeout
    rows = run_sweep(load_sweep(spec), tmp_path / "out", workers=2, progress=False, batch=batch)
    # 4 restitutions x 2 masses for each engine; the faults hit MuJoCo only
    assert len(rows) == 16 and not rows.duplicated(KEY).any()
    assert rows.attrs["sweep"]["units"] == {1: 16, 3: 3 + 3}[batch]  # the batches above, and PyBullet's 3 + 3 + 2
    mj = rows[rows["engine"] == "mujoco"].set_index(["restitution", "mass2"])
    for m in (1.0, 2.0):
        assert mj.loc[(0.3, m), "status"] == "ok"
        assert mj.loc[(0.31, m), ["status", "verdict"]].tolist() == ["crashed", "crashed"]
        assert "SIGSEGV" in mj.loc[(0.31, m), "message"]
        assert mj.loc[(0.32, m), ["status", "verdict"]].tolist() == ["timeout", "timeout"]
        assert mj.loc[(0.33, m), "status"] == "error"
        assert "InjectedFault" in mj.loc[(0.33, m), "message"]
    assert (rows.loc[rows["engine"] == "pybullet", "status"] == "ok").all()
    assert (rows["dt"] == 1e-3).all()
    # a failed run's row still says where it sits on a map: mu = m2 / m1 = 0 for the ball on a fixed floor
    assert (rows["mass_ratio"] == 0.0).all()
    # the reference ran (and was timed) wherever the run got as far as a result, an engine exception included
    lost = rows["status"].isin(["crashed", "timeout"])
    assert (rows.loc[~lost, "reference_cost_per_sim_s"] > 0).all() and rows.loc[lost, "reference_cost_per_sim_s"].isna().all()


def test_resolved_spec_reads_back_and_guards_the_output(tmp_path, capsys):
    out = tmp_path / "out"
    one = Sweep(scene="bouncing-ball", engines=("mujoco",), fixed={"duration": 0.3, "dt": 1e-3},
                grid={"restitution": (0, 0.5)})  # an int and a float: one float column
    rows = run_sweep(one, out, workers=1, progress=False)
    assert rows["restitution"].tolist() == [0.0, 0.5]
    assert load_sweep(out / "sweep.toml").identity() == one.identity()
    again = run_sweep(one, out, resume=True, workers=1, progress=False)
    assert again.attrs["sweep"]["runs"] == 0 and len(again) == 2

    other = _spec(tmp_path, 'scene = "bouncing-ball"\nengines = ["mujoco"]\n[grid]\nrestitution = [0.1]\n')
    assert main(["sweep", str(other), "--out", str(out), "--resume"]) == 2
    assert "different sweep" in capsys.readouterr().err
    assert main(["sweep", str(other), "--out", str(out)]) == 2
    assert "--resume" in capsys.readouterr().err


@pytest.mark.parametrize("text, says", [
    ('scene = "bouncing-ball"\nengins = ["mujoco"]\n[grid]\ndt = [1e-3]\n', ["engins: unknown key", "did you mean 'engines'"]),
    ('scene = "bouncing-ball"\n[grid]\ndt = []\n', ["grid.dt = []", "empty grid"]),
    ('scene = "bouncing-ball"\n[grid]\nrestitution = [0.5, 1.5]\n', ["grid.restitution = 1.5", "must be in [0, 1)"]),
    ('scene = "bouncing-ball"\n[grid]\nrestitution = 0.5\n', ["grid.restitution = 0.5", "must be an array"]),
    ('scene = "bouncing-ball"\n[grid]\nrestitution = [0.5, "high"]\n', ["grid.restitution", "mixes"]),
    ('scene = "bouncing-ball"\n[grid]\nmujoco.w0dt = [0.03]\n', ["mujoco.w0dt", "did you mean 'w0_dt'"]),
    ('scene = "bouncing-ball"\n[grid]\ndt = [-1e-3]\n', ["grid.dt = -0.001", "must be > 0"]),
    ('scene = "bouncing-ball"\nengines = ["mujoco"]\n[grid]\npybullet.erp = [0.1]\n', ["pybullet is not in engines"]),
    ('scene = "bouncing-ball"\n[set]\ndt = 1e-3\n[grid]\ndt = [1e-3]\n', ["grid.dt: also in [set]"]),
    ('scene = "bouncing-ball"\ntimeout = 0\n[grid]\ndt = [1e-3]\n', ["timeout = 0", "> 0"]),
    ('scene = "bouncing-bal"\n[grid]\ndt = [1e-3]\n', ["bouncing-bal", "did you mean 'bouncing-ball'"]),
    ('scene = "bouncing-ball"\n', ["no points"]),
    ('scene = "bouncing-ball"\n[grid\ndt = [1e-3]\n', ["not valid TOML"]),
])
def test_bad_spec_is_one_clear_message_and_exit_code_2(tmp_path, capsys, text, says):
    spec = _spec(tmp_path, text)
    assert main(["sweep", str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and str(spec) in err, err
    for s in says:
        assert s in err, err
    assert not (tmp_path / "out").exists(), "nothing is written for a bad spec"


def test_work_units_cover_every_run_once_and_shrink_towards_the_end():
    from chatterbench.comparisons.studies.sweep.worker import MAX_BATCH, work_units

    sweep = Sweep(scene="bouncing-ball", engines=("mujoco", "pybullet"), fixed={"duration": 0.6},
                  grid={"dt": (1e-3, 5e-4), "restitution": tuple(0.01 * i for i in range(1, 51))})
    runs = sweep_runs(sweep)
    units = work_units(runs, None, slots=2)
    assert sorted(r.index for u in units for r in u) == list(range(len(runs)))
    for u in units:
        assert len({r.engine for r in u}) == 1
        if u[0].engine == "mujoco":  # a MuJoCo batch shares its step count
            assert len({r.dt for r in u}) == 1
    for key in [("mujoco", 1e-3), ("mujoco", 5e-4), ("pybullet", None)]:
        sizes = [len(u) for u in units if u[0].engine == key[0] and key[1] in (None, u[0].dt)]
        assert sizes == sorted(sizes, reverse=True) and sizes[-1] == 1 and max(sizes) <= MAX_BATCH
    # 100 PyBullet runs on 2 slots start at the cap; 50 MuJoCo runs per dt at 50 // 8 = 6
    assert max(len(u) for u in units if u[0].engine == "pybullet") == MAX_BATCH
    assert [u[0].index for u in units] == sorted(u[0].index for u in units)
    assert all(len(u) == 1 for u in work_units(runs, 1, slots=2))
    # an engine that names its own unit (MuJoCo Warp on a GPU: 4096 worlds) gets whole units of it, no shrinking;
    # the others keep the sweep's choice; --batch still wins
    own = work_units(runs, None, slots=2, unit_runs=lambda r: 32 if r.engine == "mujoco" else None)
    assert [len(u) for u in own if u[0].engine == "mujoco"] == [32, 18, 32, 18]
    assert [len(u) for u in own if u[0].engine == "pybullet"] == [len(u) for u in units if u[0].engine == "pybullet"]
    assert all(len(u) == 1 for u in work_units(runs, 1, slots=2, unit_runs=lambda r: 32))
    assert work_units(runs, None, slots=2, unit_runs=lambda r: None) == units  # as the engines name none here


def test_an_engine_that_cannot_be_forked_runs_in_the_worker_with_the_same_rows(monkeypatch):
    # MuJoCo Warp on cuda (a CUDA context does not survive a fork) runs its units in the sweep's worker; here MuJoCo
    # is told so (the adapter's fact), and its rows are those of forked runs; a failure is still a failure row
    from chatterbench.comparisons.studies.sweep import worker
    from chatterbench.engines.registry import adapter

    sweep = Sweep(scene="bouncing-ball", engines=("mujoco",), fixed={"duration": 0.6, "dt": 1e-3},
                  grid={"restitution": (0.3, 0.5, 0.7)})
    runs = sweep_runs(sweep)
    forked = [r.row for r in worker.run_batch_task(runs)] + [worker.run_task(runs[0]).row]
    monkeypatch.setattr(type(adapter("mujoco")), "forks", lambda self, settings: False)
    monkeypatch.setattr(worker, "run_isolated", None)  # not called: a fork here would fail the test
    here = [r.row for r in worker.run_batch_task(runs)] + [worker.run_task(runs[0]).row]
    pd.testing.assert_frame_equal(pd.DataFrame(here)[COMPARED], pd.DataFrame(forked)[COMPARED])
    failed = worker._here(lambda: 1 / 0)
    assert failed.status == "error" and failed.message.startswith("ZeroDivisionError: division by zero")
