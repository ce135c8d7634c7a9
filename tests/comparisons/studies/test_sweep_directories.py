"""A sweep's output directory: one sweep at a time, resumed only from its own parts, any Unicode, bounded options.

Each defect of issue 14 is reproduced first (the test failed before the fix) and kept here.
Real engines on tiny scenes (the bouncing ball before or at its first impact, dt = 1e-3):
rows of one input are bit-identical, so resumed rows are compared exactly.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.studies.sweep import (DatasetError, OutDirError, SpecError, Sweep, load_sweep, read_rows, run_sweep,
                                                    sweep_runs)
from chatterbench.comparisons.studies.sweep.dataset import FINGERPRINT
from chatterbench.comparisons.studies.sweep.directory import OutLock
from helpers import wait_until

KEY = ["point_id", "engine"]
COMPARED = KEY + ["verdict", "status", "n_episodes", "exit_error_max", "first_impact_error_max"]

# 2 restitutions x 2 engines = 4 runs of ~0.05 s; the MuJoCo rows carry one more parameter
# column than the PyBullet rows, so a part's columns depend on its rows
SPEC = """
scene = "bouncing-ball"
engines = ["mujoco", "pybullet"]
timeout = {timeout}

[set]
duration = 0.5
dt = 1e-3

[grid]
restitution = [0.3, 0.5]
mujoco.w0_dt = [0.1]
{extra}"""


def _spec(folder: Path, name: str = "spec.toml", timeout: float = 60, extra: str = "") -> Path:
    path = folder / name
    path.write_text(SPEC.format(timeout=timeout, extra=extra), encoding="utf-8")
    return path


def _rows(frame: pd.DataFrame) -> pd.DataFrame:
    return frame[COMPARED].sort_values(KEY).reset_index(drop=True)


def _sweep(*args: str) -> list[str]:
    return [sys.executable, "-m", "chatterbench.comparisons.cli", "sweep", *args]


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> tuple[Path, Path]:
    """(spec, a finished sweep of it): copy the sweep before changing it."""
    folder = tmp_path_factory.mktemp("finished")
    spec = _spec(folder)
    run_sweep(load_sweep(spec), folder / "out", workers=1, progress=False)
    return spec, folder / "out"


def _tag(out: Path) -> str:
    """The temp-file tag the holder of OUT's lock recorded (directory.OutLock)."""
    return json.loads((out / ".lock").read_text(encoding="utf-8"))["temps"]


def _copy(finished: tuple[Path, Path], tmp_path: Path) -> tuple[Path, Path]:
    spec, out = finished
    shutil.copytree(out, tmp_path / "out")
    return spec, tmp_path / "out"


def _resume(spec: Path, out: Path, capsys) -> str:
    """``chatterbench sweep SPEC --out OUT --resume``, which must succeed; returns its stderr."""
    code = main(["sweep", str(spec), "--out", str(out), "--resume", "--workers", "1"])
    err = capsys.readouterr().err
    assert code == 0, err
    return err


def _assert_whole(spec: Path, out: Path, finished_out: Path) -> None:
    """OUT holds exactly the spec's rows, once each, equal to the uninterrupted sweep's."""
    raw = read_rows(out, dedupe=False)
    assert len(raw) == len(sweep_runs(load_sweep(spec))) and not raw.duplicated(KEY).any()
    assert not raw["restitution"].isna().any() and not raw["verdict"].isna().any()
    pd.testing.assert_frame_equal(_rows(pd.read_parquet(out / "rows.parquet")),
                                  _rows(pd.read_parquet(finished_out / "rows.parquet")))


# -- 1. one sweep at a time --------------------------------------------------------------------

@pytest.mark.slow
def test_a_second_sweep_on_the_same_directory_is_refused(tmp_path):
    # a run that hangs until its 4 s limit keeps the first sweep busy; once it holds the lock it is stopped
    # (SIGSTOP: alive, holding the lock, doing nothing) while the second starts, however slowly a loaded machine
    # starts it, and continued afterwards
    spec = _spec(tmp_path, timeout=4)
    env = {**os.environ, "CHATTERBENCH_FAULT": "hang:pybullet:restitution=0.3"}
    out = tmp_path / "out"
    first = subprocess.Popen(_sweep(str(spec), "--out", str(out), "--workers", "1"), env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_until(lambda: first.poll() is not None or ((out / ".lock").is_file()
                                                    and str(first.pid) in (out / ".lock").read_text()),
               "the first sweep never took the lock")
    os.kill(first.pid, signal.SIGSTOP)
    try:
        assert first.poll() is None, first.communicate()
        second = subprocess.run(_sweep(str(spec), "--out", str(out), "--workers", "1", "--resume"),
                                capture_output=True, text=True, timeout=300)
        assert first.poll() is None, "the first sweep must still run for the refusal to mean anything"
    finally:
        os.kill(first.pid, signal.SIGCONT)
    assert second.returncode == 2
    lines = second.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("chatterbench: error: --out "), second.stderr
    assert f"pid {first.pid} " in lines[0] and "started 20" in lines[0], lines[0]
    _, err = first.communicate(timeout=60)
    assert first.returncode == 0, err
    raw = read_rows(out, dedupe=False)
    assert len(raw) == len(sweep_runs(load_sweep(spec))) == 4 and not raw.duplicated(KEY).any()
    assert len(pd.read_parquet(out / "rows.parquet")) == 4


def test_a_killed_holder_leaves_no_stale_lock(tmp_path):
    spec = load_sweep(_spec(tmp_path))
    out = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time\n"
                               "from chatterbench.comparisons.studies.sweep.directory import OutLock\n"
                               "OutLock(sys.argv[1]).__enter__(); print('locked', flush=True); time.sleep(120)",
                               str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        torn = out / f".rows.parquet.{_tag(out)}k3j4h5g6.tmp"  # the holder's write, under way
        torn.write_bytes(b"PAR1")
        with pytest.raises(OutDirError, match=rf"--out {out}: another sweep is writing there \(pid {holder.pid} "):
            run_sweep(spec, out, workers=1, progress=False)
        assert torn.exists(), "a refused sweep touches nothing"
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    rows = run_sweep(spec, out, workers=1, progress=False)  # flock died with its process
    assert len(rows) == 4 and not torn.exists()


def test_forked_children_do_not_keep_the_lock(tmp_path):
    lock = OutLock(tmp_path).__enter__()
    ready, started = os.pipe()
    child = os.fork()
    if child == 0:  # a run's child that outlives its sweep by a moment
        os.write(started, b"x")  # os.fork has returned here: the fork hooks have run
        time.sleep(3)
        os._exit(0)
    try:
        assert os.read(ready, 1) == b"x"
        lock.__exit__(None, None, None)
        with OutLock(tmp_path):  # taken at once, while the child still runs
            assert os.waitpid(child, os.WNOHANG) == (0, 0)
    finally:
        os.kill(child, signal.SIGKILL)
        os.waitpid(child, 0)
        os.close(ready)
        os.close(started)


# -- 2. a resumed sweep reads only its own parts -----------------------------------------------

def _first_part(out: Path) -> Path:
    return sorted((out / "rows").glob("part-*.parquet"))[0]


def _damage(kind: str, part: Path) -> str:
    """Damage ``part`` as ``kind``; returns what the set-aside note must say."""
    if kind == "truncated":
        part.write_bytes(part.read_bytes()[:100])
        return "unreadable (Could not open Parquet input source"
    if kind == "empty":
        part.write_bytes(b"")
        return "empty file (0 bytes)"
    frame = pd.read_parquet(part)
    if kind == "missing parameter":  # the NaN rows of issue 14
        frame, says = frame.drop(columns="restitution"), "another schema: row 0 has restitution = nan"
    elif kind == "missing column":
        frame, says = frame.drop(columns="verdict"), "another schema: no column verdict"
    elif kind == "foreign column":
        frame, says = frame.assign(mass2=2.0), "another schema: columns 'mass2' are not this sweep's"
    elif kind == "foreign point":
        frame, says = frame.assign(point_id="0123456789abcdef"), "rows of points not in this sweep ("
    else:  # "another spec": a part of another sweep, with its fingerprint
        frame.attrs[FINGERPRINT], says = "0000000000000000", "written by another sweep spec (fingerprint 0000000000000000"
    frame.to_parquet(part, index=False)
    return says


@pytest.mark.parametrize("kind", ["truncated", "empty", "missing parameter", "missing column", "foreign column",
                                  "foreign point", "another spec"])
def test_resume_sets_aside_a_part_that_is_not_its_own(finished, tmp_path, capsys, kind):
    spec, out = _copy(finished, tmp_path)
    part = _first_part(out)
    says = _damage(kind, part)
    err = _resume(spec, out, capsys)  # before: ArrowInvalid with no hint, or the part's rows mixed in
    assert f"chatterbench: note: set aside 1 part file(s) of {out / 'rows'} in {out / 'rows' / 'set-aside'} " \
           f"({part.name}): {says}" in err, err
    assert not part.exists() and (out / "rows" / "set-aside" / part.name).exists()
    _assert_whole(spec, out, finished[1])


def test_an_unreadable_part_is_named_when_read(finished, tmp_path):
    _, out = _copy(finished, tmp_path)
    part = _first_part(out)
    part.write_bytes(b"PAR1 torn")
    # before: pyarrow's ArrowInvalid, naming no remedy
    with pytest.raises(DatasetError, match=rf"{part.name}: cannot read this part \(.*\); .*--resume` sets such parts aside"):
        read_rows(out)


@pytest.mark.parametrize("change", ['[tolerances]\nexit = 0.5\n', ""])
def test_resume_without_sweep_toml_sets_aside_another_specs_rows(finished, tmp_path, capsys, change):
    """sweep.toml deleted, then --resume with another spec: other tolerances (the same point ids!) or another grid."""
    _, out = _copy(finished, tmp_path)
    (out / "sweep.toml").unlink()
    if change:
        other = _spec(tmp_path, "other.toml", extra=change)
    else:
        other = tmp_path / "other.toml"
        other.write_text(SPEC.format(timeout=60, extra="").replace("[0.3, 0.5]", "[0.3, 0.6]"), encoding="utf-8")
    n_parts = len(list((out / "rows").glob("part-*.parquet")))
    err = _resume(other, out, capsys)
    assert f"set aside {n_parts} part file(s)" in err and "written by another sweep spec" in err, err
    assert load_sweep(out / "sweep.toml").identity() == load_sweep(other).identity()
    rows = read_rows(out, dedupe=False)
    assert len(rows) == 4 and not rows.duplicated(KEY).any()
    assert set(rows["point_id"]) == {r.point_id for r in sweep_runs(load_sweep(other))}
    assert pd.read_parquet(out / "rows.parquet").attrs[FINGERPRINT] == load_sweep(other).fingerprint()


def test_resume_keeps_its_own_parts_written_without_a_fingerprint(finished, tmp_path, capsys):
    """Parts of an earlier chatterbench have no fingerprint: kept when sweep.toml is this spec."""
    spec, out = _copy(finished, tmp_path)
    for part in (out / "rows").glob("part-*.parquet"):
        frame = pd.read_parquet(part)
        frame.attrs.clear()
        frame.to_parquet(part, index=False)
    err = _resume(spec, out, capsys)
    assert "set aside" not in err and not (out / "rows" / "set-aside").exists()
    _assert_whole(spec, out, finished[1])


# -- 3. any Unicode round-trips through sweep.toml ---------------------------------------------

BALL = """name = "ball-\N{TENNIS RACQUET AND BALL}"
mass1 = "inf"
mass2 = 1.0
restitution = 0.5
duration = 0.5
[gap]
lower = 0.0
[[forces]]
kind = "constant"
on = "body2"
value = -9.81
[initial]
y = 1.0
"""


def test_sweep_toml_round_trips_any_unicode(tmp_path):
    scene = tmp_path / "sc\N{LATIN SMALL LETTER E WITH GRAVE}nes \N{TENNIS RACQUET AND BALL}" / "ball.toml"
    scene.parent.mkdir()
    scene.write_text(BALL, encoding="utf-8")
    text = 'quote " backslash \\ newline \n tab \t del \x7f nul \x00 bell \x07 \N{GRINNING FACE} \u2028 \u00e9 \U0001F3BE'
    sweep = Sweep(scene=str(scene), engines=("pybullet",), fixed={"dt": 1e-3}, grid={"restitution": (0.3,)},
                  points=({"description": text}, {"description": "\N{GRINNING FACE}"}), description=text)
    path = tmp_path / "sweep.toml"
    path.write_text(sweep.to_toml(), encoding="utf-8")
    assert "\\ud83" not in path.read_text(encoding="utf-8")  # JSON's surrogate escapes are not TOML
    back = load_sweep(path)
    assert back.description == text and back.points[0]["description"] == text and back.scene == str(scene)
    assert back.identity() == sweep.identity() and back.fingerprint() == sweep.fingerprint()


def test_a_lone_surrogate_is_refused_by_name():
    with pytest.raises(SpecError, match=r"description = '\\udc80x': not valid Unicode"):
        Sweep(scene="bouncing-ball", grid={"dt": (1e-3,)}, description="\udc80x")


def test_a_sweep_with_emoji_resumes(tmp_path, capsys):
    spec = _spec(tmp_path, extra="").read_text(encoding="utf-8")
    spec = spec.replace('scene = "bouncing-ball"', 'scene = "bouncing-ball"\ndescription = "first impact \N{TENNIS RACQUET AND BALL}"')
    spec = spec.replace("dt = 1e-3", 'dt = 1e-3\ndescription = "ball \N{GRINNING FACE}"')
    path = tmp_path / "emoji.toml"
    path.write_text(spec, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "1"]) == 0, capsys.readouterr().err
    capsys.readouterr()
    # before: "the sweep written there cannot be read back (... not a Unicode scalar value ...)", exit 2
    _resume(path, out, capsys)
    assert load_sweep(out / "sweep.toml").description == "first impact \N{TENNIS RACQUET AND BALL}"
    assert load_sweep(out / "sweep.toml").fixed["description"] == "ball \N{GRINNING FACE}"


# -- 4. temp files of torn writes ---------------------------------------------------------------

def test_stale_temp_files_of_a_killed_write_are_removed(finished, tmp_path, capsys):
    spec, out = _copy(finished, tmp_path)
    tag = _tag(out)  # a killed sweep's temps bear the tag its .lock records (atomic.temp_tag)
    stale = [out / f".rows.parquet.{tag}a1b2c3d4.tmp", out / f".sweep.toml.{tag}x_9y8z7w.tmp",
             out / "rows" / f".{_first_part(out).name}.{tag}qwertyui.tmp"]
    kept = [out / ".notes.tmp", out / "mine.tmp", out / "rows" / ".keep.me.tmp",  # not atomic.py's pattern
            out / ".rows.parquet.a1b2c3d4.tmp", out / "rows" / ".precious.abcdefghabcdefgh.tmp"]  # no sweep's tag
    for p in stale + kept:
        p.write_bytes(b"PAR1 torn")
    _resume(spec, out, capsys)
    assert not any(p.exists() for p in stale) and all(p.exists() for p in kept)


# -- 5. bounded options ------------------------------------------------------------------------

def test_timeout_and_workers_are_bounded_and_dask_needs_an_address(tmp_path, capsys):
    out = tmp_path / "out"
    big = _spec(tmp_path, "big.toml", timeout=1e10)
    assert main(["sweep", str(big), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    # before: OverflowError: timestamp too large to convert to C _PyTime_t, from the first run
    assert "timeout = 10000000000.0: must be in (0, 86400] seconds (one day at most)" in err, err
    spec = _spec(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main(["sweep", str(spec), "--out", str(out), "--timeout", "1e300"])
    assert exit_.value.code == 2
    assert "argument --timeout: '1e300': must be at most 86400 s" in capsys.readouterr().err
    # before: --dask "" ran locally without a word
    assert main(["sweep", str(spec), "--out", str(out), "--dask", ""]) == 2
    assert "chatterbench: error: --dask '': no scheduler address" in capsys.readouterr().err
    cores = len(os.sched_getaffinity(0))
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "4096"]) == 2
    err = capsys.readouterr().err
    assert "chatterbench: error: --workers 4096: must be in [1, " in err and f"({cores} cores, " in err, err
    assert not out.exists(), "nothing is written for a refused option"


# -- 6. a Dask cluster with no worker ----------------------------------------------------------

@pytest.fixture
def empty_cluster():
    """A Dask cluster whose only worker is closed: (cluster, client)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        cluster.scale(0)
        wait_until(lambda: not client.nthreads(), "the worker did not close")
        yield cluster, client


def test_dask_without_workers_stops_when_asked(empty_cluster, tmp_path, capsys):
    cluster, _ = empty_cluster
    spec, out = _spec(tmp_path), tmp_path / "out"
    # before: waited forever, without a word
    code = main(["sweep", str(spec), "--out", str(out), "--dask", cluster.scheduler_address, "--dask-wait", "0.5",
                 "--dask-no-workers", "stop"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "no worker for 0.5 s (--dask-wait); stopped (--dask-no-workers stop) with 0 of 4 runs finished" in err, err
    assert (out / "sweep.toml").exists()  # the sweep can be resumed, and its lock was released:
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--resume"]) == 0


def test_dask_without_workers_says_so_and_waits_for_one(empty_cluster, tmp_path, capsys):
    cluster, client = empty_cluster
    spec = load_sweep(_spec(tmp_path))
    threading.Timer(1.5, cluster.scale, [1]).start()  # a worker comes back after the note
    rows = run_sweep(spec, tmp_path / "out", executor=client, progress=False, no_worker_wait=0.5)
    err = capsys.readouterr().err
    assert "no worker for 0.5 s (--dask-wait); waiting for one (--dask-no-workers wait)" in err, err
    assert "worker(s) back; the sweep goes on" in err
    assert len(rows) == 4 and (rows["status"] == "ok").all()
