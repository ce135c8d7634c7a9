"""Shared by the sweep tests: a `chatterbench sweep` in a child process, and killing it at a chosen moment."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path
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


# -- a real Dask cluster on 127.0.0.1 (the sweep's and the atlas's tests) ------------------------------------------

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args: str, log: Path) -> subprocess.Popen:
    """``dask ARGS`` (the command a user types: ``python -m dask`` is the same entry point) in a session of its own,
    so that killing it kills the whole worker, nanny included."""
    with open(log, "w", encoding="utf-8") as f:
        return subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=f, stderr=subprocess.STDOUT,
                                start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)


@pytest.fixture
def cluster(tmp_path):
    pytest.importorskip("distributed")
    """A scheduler and two workers (one process, one thread each) on 127.0.0.1: (address, [worker processes])."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = _dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard",
                      log=tmp_path / "scheduler.log")
    workers = [_dask("worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard", "--name", f"w{i}",
                     log=tmp_path / f"worker{i}.log") for i in (1, 2)]
    try:
        from distributed import Client

        def two_workers() -> bool:
            try:
                with Client(address, timeout=5) as client:
                    return len(client.scheduler_info()["workers"]) == 2
            except OSError:
                return False

        wait_until(two_workers, "the cluster's two workers never joined the scheduler", every=0.5)
        yield address, workers
    finally:
        for proc in (*workers, scheduler):
            _stop(proc)


