"""A search interrupted while a pass's candidates are queued stops at once: ``tune``, ``atlas`` and an atlas of two
cases side by side, under SIGTERM (a cancelled CI job, ``kill``) or SIGINT (Ctrl-C), their workers killed, not waited
for.

Before: the pool's shutdown waited for every candidate already handed to it, so a killed atlas of Drake's spring pair
ran on for minutes (seen: still running 50 s after SIGTERM, the main thread in ``ProcessPoolExecutor.shutdown``).
The signal is sent by the command's own process just before it reads the first row of a pass of 16 candidates or
more (two candidates' band runs at a phase, ``2 * BAND_PART``; all of the pass handed out to the pool), so the moment
is the same on every machine, and each judged candidate writes a line after it: at most the two the workers were
running may finish once the signal is sent. Each candidate runs 400 simulated seconds (about a second), so a pass run
out took seconds more and 14 candidates or more after the signal; an interrupted one stops at once.
"""

from __future__ import annotations

import dataclasses
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from chatterbench.reference.scene import load_scene
from chatterbench.reference.scene_toml import scene_toml

HOOK = """
import os, signal, sys
sys.argv[0] = "chatterbench"  # as the console script: the command's own signal handling
from chatterbench.comparisons.studies.tune import rows, runner
from chatterbench.comparisons.studies.tune.search import BAND_PART
sig, log, handed, sent = int(sys.argv[1]), sys.argv[2], [], []
WHOLE = 2 * BAND_PART  # a pass this long or longer: two candidates' band runs at a phase, or a grid's pass
real_evaluator, real_row, real_evaluate = runner.evaluator, rows._row, rows.evaluate

def note(word):  # one line a write, appended: whole lines from every process
    with open(log, "a") as f:
        f.write(word + "\\n")

def evaluator(*args, **kwargs):
    run_batch = real_evaluator(*args, **kwargs)
    def counted(batch, *more):
        handed.append(len(batch))
        return run_batch(batch, *more)
    return counted

def signal_first(*args, **kwargs):  # a row waited for once a pass of WHOLE candidates or more is all handed out
    if handed and handed[-1] >= WHOLE and not sent:  # once (cases side by side: the first of them)
        handed.clear()
        sent.append(True)
        note("signal")
        os.kill(os.getpid(), sig)  # delivered at once, as a user's Ctrl-C or a CI job's kill would be
    return real_row(*args, **kwargs)

def evaluate(*args, **kwargs):  # in a worker (forked from here): a candidate judged
    row = real_evaluate(*args, **kwargs)
    note("candidate")
    return row

runner.evaluator, rows._row, rows.evaluate = evaluator, signal_first, evaluate  # tune's search calls runner's name
from chatterbench.comparisons.cli.main import main
sys.exit(main(sys.argv[3:]))
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


# each command under one signal, and each signal under a command with one pool and one with two side by side: the
# handlers are the command's (cli.interrupt), not the pool's, so the six pairs added CI time and no case
CASES = [("tune", signal.SIGINT, 130), ("atlas", signal.SIGTERM, 143), ("atlas-side-by-side", signal.SIGINT, 130)]


@pytest.mark.slow
@pytest.mark.parametrize("command, sig, code", CASES, ids=[f"{c}-{s.name}" for c, s, _ in CASES])
def test_a_search_interrupted_mid_pass_stops_without_running_the_pass_out(tmp_path, command, sig, code):
    ball = load_scene("bouncing-ball", ["duration=400"])
    scenes = []  # the built-in ball run for 400 s, as scene files (the atlas takes no --set): a candidate takes seconds
    for name in ("long-ball", "long-ball-2")[:2 if command == "atlas-side-by-side" else 1]:
        scenes.append(tmp_path / f"{name}.toml")
        scenes[-1].write_text(scene_toml(dataclasses.replace(ball, name=name), "the built-in ball, run for 400 s"))
    out, log = tmp_path / f"{command}-out", tmp_path / "events.txt"
    # the atlas one case at a time, and two cases side by side, each with its pool of 2 workers
    at_once = {"atlas": ["--cases-at-once", "1"], "atlas-side-by-side": ["--cases-at-once", "2"]}.get(command, [])
    argv = [command.split("-")[0], *map(str, scenes), "--engines", "pybullet", "--workers", "2", *at_once,
            "--out", str(out)]
    try:
        done = subprocess.run([sys.executable, "-c", HOOK, str(int(sig)), str(log), *argv], capture_output=True,
                              text=True, timeout=240)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{command} ran the interrupted pass out: still running 240 s after the signal")
    assert done.returncode == code, done.stdout + done.stderr
    events = log.read_text().split()
    after = events[events.index("signal") + 1:]
    # at most the candidates the workers were running (2 a case) finish in the moment before they are killed;
    # before, the rest of the pass ran: 14 or more candidates after the signal
    assert len(after) <= 2 * len(scenes), f"{command} ran {len(after)} candidates after the signal"
    for _ in range(50):  # a killed worker is reaped by the system a moment after its parent's exit
        left = _left_running(str(out))
        if not left:
            break
        time.sleep(0.1)
    assert not left, f"workers left running after {command} exited: {left}"
    assert not list(out.glob("cases/*/*/case.json"))  # no case finished: none written as if it had
    assert not (out / "recommended.json").exists()  # nothing finished, nothing written as if it had
