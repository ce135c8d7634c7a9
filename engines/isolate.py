"""Run one function call in a forked child under a wall-clock limit; a crash or a hang becomes a result.

    >>> from chatterbench.engines.isolate import run_isolated
    >>> outcome = run_isolated(sum, [1, 2, 3], timeout=10.0)
    >>> outcome.status, outcome.value, outcome.message
    ('ok', 6, '')
    >>> import os
    >>> run_isolated(os._exit, 3, timeout=10.0).status      # the child died: its caller goes on
    'crashed'

Promises: ``run_isolated`` never raises for what the call does. The call returns ->
``ok`` with its value; it raises -> ``error`` with the exception and traceback; its
process dies (a signal such as SIGSEGV, or ``os._exit``) -> ``crashed``; it runs past
``timeout`` seconds -> the child is killed (SIGKILL) and the outcome is ``timeout``.
The caller's process is never touched, so a sweep goes on after any of them.

The command's limit on one engine run (``run_limit``, ``set_run_limit``: ``--timeout``, a sweep's
``timeout``; ``RUN_LIMIT`` where none is set) is what a plugin's isolated run (``base.EngineAdapter.isolated``),
a plugin's load (``plugins.py``) and an engine's own child process (Siconos's) are held to. Inside a child of
``run_isolated`` (``inside``) a run is already isolated and is not forked again.

How: ``os.fork`` and a one-way ``multiprocessing`` pipe carrying the pickled result.
Forking keeps everything the caller already loaded (engine modules, numba-compiled
kernels), so a child starts in about a millisecond. ``multiprocessing.Process`` is
not used because it refuses to start children from a daemonic process, which is what
a Dask worker is. On Linux the child asks the kernel to kill it when its parent dies
(``PR_SET_PDEATHSIG``), so killing a sweep never leaves a hung point running.
POSIX only (fork).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import faulthandler
import functools
import math
import os
import signal
import sys
import time
import traceback
from dataclasses import dataclass
from multiprocessing.connection import Pipe
from typing import Any, Callable

OUTCOMES = ("ok", "error", "crashed", "timeout")
_PR_SET_PDEATHSIG = 1  # linux/prctl.h
RUN_LIMIT = 600.0  # [s] the limit on one engine run where the command sets none (the command line's --timeout default)
POLL_S = 0.25  # [s] the longest a main thread blocks in one wait for a child or a worker (comparisons' waits.py too)
_STATE = {"limit": RUN_LIMIT, "inside": False}  # this process's run limit; whether it is a child of run_isolated


def run_limit() -> float:
    """The command's wall-clock limit on one engine run [s] (``set_run_limit``; ``RUN_LIMIT`` by default)."""
    return _STATE["limit"]


def set_run_limit(seconds: float) -> None:
    """Make ``seconds`` (> 0, finite) the limit on every engine run of this process from now on."""
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0 < seconds < math.inf:
        raise ValueError(f"run limit = {seconds!r}: must be a number of seconds > 0")
    _STATE["limit"] = float(seconds)


def inside() -> bool:
    """Whether this process is a child of ``run_isolated`` (its runs are isolated already)."""
    return _STATE["inside"]


@dataclass(frozen=True)
class Outcome:
    """What became of one isolated call."""

    status: str  # one of OUTCOMES
    value: Any  # the call's return value when status == "ok", else None
    message: str  # "" when ok; the exception, the signal or the limit otherwise
    wall_time: float  # [s] from fork to result, crash or kill, measured by the parent


@functools.cache
def _libc():
    """The C library, looked up once in the parent (``find_library`` runs a subprocess: slow)."""
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:
        return None


def die_with_parent(parent: int) -> None:
    """Ask Linux to SIGKILL this process when its parent exits (no-op elsewhere); a parent (pid ``parent``) that
    exited before the request took effect ends this process here."""
    libc = _libc() if sys.platform.startswith("linux") else None
    if libc is not None:  # without libc a child simply outlives a killed parent
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:
        os._exit(1)


def _child(fn: Callable[..., Any], args: tuple, send, parent: int) -> None:
    """Body of the forked child: never returns (``os._exit``), so no parent cleanup runs twice."""
    code = 0
    _STATE["inside"] = True
    try:
        die_with_parent(parent)
        # a crash is reported in the outcome; a faulthandler dump would only scribble over the progress bar
        faulthandler.disable()
        try:
            value = fn(*args)
            send.send(("ok", value, ""))
        except BaseException as exc:  # report everything, even SystemExit, as an error
            send.send(("error", None, f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"))
        send.close()
    except BaseException:  # the result could not be sent (unpicklable value, closed pipe)
        code = 3
    finally:
        os._exit(code)


def _exit_message(wait_status: int) -> str:
    if os.WIFSIGNALED(wait_status):
        sig = os.WTERMSIG(wait_status)
        try:
            name = signal.Signals(sig).name
        except ValueError:
            name = f"signal {sig}"
        return f"killed by {name}"
    return f"exited with code {os.WEXITSTATUS(wait_status)} without a result"


def _ready(recv, timeout: float) -> bool:
    """Whether the child's pipe ``recv`` has its result (or closed) within ``timeout`` [s] (inf: no limit), waited for
    ``POLL_S`` at a time: between slices the main thread runs and acts on a Ctrl-C that another thread received
    (Python 3.11 notices such a signal only then; one wait of the whole limit held it for the run's length)."""
    end = time.monotonic() + timeout
    while True:
        left = end - time.monotonic()
        if recv.poll(min(POLL_S, max(left, 0.0))):
            return True
        if left <= 0.0:
            return False


def run_isolated(fn: Callable[..., Any], *args: Any, timeout: float = math.inf) -> Outcome:
    """Call ``fn(*args)`` in a forked child; wait at most ``timeout`` seconds [s].

    ``fn``'s return value must be picklable. Returns an ``Outcome`` (see the module
    docstring); raises only for a bad ``timeout`` or when the system cannot fork.
    """
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise ValueError(f"timeout = {timeout!r}: must be a number of seconds > 0")
    if sys.platform.startswith("linux"):
        _libc()  # before the fork, so that no child looks it up
    recv, send = Pipe(duplex=False)
    parent = os.getpid()
    start = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - runs in the child, which leaves through os._exit
        recv.close()
        _child(fn, args, send, parent)
    send.close()
    try:
        if _ready(recv, float(timeout)):
            try:
                status, value, message = recv.recv()
            except (EOFError, OSError):  # the pipe closed without a result: the child died
                _, wstatus = os.waitpid(pid, 0)
                return Outcome("crashed", None, _exit_message(wstatus), time.perf_counter() - start)
            os.waitpid(pid, 0)
            return Outcome(status, value, message, time.perf_counter() - start)
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        return Outcome("timeout", None, f"no result after {timeout:g} s; killed", time.perf_counter() - start)
    except BaseException:  # interrupted while waiting: take the child down with us
        try:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        except (ProcessLookupError, ChildProcessError):
            pass
        raise
    finally:
        recv.close()


def _answer(fn: Callable[..., Any], refused: type[BaseException], *args: Any) -> tuple[str, Any]:
    """``fn(*args)`` in the child: ("ok", value), or ("refused", message) for a ``refused`` exception."""
    try:
        return "ok", fn(*args)
    except refused as exc:
        return "refused", str(exc)


def call_isolated(fn: Callable[..., Any], *args: Any, refused: type[BaseException]) -> Any:
    """``fn(*args)``'s value, computed in a forked child under ``run_limit``; the ``Outcome`` when the child failed
    (crashed, timeout, error). A ``refused`` exception in the child (a user's mistake, not the call's failure) is
    raised again here with its message."""
    outcome = run_isolated(_answer, fn, refused, *args, timeout=run_limit())
    if outcome.status != "ok":
        return outcome
    kind, value = outcome.value
    if kind == "refused":
        raise refused(value)
    return value
