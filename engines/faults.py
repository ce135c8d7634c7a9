"""Test-only fault injection: make an engine run crash, hang or raise on purpose.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.faults import planned_fault
    >>> import os
    >>> os.environ["CHATTERBENCH_FAULT"] = "raise:mujoco:restitution=0.3"
    >>> planned_fault("mujoco", load_scene("bouncing-ball", ["restitution=0.3"]))
    'raise'
    >>> planned_fault("mujoco", load_scene("bouncing-ball")), planned_fault("pybullet", load_scene("bouncing-ball", ["restitution=0.3"]))
    ('', '')
    >>> del os.environ["CHATTERBENCH_FAULT"]

Read only from the environment variable ``CHATTERBENCH_FAULT`` (never from the engine
settings or the command line, so no user can set it by mistake; processes started by a
sweep's pool inherit it). Its value is rules separated by ``;``, each
``FAULT[:ENGINE[:KEY=VALUE]]``: FAULT one of ``segfault`` (SIGSEGV in the process running
the engine), ``hang`` (sleeps forever), ``raise`` (``InjectedFault``); ENGINE an engine name
or ``*``; KEY=VALUE a scene field by its dotted key (``restitution=0.3``,
``initial.vy=0.1``) that the run's scene must have (numbers compared to 1e-12 relative).
The first rule that matches a run is injected as the engine starts, inside the adapter's
run (``base.EngineAdapter.finish``: a ``raise`` is then the engine's failure, classified
``error`` where every engine failure is), and before a batch (``registry.run_engine_batch``:
the whole batch fails). The tests use it to prove that compare,
report, gate and sweeps survive a run that dies, never returns or raises, and classify it
while keeping every other result.
"""

from __future__ import annotations

import ctypes
import math
import os
import time
from typing import Any

from chatterbench.reference.scene import Scene
from chatterbench.reference.tables import flatten

ENV = "CHATTERBENCH_FAULT"
FAULTS = ("segfault", "hang", "raise")


class InjectedFault(RuntimeError):
    """The exception raised by the ``raise`` fault."""


def _same(have: Any, want: str) -> bool:
    try:
        return math.isclose(float(have), float(want), rel_tol=1e-12, abs_tol=0.0)
    except (TypeError, ValueError):
        return str(have) == want


def planned_fault(engine: str, scene: Scene) -> str:
    """The fault ``CHATTERBENCH_FAULT`` plans for this run, or ``""`` (module docstring)."""
    text = os.environ.get(ENV, "")
    fields = None
    for rule in filter(None, (r.strip() for r in text.split(";"))):
        fault, _, rest = rule.partition(":")
        who, _, condition = rest.partition(":")
        if fault not in FAULTS or (who not in ("", "*", engine)):
            continue
        if condition:
            key, _, want = condition.partition("=")
            fields = fields if fields is not None else flatten(scene.to_dict(), lists=True)
            if key.strip() not in fields or not _same(fields[key.strip()], want.strip()):
                continue
        return fault
    return ""


def inject(fault: str) -> None:
    """Do what ``fault`` says: nothing (""), a segmentation fault, an endless sleep, or an exception."""
    if fault == "segfault":
        ctypes.string_at(0)  # reads address 0: SIGSEGV in this process
    elif fault == "hang":
        while True:
            time.sleep(3600)
    elif fault == "raise":
        raise InjectedFault(f"fault injected by {ENV} (raise)")


def inject_planned(engine: str, scene: Scene) -> None:
    """Inject whatever ``CHATTERBENCH_FAULT`` plans for this run (usually nothing)."""
    inject(planned_fault(engine, scene))
