"""compare, report and gate run each engine in a child with a time limit: one engine's crash or hang
is that engine's verdict, and the other engine's results (and the report) are kept.

The faults are real: ``CHATTERBENCH_FAULT`` (engines/faults.py, the test-only hook) makes the
engine's process raise SIGSEGV or sleep forever before its first step.
"""

from __future__ import annotations

import json
from xml.etree import ElementTree as ET

import pandas as pd
import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.engines.registry import make_settings, run_engine, run_engine_isolated
from chatterbench.reference import load_scene

from helpers import RESTS, ball_check, ball_gate

BALL = ["bouncing-ball", "--set", "duration=1.6"]  # one sliding episode, Zeno point 1.355 s
# PyBullet as a user sets it: the ball rests after the stick (at its default threshold 0 it keeps bouncing at g dt: buzz)
RESTING = ["--set", "pybullet.restitution_velocity_threshold=0.002"]


def test_an_isolated_engine_run_that_segfaults_comes_back_crashed(monkeypatch):
    monkeypatch.setenv("CHATTERBENCH_FAULT", "segfault:mujoco")
    scene = load_scene("bouncing-ball", ["duration=0.5"])
    traj = run_engine_isolated("mujoco", scene, make_settings("mujoco"), timeout=60)
    assert traj.status == "crashed" and "SIGSEGV" in traj.message
    assert len(traj.t) == 1 and traj.settings["dt"] == 1e-4  # the failed-run trajectory, settings kept
    ok = run_engine_isolated("pybullet", scene, make_settings("pybullet"), timeout=60)
    assert ok.status == "ok" and len(ok.t) > 1000


def test_an_isolated_run_gives_the_same_trajectory_as_in_process():
    scene = load_scene("bouncing-ball", ["duration=0.5"])
    settings = make_settings("mujoco", dt=1e-3)
    child = run_engine_isolated("mujoco", scene, settings, timeout=60)
    same = run_engine("mujoco", scene, settings)
    assert child.status == "ok" and (child.t == same.t).all() and (child.y == same.y).all()


def test_compare_keeps_pybullet_when_mujoco_segfaults(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CHATTERBENCH_FAULT", "segfault:mujoco")
    out = tmp_path / "cmp"
    assert main(["compare", *BALL, *RESTING, "--out", str(out), "--no-figures"]) == 0
    captured = capsys.readouterr()
    summary = captured.out.split("summary:")[1]
    rows = {line.split()[0]: line.split() for line in summary.strip().splitlines()[1:]}
    assert rows["mujoco"][1] == "crashed" and rows["pybullet"][1] == "match"
    assert "mujoco: crashed: killed by SIGSEGV" in captured.err
    table = pd.read_csv(out / "episodes.csv", keep_default_na=False)
    assert dict(zip(table.engine, table.verdict)) == {"mujoco": "crashed", "pybullet": "match"}
    provenance = json.loads((out / "provenance.json").read_text(encoding="utf-8"))
    assert provenance["engines"]["mujoco"]["status"] == "crashed"
    assert provenance["engines"]["pybullet"]["status"] == "ok"


@pytest.mark.slow
def test_report_is_written_when_one_engine_segfaults(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CHATTERBENCH_FAULT", "segfault:pybullet")
    out = tmp_path / "report"
    assert main(["report", "bouncing-ball", "--set", "duration=1.6", "--out", str(out)]) == 0
    md = (out / "report.md").read_text(encoding="utf-8")
    html = (out / "index.html").read_text(encoding="utf-8")
    summary = md.split("## Summary")[1]
    ball = [line for line in summary.splitlines() if "bouncing-ball" in line]
    assert any("pybullet" in line and "crashed" in line for line in ball), ball
    assert any("mujoco" in line and "crashed" not in line for line in ball), ball
    assert "crashed" in html and "killed by SIGSEGV" in html + md


def test_a_hanging_engine_times_out_and_the_gate_reports_the_others(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CHATTERBENCH_FAULT", "hang:mujoco")
    gate = tmp_path / "gate.toml"
    gate.write_text(ball_gate(ball_check("ball/pybullet", ["verdict == match"], settings=RESTS),
                              ball_check("ball/mujoco", ["verdict in [match, rebound]"], engine="mujoco")))

    junit = tmp_path / "gate.xml"
    assert main(["gate", str(gate), "--timeout", "2", "--junit", str(junit)]) == 1
    out = capsys.readouterr().out
    assert "FAIL: 1 of 2 checks passed" in out
    cases = {c.get("name"): c for c in ET.parse(junit).getroot().iter("testcase")}
    assert cases["ball/pybullet"].find("failure") is None
    failure = cases["ball/mujoco"].find("failure")
    assert "verdict = timeout" in failure.get("message") and "no result after 2 s" in failure.text
