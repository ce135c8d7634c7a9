"""How an engine run ended: the ``Status`` enum with one message table, the failures an adapter raises to say which.

    >>> from chatterbench.engines.status import Status
    >>> Status.DIVERGED == "diverged", Status("crashed").message
    (True, 'the process running the engine died (a signal, or out of memory)')

A run never raises for what its engine does: ``base.EngineAdapter.finish`` catches it and the
trajectory says how the run ended (``Status``, scipy's ``OdeResult.status`` and MuJoCo's
``minimize.Status`` + ``_STATUS_MESSAGE`` habit). An adapter raises ``Diverged``, ``Crashed`` or
``TimedOut`` for what its engine reports itself; any other exception is ``error``.
``failed_trajectory`` is the result of a run that failed before its first step.
"""

from __future__ import annotations

import enum
from typing import Any

import numpy as np

from chatterbench.reference.scene import Scene

from .trajectory import Trajectory


class Status(enum.StrEnum):
    """How a run ended; compares equal to its string (``Status.OK == "ok"``), ``message`` says what it means."""

    OK = "ok"
    ERROR = "error"
    DIVERGED = "diverged"
    TIMEOUT = "timeout"
    CRASHED = "crashed"

    @property
    def message(self) -> str:
        """What the status means (``STATUS_MESSAGE``)."""
        return STATUS_MESSAGE[self]

    def __repr__(self) -> str:
        return repr(self.value)  # shown as the string it equals, in tuples, lists and tables


STATUS_MESSAGE = {
    Status.OK: "the run reached the end of the scene",
    Status.ERROR: "the engine raised, refused the model or stopped short; the samples before are kept",
    Status.DIVERGED: "a state or force became non-finite or huge; the samples before it are kept",
    Status.TIMEOUT: "the run passed its wall-clock limit and was stopped (an isolated run, or the engine's own child)",
    Status.CRASHED: "the process running the engine died (a signal, or out of memory)",
}


class Diverged(RuntimeError):
    """Raised by an adapter (``step`` or ``samples``) when its engine itself reports a blow-up (MuJoCo's warnings):
    the run is ``diverged``."""


class Crashed(RuntimeError):
    """Raised by an adapter when the process running its engine died (a child of the adapter killed by a signal, as
    Siconos's): the run is ``crashed``, as an isolated run whose own process dies."""


class TimedOut(RuntimeError):
    """Raised by an adapter when it stopped its engine at the run's time limit (``isolate.run_limit``: a child
    process of the adapter killed, as Siconos's): the run is ``timeout``, as an isolated run past its limit."""


def failed_trajectory(engine: str, scene: Scene, status: str, message: str, settings: dict[str, Any] | None = None,
                      wall_time: float = 0.0) -> Trajectory:
    """The trajectory of a run that failed before its first step: the initial state as its one sample."""
    ini = scene.initial
    one = lambda v: np.array([float(v)])  # noqa: E731
    walls = scene.gap.walls
    return Trajectory(
        engine=engine, t=one(ini.t), x1=one(ini.x1), x2=one(ini.x1 + ini.y), v1=one(ini.v1), v2=one(ini.v1 + ini.vy),
        contact={w: np.zeros(1, bool) for w in walls}, normal_force={w: np.zeros(1) for w in walls},
        wall_time=wall_time, settings=dict(settings or {}), status=Status(status), message=message,
    )
