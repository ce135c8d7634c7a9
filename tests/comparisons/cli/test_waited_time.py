"""The times the commands print include everything the user waited for: a fresh process, timed from outside."""

from __future__ import annotations

import re
import sys

import pytest
from helpers import check_printed_age, run_timed

GATE = """description = "one short check"
[defaults]
dt = 1e-4
[[check]]
scene = "bouncing-ball"
engine = "pybullet"
limits = ["restitution_error_max <= 0.5"]
"""


def test_gate_prints_the_time_since_the_command_started(tmp_path):
    # the old title "1 checks in 0.3 s" counted the checks' runs only, where the user waited for imports and files too
    (tmp_path / "g.toml").write_text(GATE)
    run = run_timed([sys.executable, "-m", "chatterbench.comparisons.cli", "gate", str(tmp_path / "g.toml"),
                     "--junit", str(tmp_path / "j.xml")])
    assert run.proc.returncode == 0, run.proc.stderr
    printed = float(re.search(r"1 checks in ([\d.]+) s since the command started", run.proc.stdout).group(1))
    # the JUnit file is written before the line: the time printed covers the imports, the check and the file
    check_printed_age(printed, run, (tmp_path / "j.xml").stat().st_mtime, rounding=0.05)
    # the other way: the old title's figure, the check's runs alone, is caught by the same check
    runs = float(re.search(r"\(their runs ([\d.]+) s\)", run.proc.stdout).group(1))
    with pytest.raises(AssertionError, match="misses part of the run"):
        check_printed_age(runs, run, (tmp_path / "j.xml").stat().st_mtime, rounding=0.05)
