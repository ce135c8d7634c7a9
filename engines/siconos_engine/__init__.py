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
Siconos side), ``run`` (the adapter: finding Siconos, a whole run in the child under the run's
time limit, the samples, the bare loop).

Body 1 of infinite mass (fixed, or prescribed x1(t)) is no body in Siconos: the one dof is
y = x2 - x1, body 2 seen from body 1, with the inertial force -m2 x1''(t) (``protocol.py``).
"""

from __future__ import annotations

from .run import SiconosEngine
from .settings import SOLVERS, SiconosSettings

__all__ = ["SOLVERS", "SiconosEngine", "SiconosSettings"]
