"""Long commands say what runs: a tqdm bar on a terminal's stderr, nothing in pipes, and MuJoCo Warp's compile noted."""

import fcntl
import io
import os
import pty
import struct
import subprocess
import sys
import termios

from helpers import needs_engine

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.cli.progress import Progress
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.reference import load_scene

COMMAND = [sys.executable, "-m", "chatterbench.comparisons.cli", "compare", "bouncing-ball", "--engines", "pybullet",
           "--set", "duration=1.6"]


def _on_a_terminal(command: list[str]) -> tuple[str, str]:
    """Run ``command`` with stderr on a 120-column pseudo-terminal; returns (stdout, what the terminal showed)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL)
    os.close(slave)
    shown = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # the child closed its end
            break
        if not chunk:
            break
        shown += chunk
    os.close(master)
    out, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0
    return out.decode(), shown.decode(errors="replace")


def test_compare_shows_a_bar_on_a_terminal_and_keeps_stdout_clean():
    out, shown = _on_a_terminal(COMMAND)
    # before: nothing on stderr until the tables came (5 minutes for mujoco_warp's first run)
    assert "compare bouncing-ball: reference" in shown and "compare bouncing-ball: pybullet" in shown
    assert "/2 runs done [" in shown  # two runs to go through: the reference and pybullet
    assert "\r" not in out and "summary:" in out  # the tables on stdout, no bar mixed in


def test_no_bar_where_stderr_is_not_a_terminal():
    proc = subprocess.run(COMMAND, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0
    assert "%|" not in proc.stderr and "\r" not in proc.stderr  # CI logs stay clean


def test_mujoco_warps_compile_is_noted_terminal_or_not():
    needs_engine("mujoco_warp")  # the note is the adapter's fact (first_run_note)
    log = io.StringIO()  # not a terminal: no bar, the note still
    with Progress(2, "compare feigin-pair", unit="run", file=log) as bar:
        bar.stage("reference")
        bar.stage("mujoco_warp")
    assert "compiles MuJoCo Warp's kernels" in log.getvalue()
    assert log.getvalue().count("chatterbench: note:") == 1


def test_compare_says_each_run_as_it_starts():
    said = []
    compare(load_scene("bouncing-ball", ["duration=0.6"]), settings=settings_for(("pybullet", "mujoco"), 1e-3), progress=said.append)
    assert said == ["reference", "pybullet", "mujoco"]


def test_a_counted_task_of_several_candidates_counts_each():
    # tune hands a worker a part of a pass (``rows.evaluate_part``: a list of rows); the bar counts candidates, so a
    # part of three counts three, a lone candidate one, and a failed task one (before: a part counted one)
    from concurrent.futures import ThreadPoolExecutor

    from chatterbench.comparisons.cli.progress import CountingExecutor

    def fail():
        raise ValueError("a candidate's failure")

    bar = Progress(None, "tune", unit="candidate", enabled=False)
    with ThreadPoolExecutor(1) as pool:
        counted = CountingExecutor(pool, bar)
        futures = [counted.submit(lambda: [{"dt": 1e-3}] * 3), counted.submit(lambda: {"dt": 1e-3}), counted.submit(fail)]
        for f in futures:
            f.exception()
    bar.close()
    assert bar.n == 5
