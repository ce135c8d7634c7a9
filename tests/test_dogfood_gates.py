"""This repo's own accuracy gate: `gates/default.toml` through the CLI's code path, and the pytest fixture."""

from importlib.metadata import entry_points
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

from chatterbench.comparisons.cli import main

GATES = Path(__file__).resolve().parents[1] / "gates" / "default.toml"
_REGISTERED = any(ep.value == "chatterbench.comparisons.pytest_plugin" for ep in entry_points(group="pytest11"))
if not _REGISTERED:
    # a source tree installed before the pytest11 entry point existed: load the plugin here
    pytest_plugins = ["chatterbench.comparisons.pytest_plugin"]


def test_default_gate_passes(tmp_path, capsys):
    junit = tmp_path / "gate.xml"
    code = main(["gate", str(GATES), "--junit", str(junit)])
    out = capsys.readouterr().out
    assert code == 0, out  # the failing checks' numbers are in the output
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite.get("failures") == "0"
    assert int(suite.get("tests")) == 7


def test_chatter_gate_fixture(chatter_gate):
    # the README's example: MuJoCo's defaults slide and let go on time on Feigin's pair
    # (exit within 0.93 ms of the reference, every one of the 13 episodes a match)
    result = chatter_gate.check("feigin-pair", engine="mujoco", dt=1e-4, exit_error_max=2e-3, verdict="match")
    assert result.row["n_match"] == 13


def test_plugin_is_registered_through_its_entry_point(pytestconfig):
    if not _REGISTERED:
        pytest.skip("chatterbench is installed without its pytest11 entry point; reinstall: pip install -e .")
    assert pytestconfig.pluginmanager.get_plugin("chatterbench") is not None
