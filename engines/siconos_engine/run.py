"""Running Siconos: find an interpreter that has it, start ``child.py`` under it, turn its frames into samples.

    >>> from chatterbench.engines.siconos_engine.run import ENV, unavailable
    >>> ENV
    'CHATTERBENCH_SICONOS_PYTHON'
    >>> isinstance(unavailable(), str)          # "" when an interpreter with siconos is found, else why not
    True

Siconos is not on the package index: Debian's ``python3-siconos`` serves the system Python
(``/usr/bin/python3``), not a venv or pyenv interpreter. So each run starts one child process,
``child.py`` under an interpreter that can ``import siconos.kernel``: the one named by the
environment variable ``CHATTERBENCH_SICONOS_PYTHON`` (when it is set, only that one), else
``/usr/bin/python3``, else the first ``python3`` on PATH that has Siconos (``interpreter``).
The request and the reply are ``protocol.py``'s. A child costs a fixed start (the interpreter,
numpy and Siconos's import: 0.08 to 0.27 s measured, README) on top of its steps.

Promises: a child that exits non-zero, dies of a signal or sends what is not the protocol
raises ``SiconosFailure`` with one line saying which (its last stderr line), and the base
makes it the run's ``error`` status (``crashed`` for a signal: ``SiconosCrash``) with the
samples before it; a run cut short by the base (a blow-up) or by an exception kills its
child. Sample k is the state after k steps; the contact force of a wall at sample k is the
LCP's impulse of that step over dt [N] (> 0: the wall pushed).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from chatterbench.reference.scene import Scene

from ..base import Crashed, Recording
from ..trajectory import Trajectory
from ..window import CHUNK
from .protocol import ProtocolError, read_frames, request
from .settings import SiconosSettings

ENV = "CHATTERBENCH_SICONOS_PYTHON"  # a python that can import siconos.kernel (overrides the search)
INSTALL = (f"apt-get install python3-siconos (Debian/Ubuntu: for /usr/bin/python3), or set {ENV} to a python that "
           "can import siconos.kernel")
CHILD = Path(__file__).with_name("child.py")
PARENT = "CHATTERBENCH_SICONOS_PARENT"  # the child's check that its parent is alive (``child.die_with_parent``)
PROBE_TIMEOUT = 60.0  # [s] for ``python -c "import siconos.kernel"`` (a cold disk cache: a few seconds)
_PROBE = "import numpy, siconos, siconos.kernel; print(siconos.version)"


class SiconosFailure(RuntimeError):
    """The child failed: a non-zero exit, a signal, or a reply that is not the protocol; the message says which."""


class SiconosCrash(SiconosFailure, Crashed):
    """The child died of a signal (a segfault, the out-of-memory killer): the run is ``crashed``, not ``error``."""


@dataclasses.dataclass(frozen=True)
class Interpreter:
    """A python that can import Siconos."""

    path: str  # the executable
    version: str  # ``siconos.version`` there


@functools.cache
def _probe(python: str) -> Interpreter | str:
    """``python``'s Siconos, or why it has none (cached per path: a probe starts an interpreter)."""
    try:
        out = subprocess.run([python, "-c", _PROBE], capture_output=True, text=True, timeout=PROBE_TIMEOUT)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"{python}: {type(exc).__name__}: {exc}"
    if out.returncode != 0:
        lines = out.stderr.strip().splitlines()
        return f"{python}: {lines[-1] if lines else f'exit code {out.returncode}'}"
    return Interpreter(python, out.stdout.strip())


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
    """One ``child.py`` process under ``python`` answering ``request``; a context manager that kills it on exit."""

    def __init__(self, python: str, request: dict) -> None:
        self.stderr = tempfile.TemporaryFile()
        self.proc = subprocess.Popen([python, str(CHILD)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.stderr, env={**os.environ, PARENT: str(os.getpid())})
        try:
            self.proc.stdin.write(json.dumps(request).encode())
            self.proc.stdin.close()
        except BrokenPipeError:  # it died before reading: its exit code says why
            pass

    def __enter__(self) -> "Child":
        return self

    def __exit__(self, *exc) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self.proc.stdout.close()
        self.stderr.close()

    def failure(self, why: str = "") -> SiconosFailure:
        """What went wrong, in one line: the exit (code or signal) and the child's last stderr line."""
        code = self.proc.wait()
        self.stderr.seek(0)
        lines = self.stderr.read().decode(errors="replace").strip().splitlines()
        last = lines[-1] if lines else ""
        if code < 0:
            try:
                exit_ = f"killed by {signal.Signals(-code).name}"
            except ValueError:
                exit_ = f"killed by signal {-code}"
        else:
            exit_ = f"exited with code {code}"
        kind = SiconosCrash if code < 0 else SiconosFailure
        return kind("; ".join(filter(None, (f"the Siconos child {exit_}", why, last))))


def _request(scene: Scene, settings: SiconosSettings, steps: int, bare: bool = False) -> dict:
    return request(scene, dt=settings.dt, steps=steps, theta=settings.theta, solver=settings.solver,
                            tolerance=settings.tolerance, chunk=CHUNK, bare=bare)


def _python() -> str:
    got = interpreter()
    if not isinstance(got, Interpreter):
        raise SiconosFailure(got)
    return got.path


def simulate(run: Recording) -> None:
    """Run the scene in one child, handing the samples to ``run`` frame by frame (the initial state first)."""
    scene, s = run.scene, run.settings
    req = _request(scene, s, run.n)
    ndof, walls = len(req["mass"]), scene.gap.walls
    width = 2 * ndof + len(walls)
    first = np.array([*req["q0"], *req["v0"], *np.zeros(len(walls))])[None, :]
    start = time.perf_counter()
    k, seconds = 0, None
    with Child(_python(), req) as child:
        try:
            for frame in read_frames(child.proc.stdout, width):
                if isinstance(frame, float):
                    seconds = frame
                    break
                rows = np.vstack([first, frame]) if k == 0 else frame
                t = scene.initial.t + s.dt * np.arange(k, k + len(rows))
                k += len(rows)
                force = {w: rows[:, 2 * ndof + i] / s.dt for i, w in enumerate(walls)}
                if ndof == 1:
                    go_on = run.add(t, force, y=rows[:, 0], vy=rows[:, 1])
                else:
                    go_on = run.add(t, force, x1=rows[:, 0], x2=rows[:, 1], v1=rows[:, 2], v2=rows[:, 3])
                if not go_on:
                    break
        except ProtocolError as exc:
            raise child.failure(str(exc)) from None
        if seconds is not None and child.proc.wait() != 0:
            raise child.failure()
    run.wall_time += seconds if seconds is not None else time.perf_counter() - start


def bare_seconds(scene: Scene, settings: SiconosSettings, traj: Trajectory) -> float:
    """The child's own stepping seconds over the run ``traj`` with no samples sent back (``bare``)."""
    req = _request(scene, settings, len(traj.t) - 1, bare=True)
    with Child(_python(), req) as child:
        try:
            frames = list(read_frames(child.proc.stdout, 0))
        except ProtocolError as exc:
            raise child.failure(str(exc)) from None
        if child.proc.wait() != 0:
            raise child.failure()
    return float(frames[-1])


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

