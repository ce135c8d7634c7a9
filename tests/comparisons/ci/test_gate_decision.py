"""One decision, every writer: a regressed baseline fails the gate in JUnit, the job summary, the
progress lines, the annotations and the benchmark JSON, as it does in the exit code; a passing
gate says PASS in all of them. The JUnit file is read by a from-scratch reader (ElementTree
against the JUnit schema's elements, no chatterbench import)."""

from __future__ import annotations

import json
import re
import shlex
from xml.etree import ElementTree as ET

import pytest

from chatterbench.comparisons.cli.main import main

from helpers import BALL_PYBULLET_GATE, cli_process

# two cheap checks (0.4 s of engine time together): the ball's one sliding episode on each engine, PyBullet with the
# restitution threshold that lets the ball rest after the stick (its default 0 keeps bouncing: buzz; gates/default.toml)
GATE = BALL_PYBULLET_GATE + """settings = { restitution_velocity_threshold = 0.002 }

[[check]]
name = "ball/mujoco"
scene = "bouncing-ball"
engine = "mujoco"
limits = ["verdict in [match, rebound, late]", "stick_error_rel_max <= 0.3"]   # loose: the gate's plumbing is tested here
"""
CHECKS = ("ball/pybullet", "ball/mujoco")
NUMBER = re.compile(r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


def read_junit(path) -> dict:
    """A JUnit reader written from scratch: the totals the suites declare and every testcase's failure.

    Follows the JUnit schema's elements (testsuites > testsuite > testcase > failure/error/skipped)
    the way a CI system reads them; asserts the declared counts agree with the testcases."""
    root = ET.parse(path).getroot()
    assert root.tag in ("testsuites", "testsuite")
    suites = [root] if root.tag == "testsuite" else root.findall("testsuite")
    cases, declared = {}, 0
    for suite in suites:
        suite_cases = suite.findall("testcase")
        failing = [c for c in suite_cases if c.find("failure") is not None or c.find("error") is not None]
        assert int(suite.get("tests")) == len(suite_cases)
        assert int(suite.get("failures")) + int(suite.get("errors", "0")) == len(failing)
        declared += int(suite.get("failures"))
        for case in suite_cases:
            assert case.get("name") and case.get("classname")
            failure = case.find("failure")
            cases[case.get("name")] = None if failure is None else (failure.get("message") or "") + "\n" + (failure.text or "")
    if root.tag == "testsuites" and root.get("failures") is not None:
        assert int(root.get("failures")) == declared
    return {"failures": declared, "cases": cases}


@pytest.fixture
def gate_and_baseline(tmp_path):
    gate = tmp_path / "gate.toml"
    gate.write_text(GATE)
    base = tmp_path / "base.json"
    assert main(["gate", str(gate), "--save-baseline", str(base)]) == 0
    return gate, base


def _gate(capsys, monkeypatch, tmp_path, gate, base):
    monkeypatch.setenv("GITHUB_ACTIONS", "true")
    monkeypatch.delenv("GITHUB_STEP_SUMMARY", raising=False)
    capsys.readouterr()
    files = {k: tmp_path / f"out.{k}" for k in ("xml", "md", "json")}
    code = main(["gate", str(gate), "--baseline", str(base), "--junit", str(files["xml"]),
                 "--summary", str(files["md"]), "--json", str(files["json"])])
    captured = capsys.readouterr()
    return code, captured.out, captured.err, files


def _numbers(text: str) -> list[float]:
    return [float(n) for n in NUMBER.findall(text)]


def test_a_regressed_baseline_fails_in_every_writer(gate_and_baseline, tmp_path, capsys, monkeypatch):
    gate, base = gate_and_baseline
    saved = json.loads(base.read_text())
    measured = {}
    for name, metrics in saved["checks"].items():  # a baseline from a 10x better engine
        for metric, value in metrics.items():
            if metric.endswith("_max") and isinstance(value, float) and value > 0:
                measured[name, metric] = value
                metrics[metric] = value / 10
    base.write_text(json.dumps(saved))
    code, out, err, files = _gate(capsys, monkeypatch, tmp_path, gate, base)
    assert code == 1

    # JUnit: a failing testcase per regressed metric, carrying measured, limit and baseline; each check fails
    junit = read_junit(files["xml"])
    failed = {name: text for name, text in junit["cases"].items() if text is not None}
    assert junit["failures"] == len(failed) >= len(CHECKS)
    for check in CHECKS:
        assert failed.get(check), f"check {check} passes in JUnit: {junit['cases']}"
        regressed = {m for (c, m) in measured if c == check}
        for metric in regressed:
            case = [text for name, text in failed.items() if name.startswith(check) and metric in name]
            assert len(case) == 1, (check, metric, list(failed))
            numbers = _numbers(case[0].split("\n")[0])
            now, was = measured[check, metric], measured[check, metric] / 10
            assert any(abs(n - now) <= 1e-3 * now for n in numbers), (case[0], now)  # measured (4 digits)
            assert any(abs(n - was) <= 1e-3 * was for n in numbers), (case[0], was)  # baseline
            assert any(abs(n - 1.1 * was) <= 1e-3 * was for n in numbers), (case[0], 1.1 * was)  # limit: +10% band

    summary = files["md"].read_text()
    head = summary.splitlines()[0]
    assert "FAIL" in head and "PASS" not in head
    assert "0 of 2 checks passed" in summary
    failure_rows = [line for line in summary.splitlines() if line.startswith("| ball/") and "FAIL" in line]
    assert len(failure_rows) >= len(measured)  # a row per failure

    progress = [line for line in err.splitlines() if re.match(r"\[\d/2\]", line)]
    assert len(progress) == 2 and all("FAIL" in line and "pass" not in line for line in progress), progress
    errors = [line for line in out.splitlines() if line.startswith("::error ")]
    assert {c for c in CHECKS if any(f"chatter gate {c}" in line for line in errors)} == set(CHECKS)
    bench = json.loads(files["json"].read_text())
    regressed = [e for e in bench if "regressed" in e["extra"]]
    assert {e["name"] for e in regressed} == {f"{c}: {m}" for c, m in measured}

    # the gate ends with what to run next: the worst check's compare, with its figures under --out
    lines = out.rstrip().splitlines()
    verdict = [n for n, line in enumerate(lines) if line.startswith("FAIL: ")]
    assert len(verdict) == 1 and lines[verdict[0]].startswith("FAIL: 0 of 2 checks passed; 10 metric(s) regressed")
    after = lines[verdict[0] + 1:]
    assert after[0].startswith("Next, the worst check 'ball/"), after
    assert after[1].strip().startswith("chatterbench compare bouncing-ball ") and " --out gate-failure/" in after[1]
    assert after[2].strip().startswith("chatterbench tune bouncing-ball ") and len(after) == 3


def test_a_passing_gate_says_pass_everywhere(gate_and_baseline, tmp_path, capsys, monkeypatch):
    gate, base = gate_and_baseline
    code, out, err, files = _gate(capsys, monkeypatch, tmp_path, gate, base)
    assert code == 0
    junit = read_junit(files["xml"])
    assert junit["failures"] == 0 and set(junit["cases"]) == set(CHECKS)
    assert all(text is None for text in junit["cases"].values())
    summary = files["md"].read_text()
    assert "PASS" in summary.splitlines()[0] and "FAIL" not in summary
    progress = [line for line in err.splitlines() if re.match(r"\[\d/2\]", line)]
    assert len(progress) == 2 and all(": pass" in line for line in progress)
    assert "::error" not in out and "chatterbench compare" not in out
    assert out.rstrip().splitlines()[-1].startswith("PASS: 2 of 2 checks passed; 0 metric(s) regressed")
    assert not any("regressed" in e["extra"] for e in json.loads(files["json"].read_text()))


def test_a_check_missing_from_the_baseline_fails_it_everywhere(gate_and_baseline, tmp_path, capsys, monkeypatch):
    gate, base = gate_and_baseline
    saved = json.loads(base.read_text())
    del saved["checks"]["ball/mujoco"]
    base.write_text(json.dumps(saved))
    code, out, err, files = _gate(capsys, monkeypatch, tmp_path, gate, base)
    assert code == 1
    junit = read_junit(files["xml"])
    assert junit["failures"] == 1 and "not in the baseline" in junit["cases"]["ball/mujoco"]
    assert junit["cases"]["ball/pybullet"] is None
    summary = files["md"].read_text()
    assert "FAIL" in summary.splitlines()[0] and "1 of 2 checks passed" in summary
    assert "[2/2] ball/mujoco: FAIL" in err and "[1/2] ball/pybullet: pass" in err


@pytest.mark.slow
def test_the_suggested_compare_runs_and_draws_the_failing_check(tmp_path, capsys, monkeypatch):
    # a limit the ball cannot meet; the printed command, run as written in a fresh process, writes its
    # figures (2.8 s alone, 7.9 s on the shared 2-core box: most of it the fresh process's imports)
    gate = tmp_path / "gate.toml"
    gate.write_text(GATE.replace('"stick_error_rel_max <= 0.05"]', '"stick_error_rel_max <= 1e-4"]'))
    monkeypatch.chdir(tmp_path)
    assert main(["gate", str(gate)]) == 1
    out = capsys.readouterr().out
    command = next(line.strip() for line in out.splitlines() if line.strip().startswith("chatterbench compare "))
    argv = shlex.split(command)
    assert argv[argv.index("--engines") + 1] == "pybullet" and "duration=1.6" in argv
    proc = cli_process(*argv[1:], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    out_dir = tmp_path / argv[argv.index("--out") + 1]
    assert list(out_dir.rglob("*.png")), sorted(p.name for p in out_dir.rglob("*"))


def test_the_worst_check_is_a_failed_limit_before_a_larger_regression(gate_and_baseline):
    from chatterbench.comparisons.ci.baseline import load_baseline
    from chatterbench.comparisons.ci.checks import run_gate
    from chatterbench.comparisons.ci.decision import decide
    from chatterbench.comparisons.ci.gate import load_gate

    gate_path, base_path = gate_and_baseline
    base = load_baseline(base_path)
    base["checks"]["ball/mujoco"]["stick_error_max"] /= 1000  # grew 1000x: excess ~900 over its band
    gate_path.write_text(GATE.replace('"stick_error_rel_max <= 0.05"]', '"stick_error_rel_max <= 1e-4"]'))
    decision = decide(run_gate(load_gate(gate_path)), base, baseline_path=str(base_path))
    assert [c.passed for c in decision.checks] == [False, False] and decision.exit_code == 1
    assert [i.kind for c in decision.checks for i in c.failures] == ["limit", "regressed"]
    # PyBullet's sticking error (0.24% of the chatter) against a 0.01% limit (24x) outranks MuJoCo's 1000x growth:
    # a limit the gate file states is the user's promise, a regression only a change
    steps = decision.next_steps()
    assert steps[0].startswith("Next, the worst check 'ball/pybullet' (stick_error_rel_max = ") and "--engines pybullet" in steps[1]


def test_a_failed_run_is_the_worst_failure_everywhere(tmp_path, capsys):
    # a 0.05 s limit on a run that needs about 0.3 s (its child process's imports alone): verdict timeout
    gate = tmp_path / "gate.toml"
    gate.write_text(GATE.split("[[check]]\nname = \"ball/mujoco\"")[0])
    junit = tmp_path / "gate.xml"
    assert main(["gate", str(gate), "--timeout", "0.05", "--junit", str(junit)]) == 1
    captured = capsys.readouterr()
    assert "[1/1] ball/pybullet: FAIL (the run failed, 2 limits failed)" in captured.err
    message = read_junit(junit)["cases"]["ball/pybullet"]
    assert message.startswith("verdict = timeout, limit verdict == match; ") and "the run failed" in message
    assert "Next, the worst check 'ball/pybullet' (verdict = timeout, limit verdict != timeout; the run failed" in captured.out
