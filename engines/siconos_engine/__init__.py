"""The Siconos adapter: a scene as Moreau-Jean time stepping with Newton's impact law, run in a child process.

    >>> from chatterbench.engines.siconos_engine import SiconosEngine, SiconosSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = SiconosEngine().run(load_scene("bouncing-ball", ["duration=0.6"]), SiconosSettings(dt=1e-4))
    >>> traj.status == "ok" or "apt-get install python3-siconos" in traj.message   # without Siconos: the install line
    True

Siconos (INRIA) is the reference time stepper of nonsmooth mechanics: the bodies are a
``LagrangianLinearTIDS``, each wall a ``LagrangianLinearTIR`` relation with
``NewtonImpactNSL(R)``, and every step of ``MoreauJeanOSI(theta)`` solves one LCP at the
velocity level, 0 <= g'+ + R g'- _|_ impulse >= 0 for the walls the step may reach. So every
impact gives R exactly, at any dt and any speed (no threshold, no compliance): like Feigin's
model, and unlike the engines, Siconos is expected to agree with the reference (the report's
"reference cross-check").

Siconos is not on the package index; Debian's ``python3-siconos`` serves ``/usr/bin/python3``.
The adapter runs it in a child process under an interpreter that has it (``run.py``: found
there, on PATH, or named by ``CHATTERBENCH_SICONOS_PYTHON``) over a small protocol
(``protocol.py``; the child is ``child.py``, which imports only numpy and Siconos). Modules:
``settings`` (``SiconosSettings``), ``protocol`` (the request and the reply), ``child`` (the
Siconos side), ``run`` (finding Siconos, the child, the samples, the bare loop).

Body 1 of infinite mass (fixed, or prescribed x1(t)) is no body in Siconos: the one dof is
y = x2 - x1, body 2 seen from body 1, with the inertial force -m2 x1''(t) (``protocol.py``).
"""

from __future__ import annotations

from chatterbench.reference.scene import Scene

from ..base import EngineAdapter, Recording
from ..trajectory import Trajectory
from . import run as _run
from .settings import SOLVERS, SiconosSettings

__all__ = ["SOLVERS", "SiconosEngine", "SiconosSettings", "run"]


class SiconosEngine(EngineAdapter):
    """Siconos behind the engine contract (``base.EngineAdapter``): rigid Newton impacts, float64, ``dt`` the cost lever."""

    name = "siconos"
    package = "siconos"  # Debian's python3-siconos, for another interpreter: ``version`` asks it
    settings_type = SiconosSettings
    compliant = False
    precision = "float64"

    def simulate(self, run: Recording) -> None:
        """Step the scene in one child process (``run.simulate``)."""
        _run.simulate(run)

    def bare_seconds(self, scene: Scene, settings: SiconosSettings, traj: Trajectory) -> float:
        """The child's stepping seconds with no samples sent back (``run.bare_seconds``)."""
        return _run.bare_seconds(scene, settings, traj)

    def record(self, scene: Scene, settings: SiconosSettings) -> dict:
        """The interpreter that runs Siconos."""
        got = _run.interpreter()
        return {"python": got.path if isinstance(got, _run.Interpreter) else ""}

    def version(self) -> str:
        """``siconos.version`` in the interpreter that runs it."""
        got = _run.interpreter()
        return got.version if isinstance(got, _run.Interpreter) else ""

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us, and theta (Siconos's 0.5 first, then fully implicit 1)."""
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5), "siconos.theta": (0.5, 1.0)}


def run(scene: Scene, settings: SiconosSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """``SiconosEngine().run``: one run, classified by the base (``base.EngineAdapter.run``)."""
    return SiconosEngine().run(scene, settings, compact_above)
