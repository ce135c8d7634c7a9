"""Gates in a real CI: job summary, annotations, benchmark JSON, and a baseline that catches growth."""

from __future__ import annotations

import json

import pytest

from chatterbench.comparisons.cli.main import main

from helpers import BALL_PYBULLET_GATE

# the check of BALL_PYBULLET_GATE (its last line is its limits) with PyBullet as a user sets it: the ball rests after
# the stick (its default threshold 0 keeps bouncing at g dt: buzz; gates/default.toml)
GATE = BALL_PYBULLET_GATE + "settings = { restitution_velocity_threshold = 0.002 }\n"


@pytest.fixture
def gate_file(tmp_path):
    path = tmp_path / "gate.toml"
    path.write_text(GATE)
    return path


def _run(*argv: str) -> int:
    return main(["gate", *map(str, argv)])


def test_baseline_passes_an_equal_run_and_fails_a_grown_stick_error(gate_file, tmp_path, capsys):
    base = tmp_path / "base.json"
    assert _run(gate_file, "--save-baseline", base) == 0
    saved = json.loads(base.read_text())
    stick = saved["checks"]["ball/pybullet"]["stick_error_max"]
    assert 1e-3 < stick < 3e-3 and "pybullet" in saved["versions"]  # PyBullet sticks 2.1 ms after the Zeno point (its own ladder)
    capsys.readouterr()
    assert _run(gate_file, "--baseline", base) == 0  # the same deterministic run: nothing grew
    assert "0 metric(s) regressed" in capsys.readouterr().out
    # a baseline from a better engine: its stick error was half of today's, so today's grew 100%
    saved["checks"]["ball/pybullet"]["stick_error_max"] = stick / 2
    base.write_text(json.dumps(saved))
    assert _run(gate_file, "--baseline", base) == 1
    out = capsys.readouterr().out
    grown = [line.strip() for line in out.splitlines() if line.strip().startswith("stick_error_max <= ")]
    assert len(grown) == 1 and "(baseline " in grown[0] and "+ 10%)" in grown[0] and grown[0].endswith("FAIL (grew 100%)")
    assert "engines now pybullet" in out and "baseline pybullet" in out  # both runs' versions
    # within a wider band it passes
    assert _run(gate_file, "--baseline", base, "--band", "1.5") == 0


def test_summary_json_and_annotations(gate_file, tmp_path, capsys, monkeypatch):
    step_summary = tmp_path / "step_summary.md"
    step_summary.write_text("earlier step\n")
    monkeypatch.setenv("GITHUB_ACTIONS", "true")
    monkeypatch.setenv("GITHUB_STEP_SUMMARY", str(step_summary))
    failing = gate_file.read_text().replace("stick_error_rel_max <= 0.05", "stick_error_rel_max <= 1e-4")
    gate_file.write_text(failing)
    summary, bench = tmp_path / "summary.md", tmp_path / "bench.json"
    assert _run(gate_file, "--summary", summary, "--json", bench) == 1
    out = capsys.readouterr().out
    annotation = [line for line in out.splitlines() if line.startswith("::error ")]
    # on the failing limit's line of the gate file (as an editor numbers it; tests/comparisons/ci/test_gate_lines.py)
    line = next(n for n, text in enumerate(failing.splitlines(), 1) if "stick_error_rel_max" in text)
    assert line == 10  # BALL_PYBULLET_GATE's limits: a blank first line, 3 of defaults, a blank, 5 of the check
    assert len(annotation) == 1 and annotation[0].startswith(f"::error file={gate_file},line={line},title=chatter gate "
                                                             "ball/pybullet::stick_error_rel_max = ")
    text = summary.read_text()
    assert text.startswith("## chatterbench gate") and "FAIL" in text and "| ball/pybullet | `stick_error_rel_max <= 0.0001` |" in text
    assert step_summary.read_text() == "earlier step\n" + text  # appended, as GitHub expects
    entries = json.loads(bench.read_text())
    names = {e["name"]: e for e in entries}
    assert names["ball/pybullet: stick_error_max"]["unit"] == "s" and names["ball/pybullet: cost_per_sim_s"]["value"] > 0
    assert "ball/pybullet: exit_error_max" not in names  # the ball never exits: NaN is left out
    assert all(set(e) == {"name", "unit", "value", "extra"} for e in entries)


def test_annotations_only_in_github_actions(gate_file, capsys, monkeypatch):
    monkeypatch.delenv("GITHUB_ACTIONS", raising=False)
    monkeypatch.delenv("GITHUB_STEP_SUMMARY", raising=False)
    gate_file.write_text(gate_file.read_text().replace("<= 0.05", "<= 1e-4"))
    assert _run(gate_file) == 1
    assert "::error" not in capsys.readouterr().out


def test_a_broken_baseline_is_refused_before_any_run(gate_file, tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert _run(gate_file, "--baseline", bad) == 2
    err = capsys.readouterr().err
    assert "--baseline" in err and "not a chatterbench gate baseline" in err
