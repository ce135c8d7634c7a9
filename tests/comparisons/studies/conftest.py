"""Shared by the sweep tests: a `chatterbench sweep` in a child process, and killing it at a chosen moment."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from typing import Callable

import pytest
from helpers import wait_until


def start_sweep(*args: str) -> subprocess.Popen:
    """``chatterbench sweep ARGS`` in a child process (stdout and stderr captured as text)."""
    return subprocess.Popen([sys.executable, "-m", "chatterbench.comparisons.cli", "sweep", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def kill_when(proc: subprocess.Popen, ready: Callable[[], bool], waiting_for: str, limit: float = 120.0) -> None:
    """SIGKILL ``proc`` as soon as ``ready()`` holds; fail if it ends first or ``limit`` [s] passes (a hang guard)."""
    wait_until(lambda: ready() or proc.poll() is not None, waiting_for, limit, every=0.02)
    if not ready():
        pytest.fail(f"sweep ended before it could be killed: {proc.communicate()}")
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()


@pytest.fixture
def sweep_process():
    """``(start_sweep, kill_when)`` for tests that kill a sweep mid-run and resume it."""
    return start_sweep, kill_when
