"""Running Siconos: find an interpreter that has it, start ``child.py`` under it, turn its frames into samples.

    >>> from chatterbench.engines.siconos_engine.run import ENV, unavailable
    >>> ENV
    'CHATTERBENCH_SICONOS_PYTHON'
    >>> isinstance(unavailable(), str)          # "" when an interpreter with siconos is found, else why not
    True

Siconos is not on the package index: Debian's ``python3-siconos`` serves the system Python
(``/usr/bin/python3``), not a venv or pyenv interpreter. So runs go to a child process,
``child.py`` under an interpreter that can ``import siconos.kernel``: the one named by the
environment variable ``CHATTERBENCH_SICONOS_PYTHON`` (when it is set, only that one), else
``/usr/bin/python3``, else the first ``python3`` on PATH that has Siconos (``interpreter``).
The request and the reply are ``protocol.py``'s. A child costs a fixed start (the interpreter,
numpy and Siconos's import: 0.11 s measured on 2 quiet cores, README), paid once: a child that
answered its run is kept for the next run of its process and thread (``kept``; a strike batch
is 20 to 120 short runs), each run a model of its own, built after the request (``samples``
yields None at the child's ready frame: set-up, not stepping time); ``OPENBLAS_NUM_THREADS`` and
``OMP_NUM_THREADS`` are 1 there where the environment does not set them (``CHILD_THREADS``: one BLAS thread).

Promises: a child that exits non-zero, dies of a signal or sends what is not the protocol
raises ``SiconosFailure`` with one line saying which (its last stderr line), and the base
makes it the run's ``error`` status (``crashed`` for a signal: ``SiconosCrash``) with the
samples before it; a child that sends what is not the protocol is killed at once (it could
otherwise block on a full pipe that nobody reads); a child still running at the run's time
limit (``isolate.run_limit``: the command's ``--timeout``) is killed, with every process it
started (its own session), and the run is ``timeout`` (``SiconosTimeout``; inside an isolated run
the isolation's own limit does it, and the child dies with its parent); a run cut short by
the base (a blow-up) or by an exception kills its child (the next run starts another). An interpreter whose answer to the
probe is not a version (bytes that are not UTF-8, say) is no Siconos, said in one line.
Sample k is the state after k steps; the contact force of a wall at sample k is the LCP's
impulse of that step over dt [N] (> 0: the wall pushed).
"""

from __future__ import annotations

import atexit
import dataclasses
import functools
import json
import math
import os
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Iterator

import numpy as np

from chatterbench.reference.scene import Scene

from ..api import Crashed, EngineAdapter, Recording, Samples, TimedOut
from ..isolate import inside, run_limit
from ..window import CHUNK
from .protocol import ProtocolError, read_frames, request
from .settings import SiconosSettings

ENV = "CHATTERBENCH_SICONOS_PYTHON"  # a python that can import siconos.kernel (overrides the search)
INSTALL = (f"apt-get install python3-siconos (Debian/Ubuntu: for /usr/bin/python3), or set {ENV} to a python that "
           "can import siconos.kernel")
CHILD = Path(__file__).with_name("child.py")
PARENT = "CHATTERBENCH_SICONOS_PARENT"  # the child's check that its parent is alive (``child.die_with_parent``)
PROBE_TIMEOUT = 60.0  # [s] for ``python -c "import siconos.kernel"`` (a cold disk cache: a few seconds)
# One BLAS thread in a child unless the environment says otherwise: its LCPs are of one or two contacts, and numpy's
# OpenBLAS starting a thread per core cost each child's start more than half its CPU (0.22 -> 0.13 s, measured with
# run.start_seconds on 2 cores); the same trajectories (tests/engines/test_unchanged_runs.py)
CHILD_THREADS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
EXIT_GRACE = 2.0  # [s] a failed child has to exit in before it is killed (one that sent garbage may be blocked writing)
_PROBE = "import numpy, siconos, siconos.kernel; print(siconos.version)"


class SiconosFailure(RuntimeError):
    """The child failed: a non-zero exit, a signal, or a reply that is not the protocol; the message says which."""


class SiconosCrash(SiconosFailure, Crashed):
    """The child died of a signal (a segfault, the out-of-memory killer): the run is ``crashed``, not ``error``."""


class SiconosTimeout(SiconosFailure, TimedOut):
    """The child ran past the run's time limit and was killed: the run is ``timeout``."""


@dataclasses.dataclass(frozen=True)
class Interpreter:
    """A python that can import Siconos."""

    path: str  # the executable
    version: str  # ``siconos.version`` there


@functools.cache
def _probe(python: str) -> Interpreter | str:
    """``python``'s Siconos, or why it has none (cached per path: a probe starts an interpreter)."""
    try:
        out = subprocess.run([python, "-c", _PROBE], capture_output=True, timeout=PROBE_TIMEOUT)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"{python}: {type(exc).__name__}: {exc}"
    if out.returncode != 0:
        lines = out.stderr.decode(errors="replace").strip().splitlines()
        return f"{python}: {lines[-1] if lines else f'exit code {out.returncode}'}"
    try:
        version = out.stdout.decode().strip()
    except UnicodeDecodeError:
        return f"{python}: answered the Siconos probe with bytes that are not UTF-8 ({out.stdout[:24]!r}), not a version"
    if not re.fullmatch(r"[0-9][0-9A-Za-z.+~-]{0,40}", version):
        return f"{python}: answered the Siconos probe with {version[:40]!r}, not a version"
    return Interpreter(python, version)


def _candidates() -> list[str]:
    """Where to look, in order: $CHATTERBENCH_SICONOS_PYTHON alone when set, else /usr/bin/python3 and PATH's python3s."""
    named = os.environ.get(ENV)
    if named is not None:
        return [named]
    found = ["/usr/bin/python3"] if os.access("/usr/bin/python3", os.X_OK) else []
    for folder in os.get_exec_path():
        path = shutil.which("python3", path=folder)
        if path and os.path.realpath(path) not in map(os.path.realpath, found):
            found.append(path)
    return found


def interpreter() -> Interpreter | str:
    """The first candidate with Siconos, or a one-line reason that names the install line."""
    reasons = []
    for python in _candidates():
        got = _probe(python)
        if isinstance(got, Interpreter):
            return got
        reasons.append(got)
    where = f"{ENV}={os.environ[ENV]!r}" if ENV in os.environ else "/usr/bin/python3 and the python3s on PATH"
    return f"engine 'siconos' needs Siconos for some python: {INSTALL} (none found in {where}: {'; '.join(reasons)[:300]})"


def unavailable() -> str:
    """Why the engine cannot run here ("" when it can): the registry's probe for ``siconos``."""
    got = interpreter()
    return "" if isinstance(got, Interpreter) else got


class Child:
    """One ``child.py`` process under ``python`` answering requests, in a session of its own; each request's run is
    held to the run's time limit ``limit`` [s] (default ``isolate.run_limit``; none inside an isolated run, whose own
    limit kills its process and so the child, ``child.die_with_parent``): when it passes, the child is killed with
    every process it started. ``request``: a one-shot child, sent that request and its stdin closed; without it, a
    child kept for the requests of ``ask`` (``kept``). A context manager that kills it on exit."""

    def __init__(self, python: str, request: dict | None = None, limit: float | None = None) -> None:
        self.given_limit = limit
        self.limit = math.inf
        self.timed_out = False
        self.timer: threading.Timer | None = None
        self.stderr = tempfile.TemporaryFile()
        self.proc = subprocess.Popen([python, str(CHILD)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.stderr, env=_child_env(), start_new_session=True)
        if request is not None:
            self.ask(request, last=True)

    def ask(self, request: dict, last: bool = False) -> bool:
        """Send one request (one line) and start its run's clock; ``last``: close stdin after it. False when the
        child is gone before reading it (its exit code says why, ``failure``)."""
        self.limit = (math.inf if inside() else run_limit()) if self.given_limit is None else self.given_limit
        self.timed_out = False
        self.timer = threading.Timer(self.limit, self._time_up)
        self.timer.daemon = True
        if math.isfinite(self.limit):
            self.timer.start()
        try:
            self.proc.stdin.write(json.dumps(request).encode() + b"\n")
            if last:
                self.proc.stdin.close()
            else:
                self.proc.stdin.flush()
        except BrokenPipeError:  # it died before reading
            return False
        return True

    def answered(self) -> None:
        """The request's end frame is read: its clock stops (a kept child waits for the next request)."""
        if self.timer is not None:
            self.timer.cancel()

    def _time_up(self) -> None:
        self.timed_out = True
        self.kill()

    def kill(self) -> None:
        """SIGKILL the child's session: the child and whatever it started (which could hold its pipes open)."""
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):  # all gone already
            pass

    def __enter__(self) -> "Child":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Kill the child (its whole session) and free its pipes."""
        self.answered()
        self.kill()
        self.proc.wait()
        for pipe in (self.proc.stdin, self.proc.stdout):
            try:
                pipe.close()
            except OSError:  # a write buffer the dead child can no longer take
                pass
        self.stderr.close()

    def failure(self, why: str = "") -> SiconosFailure:
        """What went wrong, in one line: the exit (code or signal) and the child's last stderr line. A child still
        running ``EXIT_GRACE`` seconds on (it sent what is not the protocol, and may be blocked writing more) is
        killed."""
        try:  # a child whose reply ended is exiting: its code says how
            code, running = self.proc.wait(timeout=EXIT_GRACE), False
        except subprocess.TimeoutExpired:
            self.kill()
            code, running = self.proc.wait(), True
        self.stderr.seek(0)
        lines = self.stderr.read().decode(errors="replace").strip().splitlines()
        last = lines[-1] if lines else ""
        kind = SiconosCrash if code < 0 else SiconosFailure
        if self.timed_out:
            kind, exit_ = SiconosTimeout, f"ran past the run's time limit of {self.limit:g} s and was killed"
            why = ""
        elif running:
            kind, exit_ = SiconosFailure, "sent what is not the protocol and was killed"
        elif code < 0:
            try:
                exit_ = f"killed by {signal.Signals(-code).name}"
            except ValueError:
                exit_ = f"killed by signal {-code}"
        else:
            exit_ = f"exited with code {code}"
        return kind("; ".join(filter(None, (f"the Siconos child {exit_}", why, last))))


def _child_env() -> dict[str, str]:
    """A child's environment: this one, one BLAS thread unless it says otherwise, and this process's pid."""
    return {**CHILD_THREADS, **os.environ, PARENT: str(os.getpid())}


# The children kept for the next run: per (process, thread, interpreter, environment), one waiting for a request.
# A strike batch is tens of short runs (a tune strikes each candidate at 20 to 120 places): a child each cost 0.11 s
# of start per run, most of a Siconos candidate's time. A thread's own: Linux kills a child when the thread that
# started it ends (``child.die_with_parent``), and a forked process never uses its parent's.
_KEPT: dict[tuple, Child] = {}
_KEPT_LOCK = threading.Lock()


def _key(python: str) -> tuple:
    return os.getpid(), threading.get_ident(), python, tuple(sorted(_child_env().items()))


def kept(python: str, request: dict) -> tuple[Child, tuple]:
    """A child that has been sent ``request``: this thread's kept child for ``python`` (and this environment) when it
    is alive, else a new one; with its key, to give it back (``give_back``) once the request's end frame is read."""
    key = _key(python)
    with _KEPT_LOCK:
        child = _KEPT.pop(key, None)
    if child is not None:
        if child.proc.poll() is None and child.ask(request):
            return child, key
        child.close()  # died while it waited (its thread's end), or before this request: start another
    child = Child(python)
    child.ask(request)
    return child, key


def give_back(key: tuple, child: Child) -> None:
    """Keep ``child`` (its request answered) for this thread's next run."""
    child.answered()
    with _KEPT_LOCK:
        old = _KEPT.pop(key, None)
        _KEPT[key] = child
    if old is not None:
        old.close()


@atexit.register
def _close_kept() -> None:
    """Close this process's kept children (each exits 0 at the end of its stdin; killed, as any, if it lingers)."""
    with _KEPT_LOCK:
        children = [c for k, c in _KEPT.items() if k[0] == os.getpid()]
        _KEPT.clear()
    for child in children:
        try:
            child.proc.stdin.close()
            child.proc.wait(timeout=EXIT_GRACE)
        except (OSError, subprocess.TimeoutExpired):
            pass
        child.close()


def _request(scene: Scene, settings: SiconosSettings, steps: int, bare: bool = False) -> dict:
    return request(scene, dt=settings.dt, steps=steps, theta=settings.theta, solver=settings.solver,
                            tolerance=settings.tolerance, chunk=CHUNK, bare=bare)


def _python() -> str:
    got = interpreter()
    if not isinstance(got, Interpreter):
        raise SiconosFailure(got)
    return got.path


class SiconosEngine(EngineAdapter):
    """Siconos behind the engine contract (``base.EngineAdapter``): rigid Newton impacts, float64, ``dt`` the cost lever."""

    name = "siconos"
    package = "siconos"  # Debian's python3-siconos, for another interpreter: ``version`` asks it
    settings_type = SiconosSettings
    compliant = False
    precision = "float64"

    def samples(self, run: Recording) -> Iterator[Samples | None]:
        """Run the scene in one child (set up at its ready frame), yielding its frames as samples (the initial state
        first)."""
        scene, s = run.scene, run.settings
        req = _request(scene, s, run.n)
        ndof, walls = len(req["mass"]), scene.gap.walls
        width = 2 * ndof + len(walls)
        first = np.array([*req["q0"], *req["v0"], *np.zeros(len(walls))])[None, :]
        k = 0
        child, key = kept(_python(), req)
        answered = False
        try:
            for frame in read_frames(child.proc.stdout, width):
                if not len(frame):  # ready: the child's start is behind it
                    yield None
                    continue
                rows = np.vstack([first, frame]) if k == 0 else frame
                t = scene.initial.t + s.dt * np.arange(k, k + len(rows))
                k += len(rows)
                force = {w: rows[:, 2 * ndof + i] / s.dt for i, w in enumerate(walls)}
                if ndof == 1:
                    chunk = Samples(t, force, y=rows[:, 0], vy=rows[:, 1])
                else:
                    chunk = Samples(t, force, x1=rows[:, 0], x2=rows[:, 1], v1=rows[:, 2], v2=rows[:, 3])
                if (yield chunk) is False:
                    break
            else:  # the end frame: the child waits for the next request
                answered = True
        except ProtocolError as exc:
            raise child.failure(str(exc)) from None
        finally:  # a run cut short (a blow-up, an exception, a closed generator) leaves its child mid-answer: killed
            if answered:
                give_back(key, child)
            else:
                child.close()

    def record(self, scene: Scene, settings: SiconosSettings) -> dict:
        """The interpreter that runs Siconos."""
        got = interpreter()
        return {"python": got.path if isinstance(got, Interpreter) else ""}

    def version(self) -> str:
        """``siconos.version`` in the interpreter that runs it."""
        got = interpreter()
        return got.version if isinstance(got, Interpreter) else ""

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us, and theta (Siconos's 0.5 first, then fully implicit 1)."""
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5), "siconos.theta": (0.5, 1.0)}


def start_seconds(python: str | None = None, repeats: int = 3) -> float:
    """The fixed cost of a child [s]: a one-step run of the bouncing ball, start to exit, the best of ``repeats``."""
    from chatterbench.reference.scene import load_scene

    req = _request(load_scene("bouncing-ball"), SiconosSettings(dt=1e-3), 1)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        with Child(python or _python(), req) as child:
            list(read_frames(child.proc.stdout, 3))
        best = min(best, time.perf_counter() - t0)
    return best

