"""This repo's own accuracy gate: `gates/default.toml` through the CLI's code path, and the pytest fixture."""

from importlib.metadata import entry_points
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

from chatterbench.comparisons.cli.main import main
from shared_engine_runs import share_compares_runs

GATES = Path(__file__).resolve().parents[1] / "gates" / "default.toml"
_REGISTERED = any(ep.value == "chatterbench.comparisons.ci.pytest_plugin" for ep in entry_points(group="pytest11"))
if not _REGISTERED:
    # a source tree installed before the pytest11 entry point existed: load the plugin here
    pytest_plugins = ["chatterbench.comparisons.ci.pytest_plugin"]


@pytest.mark.slow
def test_default_gate_passes(tmp_path, capsys, monkeypatch, tmp_path_factory):
    # its runs at default settings (MuJoCo's three, PyBullet's impact damper) are the README report's and the judge
    # tests'; PyBullet's other three set its restitution threshold (gates/default.toml says why) and run here
    share_compares_runs(monkeypatch, tmp_path_factory)
    junit, summary = tmp_path / "gate.xml", tmp_path / "summary.md"
    code = main(["gate", str(GATES), "--junit", str(junit), "--summary", str(summary)])
    out = capsys.readouterr().out
    assert code == 0, out  # the failing checks' numbers are in the output
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite.get("failures") == "0" and not list(suite.iter("failure"))
    assert int(suite.get("tests")) == 7
    assert summary.read_text().splitlines()[0].endswith(": PASS")


def test_chatter_gate_fixture(chatter_gate, monkeypatch, tmp_path_factory):
    share_compares_runs(monkeypatch, tmp_path_factory)  # the gate's run of MuJoCo on the pair
    # the gate page's example (docs/how-to/gate.md): MuJoCo's defaults stick and let go on time on Feigin's pair (every
    # sticking start within 5% of its chatter, every exit within 2 steps of the reference), while
    # their slow bounces lose more than R says: timing right, impacts off (rebound)
    result = chatter_gate.check("feigin-pair", engine="mujoco", dt=1e-4, verdict=["match", "rebound"],
                                stick_error_rel_max=0.05, exit_error_max=2e-4)
    assert result.row["n_episodes"] == 13 and result.row["verdict"] == "rebound"


def test_plugin_is_registered_through_its_entry_point(pytestconfig):
    if not _REGISTERED:
        pytest.skip("chatterbench is installed without its pytest11 entry point; reinstall: pip install -e .")
    assert pytestconfig.pluginmanager.get_plugin("chatterbench") is not None


@pytest.mark.slow
def test_newton_gate_passes(tmp_path, capsys):
    # the default gate's cases for the Newton engines (gates/newton.toml says why they are in a file of their own)
    pytest.importorskip("newton", reason="the newton extra is not installed: pip install \".[newton]\"")
    junit = tmp_path / "newton-gate.xml"
    code = main(["gate", str(GATES.with_name("newton.toml")), "--junit", str(junit)])
    out = capsys.readouterr().out
    assert code == 0, out
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite.get("failures") == "0" and int(suite.get("tests")) == 3
    assert {case.get("name").split("/")[-1] for case in suite.iter("testcase")} >= {"newton_xpbd", "newton_semi"}
