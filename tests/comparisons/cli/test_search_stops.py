"""A search interrupted while a pass's candidates are queued stops at once: ``tune`` and ``atlas`` under SIGTERM (a
cancelled CI job, ``kill``) and SIGINT (Ctrl-C), their workers killed, not waited for.

Before: the pool's shutdown waited for every candidate already handed to it, so a killed atlas of Drake's spring pair
ran on for minutes (seen: still running 50 s after SIGTERM, the main thread in ``ProcessPoolExecutor.shutdown``).
The signal is sent by the command's own process just before it reads the first row of a pass of 20 candidates or
more (all of the pass handed out to the pool), so the moment is the same on every machine; each candidate here
runs 400 simulated seconds (about 2 s), so a pass run out takes a minute or more, an interrupted one a second.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

HOOK = """
import os, signal, sys
sys.argv[0] = "chatterbench"  # as the console script: the command's own signal handling
from chatterbench.comparisons.studies.tune import rows, runner
sig, real_evaluator, real_row, handed = int(sys.argv[1]), rows.evaluator, rows._row, []

def evaluator(*args, **kwargs):
    run_batch = real_evaluator(*args, **kwargs)
    def counted(batch, *more):
        handed.append(len(batch))
        return run_batch(batch, *more)
    return counted

def signal_first(*args, **kwargs):  # a row waited for once a pass of 20 candidates or more is all handed out
    if handed and handed[-1] >= 20:
        handed.clear()
        os.kill(os.getpid(), sig)  # delivered at once, as a user's Ctrl-C or a CI job's kill would be
    return real_row(*args, **kwargs)

runner.evaluator, rows._row = evaluator, signal_first  # tune's search calls runner's name
from chatterbench.comparisons.cli.main import main
sys.exit(main(sys.argv[2:]))
"""

LONG_BALL = """name = "long-ball"
description = "the built-in ball, run for 400 s: a candidate takes seconds"
mass1 = "inf"
mass2 = 1.0
restitution = 0.5
duration = 400.0

[gap]
lower = 0.0

[initial]
y = 1.0

[[forces]]
kind = "constant"
on = "body2"
value = -9.81
"""


def _left_running(marker: str) -> list[int]:
    """Processes whose command line names ``marker`` (the command's own folder): its workers, if any outlived it."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if marker.encode() in cmdline.read_bytes():
                found.append(int(cmdline.parent.name))
        except OSError:  # gone meanwhile
            continue
    return found


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)], ids=["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("command", ["tune", "atlas"])
def test_a_search_interrupted_mid_pass_stops_without_running_the_pass_out(tmp_path, command, sig, code):
    scene = tmp_path / "long-ball.toml"
    scene.write_text(LONG_BALL)
    out = tmp_path / f"{command}-out"
    argv = [command, str(scene), "--engines", "pybullet", "--workers", "2", "--out", str(out)]
    try:
        done = subprocess.run([sys.executable, "-c", HOOK, str(int(sig)), *argv], capture_output=True, text=True,
                              timeout=240)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{command} ran the interrupted pass out: still running 240 s after the signal")
    assert done.returncode == code, done.stdout + done.stderr
    for _ in range(50):  # a killed worker is reaped by the system a moment after its parent's exit
        left = _left_running(str(out))
        if not left:
            break
        time.sleep(0.1)
    assert not left, f"workers left running after {command} exited: {left}"
    assert not (out / "recommended.json").exists()  # nothing finished, nothing written as if it had
