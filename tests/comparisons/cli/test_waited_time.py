"""The times the commands print include everything the user waited for: a fresh process, timed from outside."""

from __future__ import annotations

import re
import subprocess
import sys
import time

GATE = """description = "one short check"
[defaults]
dt = 1e-5
[[check]]
scene = "bouncing-ball"
engine = "pybullet"
limits = ["restitution_error_max <= 0.5"]
"""


def test_gate_prints_the_time_since_the_command_started(tmp_path):
    # the old title "1 checks in 0.3 s" counted the checks' runs only, where the user waited for imports and files too
    (tmp_path / "g.toml").write_text(GATE)
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "chatterbench.comparisons.cli", "gate", str(tmp_path / "g.toml"),
                             "--junit", str(tmp_path / "j.xml")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    printed = wall = None
    for line in proc.stdout:  # the line is timed as it arrives: the interpreter's exit after it is no one's wait
        found = re.search(r"1 checks in ([\d.]+) s since the command started", line)
        if found:
            printed, wall = float(found.group(1)), time.perf_counter() - start
    err = proc.stderr.read()
    assert proc.wait(timeout=300) == 0, err
    assert printed is not None, err
    # from the process's start to the print: the true value is within the print's 0.05 s rounding of ``printed``,
    # at most ``wall`` (the kernel's clocks tick in 0.01 s) and no more than the pipe's delivery below it
    assert wall - 0.25 <= printed + 0.05 and printed - 0.05 <= wall + 0.02, (printed, wall)
