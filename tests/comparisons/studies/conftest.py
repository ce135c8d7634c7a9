"""Shared by the sweep tests: a `chatterbench sweep` in a child process, and killing it at a chosen moment."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from typing import Callable

import pytest


def start_sweep(*args: str) -> subprocess.Popen:
    """``chatterbench sweep ARGS`` in a child process (stdout and stderr captured as text)."""
    return subprocess.Popen([sys.executable, "-m", "chatterbench.comparisons.cli", "sweep", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def kill_when(proc: subprocess.Popen, ready: Callable[[], bool], waiting_for: str, limit: float = 60.0) -> None:
    """SIGKILL ``proc`` as soon as ``ready()`` holds; fail if it ends first or ``limit`` [s] passes."""
    deadline = time.monotonic() + limit
    while not ready():
        assert proc.poll() is None, f"sweep ended before it could be killed: {proc.communicate()}"
        assert time.monotonic() < deadline, f"{waiting_for} after {limit:g} s"
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()


@pytest.fixture
def sweep_process():
    """``(start_sweep, kill_when)`` for tests that kill a sweep mid-run and resume it."""
    return start_sweep, kill_when
