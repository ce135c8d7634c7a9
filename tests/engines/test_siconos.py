"""The Siconos adapter with the real Siconos (in its child process): Newton's law, theta, Feigin's pair, failures."""

from __future__ import annotations

import json
import math
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from chatterbench.engines.registry import settings_for
from chatterbench.engines import registry
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import load_scene, scene_from_dict

from chatterbench.engines.siconos_engine import SiconosEngine, SiconosSettings, protocol
from chatterbench.engines.siconos_engine.run import CHILD, ENV, Interpreter, interpreter

FOUND = interpreter()
pytestmark = pytest.mark.skipif(not isinstance(FOUND, Interpreter), reason=str(FOUND))


def _impact_scene(mass1, y0=0.00205, duration=0.01):
    """One force-free impact at 1 m/s on the lower wall at t = y0 [s], then free flight."""
    return scene_from_dict({"name": "single-impact", "mass1": mass1, "mass2": 1.0, "restitution": 0.5,
                            "gap": {"lower": 0.0}, "initial": {"y": y0, "vy": -1.0}, "duration": duration})


@pytest.mark.parametrize("mass1", ["inf", 1.0])
def test_a_single_impact_gives_R_and_theta_moves_its_time(mass1):
    scene = _impact_scene(mass1)
    runs = {theta: SiconosEngine().run(scene, SiconosSettings(dt=1e-4, theta=theta)) for theta in (0.5, 1.0)}
    for theta, traj in runs.items():
        assert traj.status == "ok", traj.message
        # the LCP imposes Newton's law on the velocity, g'+ = -R g'-, for any theta: measured 0.5 to 1e-15
        assert -traj.vy[-1] / traj.vy[0] == pytest.approx(0.5, rel=0.01)
        if mass1 != "inf":  # the impulse is internal: m1 v1 + m2 v2 kept to rounding
            assert np.abs(traj.v1 + traj.v2 - (traj.v1 + traj.v2)[0]).max() < 1e-12
    # theta weighs the position update of the impact step: the rebound line y = R |v| (t - t_c) meets the wall at
    # t_c = 2.05 ms (exact) with theta = 0.5 (measured 2.0500 ms) and 1.5 steps early with theta = 1 (1.9000 ms)
    t_c = {theta: traj.t[-1] - traj.y[-1] / traj.vy[-1] for theta, traj in runs.items()}
    assert abs(t_c[0.5] - 0.00205) < 0.5e-4
    assert abs(t_c[1.0] - 0.00205) > 1e-4


def test_bouncing_ball_theta_one_lifts_off_late():
    # the engines page's departure (docs/explanation/engines.md) at dt 1e-4: last lift-off 1.3534 s (theta 0.5)
    # against 1.3561 s (theta 1), Zeno 1.3546 s: theta 0.5 lands each impact step half a step of motion sooner and
    # comes to rest 12 steps early, theta 1 moves each impact step with the rebound speed and keeps bouncing 15 steps past Zeno
    scene = load_scene("bouncing-ball", ["duration=1.5"])
    last = {}
    for theta in (0.5, 1.0):
        traj = SiconosEngine().run(scene, SiconosSettings(dt=1e-4, theta=theta))
        lifts = np.nonzero(traj.contact["lower"][:-1] & ~traj.contact["lower"][1:])[0]
        last[theta] = traj.t[lifts[-1] + 1]
    zeno = math.sqrt(2 / 9.81) * 3.0
    assert abs(last[0.5] - zeno) < 2e-3 and last[0.5] < zeno < last[1.0] and last[1.0] - last[0.5] > 2e-3, last


@pytest.mark.slow  # 2.8 s on a quiet machine, 7.6 s on a loaded one (the reference and 402k Siconos steps)
def test_feigin_pair_matches_the_reference():
    from chatterbench.comparisons.pipeline.compare import compare

    result = compare(load_scene("feigin-pair"), settings=settings_for(["siconos"], 1e-4))
    assert result.summary()["verdict"].tolist() == ["match"]


def test_a_prescribed_floor_is_exact_and_told_from_a_fixed_one():
    from chatterbench.comparisons.pipeline.compare import compare

    data = {**CATALOGUE["bouncing-ball"], "name": "shaken-ball", "duration": 1.5,
            "prescribed": {"amplitude": 0.01, "omega": 20.0, "phase": math.pi / 2},
            "initial": {"t": 0.0, "x1": 0.01, "v1": 0.0, "y": 0.2, "vy": 0.0}}
    shaken = scene_from_dict(data)
    s = SiconosSettings(dt=1e-4)
    assert compare(shaken, settings=settings_for(["siconos"], 1e-4)).summary()["verdict"].tolist() == ["match"]
    # the known answer the other way: the ball on a fixed floor, judged as the shaken scene, does not match
    fixed = scene_from_dict({**data, "prescribed": None, "initial": {**data["initial"], "x1": 0.0}})
    traj = SiconosEngine().run(fixed, s)
    wrong = compare(shaken, settings=settings_for(["siconos"], 1e-4), trajectories={"siconos": traj})
    assert wrong.summary()["verdict"].tolist() != ["match"]


def test_the_forces_sent_are_the_scenes():
    for name in CATALOGUE:
        scene = load_scene(name)
        req = protocol.request(scene, dt=1e-3, steps=1, theta=0.5, solver="lemke", tolerance=1e-12)
        assert len(req["mass"]) == (1 if scene.body1_infinite else 2)
    # impact-damper: body 1's spring, damper and P sin(10 t); K = [[100, 0], [0, 0]], C = [[0.4, 0], [0, 0]]
    req = protocol.request(load_scene("impact-damper"), dt=1e-3, steps=1, theta=0.5, solver="lemke", tolerance=1e-12)
    assert req["stiffness"] == [[100.0, 0.0], [0.0, 0.0]] and req["damping"] == [[0.4, 0.0], [0.0, 0.0]]
    assert req["force"][0] == {"constant": 0.0, "harmonics": [[5.0, 10.0, 0.0]]}


def _child(stdin: str) -> subprocess.CompletedProcess:
    return subprocess.run([FOUND.path, str(CHILD)], input=stdin.encode(), capture_output=True, timeout=60)


def test_the_child_refuses_garbage_with_one_line_naming_the_field():
    out = _child("garbage")
    assert out.returncode == 2 and out.stdout == b""
    assert out.stderr.decode().startswith("siconos child: bad request: not a JSON request")
    req = protocol.request(load_scene("bouncing-ball"), dt=1e-3, steps=5, theta=0.5, solver="lemke", tolerance=1e-12)
    out = _child(json.dumps({**req, "dt": -1.0}))
    want = "siconos child: bad request: dt = -1.0: must be a finite number in [0, inf]"
    assert out.returncode == 2 and out.stderr.decode().strip() == want
    out = _child(json.dumps({**req, "solver": "simplex"}))
    assert out.returncode == 2 and "solver = 'simplex': must be one of lemke" in out.stderr.decode()
    out = _child(json.dumps(req))  # and the good request is answered: 5 rows, then the end frame
    assert out.returncode == 0 and len(out.stdout) == 8 + 5 * 3 * 8 + 16


def _fake_python(tmp_path, body: str) -> str:
    """An interpreter that passes the probe (the real one) but runs ``body`` instead of the child."""
    path = tmp_path / "python3"
    path.write_text(f"#!/bin/sh\nif [ \"$1\" = -c ]; then exec {FOUND.path} \"$@\"; fi\n{body}\n")
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return str(path)


@pytest.mark.parametrize("body, status, words", [
    # before: a child killed by a signal was "error"; the process running the engine died: "crashed"
    ("kill -SEGV $$", "crashed", "SiconosCrash: the Siconos child killed by SIGSEGV"),
    ("echo 'Fatal error' >&2; exit 1", "error", "SiconosFailure: the Siconos child exited with code 1"),
    ("printf 'garbage, not frames'", "error", "SiconosFailure: the Siconos child exited with code 0; a frame of"),
])
def test_a_failed_child_is_a_result_with_one_line(tmp_path, monkeypatch, body, status, words):
    monkeypatch.setenv(ENV, _fake_python(tmp_path, body))
    traj = SiconosEngine().run(load_scene("bouncing-ball", ["duration=0.1"]), SiconosSettings(dt=1e-3))
    assert traj.status == status and traj.message.startswith(f"siconos: {words}"), traj.message
    assert "\n" not in traj.message and len(traj.t) == 1


def test_a_child_runs_one_blas_thread_unless_the_environment_says(tmp_path, monkeypatch):
    # numpy's OpenBLAS started a thread per core in every child: more than half a child's start (0.22 -> 0.13 s of
    # CPU on 2 cores, run.start_seconds); a user's own OPENBLAS_NUM_THREADS is kept
    seen = tmp_path / "threads"
    monkeypatch.setenv(ENV, _fake_python(tmp_path, f'echo "$OPENBLAS_NUM_THREADS" >> {seen}; exec {FOUND.path} "$@"'))
    scene = load_scene("bouncing-ball", ["duration=0.1"])
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    assert SiconosEngine().run(scene, SiconosSettings(dt=1e-3)).status == "ok"
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "3")
    assert SiconosEngine().run(scene, SiconosSettings(dt=1e-3)).status == "ok"
    assert seen.read_text().split() == ["1", "3"]


def test_a_missing_interpreter_is_refused_with_the_install_line(monkeypatch):
    monkeypatch.setenv(ENV, "/nowhere/python3")
    reason = registry.unavailable_reason("siconos")
    assert "apt-get install python3-siconos" in reason and ENV in reason and "/nowhere/python3" in reason
    with pytest.raises(registry.EngineUnavailable, match="python3-siconos"):
        registry.load("siconos")
    assert "siconos" not in registry.available_engines()
    traj = SiconosEngine().run(load_scene("bouncing-ball", ["duration=0.1"]), SiconosSettings(dt=1e-3))
    assert traj.status == "error" and "apt-get install python3-siconos" in traj.message
    monkeypatch.delenv(ENV)
    assert registry.unavailable_reason("siconos") == ""  # and found again without it


@pytest.mark.parametrize("field, value, words", [
    ("theta", 1.5, "siconos.theta = 1.5: must be in [0, 1]"),
    ("solver", "simplex", "siconos.solver = 'simplex': must be one of lemke, enum, pgs, nsgs"),
    ("tolerance", 0.0, "siconos.tolerance = 0.0: must be in (0, 1)"),
])
def test_settings_refusals_name_the_field_and_range(field, value, words):
    with pytest.raises(SettingsError) as info:
        SiconosSettings(**{field: value})
    assert str(info.value).startswith(words), str(info.value)


@pytest.mark.parametrize("solver", ["enum", "pgs", "nsgs"])
def test_every_lcp_solver_gives_the_same_bounce(solver):
    scene = load_scene("bouncing-ball", ["duration=1.0"])
    base = SiconosEngine().run(scene, SiconosSettings(dt=1e-3))
    other = SiconosEngine().run(scene, SiconosSettings(dt=1e-3, solver=solver))
    assert other.status == "ok", other.message
    # one contact at a time: every solver finds the LCP's unique solution (to the tolerance 1e-12)
    np.testing.assert_allclose(other.y, base.y, atol=1e-9)


def test_a_killed_run_leaves_no_child_stepping_on(tmp_path):
    # the child asks Linux to kill it with its parent (PR_SET_PDEATHSIG): a killed sweep point, benchmark or ^C
    # leaves no Siconos process behind. A run that sends samples would also end on its next frame's broken pipe;
    # the benchmark's bare loop sends nothing until its end (here 4e6 steps, about a minute), so only the signal
    # ends it (measured: without the prctl this test fails, the child steps on)
    code = ("from chatterbench.engines.siconos_engine.protocol import request\n"
            "from chatterbench.engines.siconos_engine.run import Child\n"
            "from chatterbench.reference.scene import load_scene\n"
            "req = request(load_scene('feigin-pair'), dt=1e-5, steps=4_000_000, theta=0.5, solver='lemke', "
            "tolerance=1e-12, bare=True)\n"
            f"Child({FOUND.path!r}, req).proc.wait()\n")
    parent = subprocess.Popen([sys.executable, "-c", code])
    try:
        children = []
        for _ in range(300):  # the child starts within a few seconds
            children = [p for p in Path("/proc").glob("[0-9]*") if _parent_of(p) == parent.pid and str(CHILD) in _cmdline(p)]
            if children:
                break
            time.sleep(0.05)
        assert children, "no Siconos child started"
        parent.kill()
        parent.wait()
        deadline = time.monotonic() + 10
        while children[0].exists() and _state(children[0]) not in ("Z", "X") and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not children[0].exists() or _state(children[0]) in ("Z", "X")
    finally:
        parent.kill()


def _cmdline(proc: Path) -> str:
    try:
        return (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def _stat(proc: Path) -> list[str]:
    try:
        return (proc / "stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return ["X", "0"]


def _state(proc: Path) -> str:
    return _stat(proc)[0]


def _parent_of(proc: Path) -> int:
    return int(_stat(proc)[1])


def _counting_python(tmp_path) -> tuple[str, Path]:
    """The real interpreter behind a script that writes a line to ``starts`` each time a child starts."""
    starts = tmp_path / "starts"
    return _fake_python(tmp_path, f'echo started >> {starts}; exec {FOUND.path} "$@"'), starts


def _strike_scenes() -> list:
    """Five short runs as a strike batch has them: the bouncing ball restarted from five heights."""
    return [load_scene("bouncing-ball", [f"initial.y={y}", "duration=0.3"]) for y in (0.05, 0.1, 0.2, 0.3, 0.4)]


def test_one_child_answers_a_batch_of_runs_each_as_a_child_of_its_own_would(tmp_path, monkeypatch):
    # a strike batch is 20 to 120 short runs: a child each paid 0.11 s of start per run, most of a Siconos tune's
    # time (bouncing-ball at dt = 1 ms: run 0.5 s, its strikes 12 s, measured on this code's parent); one kept child
    python, starts = _counting_python(tmp_path)
    monkeypatch.setenv(ENV, python)
    settings = SiconosSettings(dt=1e-3)
    kept = registry.run_engine_batch("siconos", [(scene, settings) for scene in _strike_scenes()])
    assert starts.read_text().split() == ["started"]
    alone = []
    for i, scene in enumerate(_strike_scenes()):  # another environment each: a child of its own each
        monkeypatch.setenv("CHATTERBENCH_TEST_RUN", str(i))
        alone.append(SiconosEngine().run(scene, settings))
    assert starts.read_text().split() == ["started"] * 6
    for a, b in zip(kept, alone):
        assert a.status == b.status == "ok", (a.message, b.message)
        for column in ("t", "y", "vy"):
            assert np.array_equal(getattr(a, column), getattr(b, column))  # bit for bit


def test_a_run_cut_short_kills_its_child_and_the_next_run_starts_another(tmp_path, monkeypatch):
    from chatterbench.engines.recording import Recording
    from chatterbench.engines.siconos_engine import run as siconos_run

    python, starts = _counting_python(tmp_path)
    monkeypatch.setenv(ENV, python)
    scene, settings = load_scene("bouncing-ball", ["duration=2"]), SiconosSettings(dt=1e-4)
    feed = SiconosEngine().samples(Recording("siconos", scene, settings, {}, None, (0.0, 1.0)))
    assert next(feed) is None and len(next(feed).t)  # ready, then the first frame of 20,000 steps
    child = feed.gi_frame.f_locals["child"]
    assert child.proc.poll() is None
    feed.close()  # the consumer stops reading mid-run (a blow-up cut): its child is mid-answer
    assert child.proc.poll() is not None  # killed, not left stepping
    assert not any(k[2] == python for k in siconos_run._KEPT)  # nor kept
    traj = SiconosEngine().run(load_scene("bouncing-ball", ["duration=0.1"]), SiconosSettings(dt=1e-3))
    assert traj.status == "ok" and starts.read_text().split() == ["started"] * 2
    assert any(k[2] == python for k in siconos_run._KEPT)  # the one that answered is kept


def test_the_child_answers_requests_in_turn_one_a_line_or_spanning_lines():
    req = protocol.request(load_scene("bouncing-ball"), dt=1e-3, steps=5, theta=0.5, solver="lemke", tolerance=1e-12)
    one = 8 + 5 * 3 * 8 + 16  # ready, 5 rows of 3 values, the end frame
    out = _child(json.dumps(req) + "\n" + json.dumps({**req, "steps": 2}) + "\n")
    assert out.returncode == 0 and len(out.stdout) == one + (8 + 2 * 3 * 8 + 16)
    assert out.stdout[:one] == _child(json.dumps(req)).stdout  # the first answered as alone
    out = _child(json.dumps(req, indent=2) + "\n" + json.dumps(req, indent=2))  # written by hand, over lines
    assert out.returncode == 0 and len(out.stdout) == 2 * one
    out = _child(json.dumps(req) + "\n" + json.dumps({**req, "dt": -1.0}) + "\n")  # the first answered, then refused
    assert out.returncode == 2 and len(out.stdout) == one and "dt = -1.0" in out.stderr.decode()
