"""Newton adapters (``pip install ".[newton]"``): two engines, ``newton_xpbd`` and ``newton_semi``, one per contact family.

    >>> from chatterbench.engines.newton_engine import NewtonSemiEngine, SemiSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = NewtonSemiEngine().run(load_scene("bouncing-ball", ["duration=0.5"]), SemiSettings(dt=1e-3, device="cpu"))
    >>> traj.status, round(traj.contact_frequency)                # w0 = w0_dt / dt
    ('ok', 30)

Newton (1.8, on NVIDIA Warp) has several solvers. Two of them are contact families this project
has not had, and they are two engines here, not one engine with a ``solver`` setting: their
settings share nothing but ``dt`` and the device (XPBD: iterations, relaxation, a restitution
pass with its threshold; semi-implicit: a penalty spring's ke and kd), one is rigid and the
other compliant (the contract's ``compliant`` fact and ``contact_scales`` are per class), and in
the tables, charts and tune frontiers each is its own row with its own reasons. (Newton's
MuJoCo solver is MuJoCo Warp, which ``mujoco_warp`` already runs.)

- ``newton_xpbd``: ``SolverXPBD(model, enable_restitution=True)``. Contacts are position
  constraints; after them a velocity pass sets each contact's normal speed to -R times its
  approach speed, R the mean of the two shapes' restitution (both carry the scene's R). Only
  approach speeds above 2 |g| dt get it (g the model's gravity): slower impacts are plastic.
- ``newton_semi``: ``SolverSemiImplicit``, symplectic Euler with a penalty contact: ke d plus kd
  times the approach speed, damped only while compressing; kd is set from R exactly for that
  law (``penalty.py``), ke from the contact frequency ``w0_dt / dt``.

Modules: ``settings`` (the two settings dataclasses), ``penalty`` (the penalty law's R, ke, kd
and time scale), ``world`` (the model, the captured step, the kernels' loading), ``run`` (the
adapters), ``export`` (the scene as a script for Newton alone). Both step in float32, on cuda
where warp finds a GPU and on warp's CPU device otherwise; each step is one launch of a warp
graph captured when the world is built. The first run on a machine compiles Newton's kernels,
forward only (``world.modules``; measured with an empty warp cache on this 2-core machine, quiet, by
``python -m chatterbench.engines.warm newton_xpbd newton_semi`` (``engines/warm.py``): 16.7 s for XPBD with the
collision pipeline, then 3.0 s more for semi-implicit; ``world.load_kernels`` alone: 9.7 s for semi-implicit on
its own; from the cache 0.1 s), one process at a time (a lock on warp's cache: others wait, then load), before the
run's clock starts: the record's ``warmup_s`` and ``kernels``.
A prescribed body 1 is a kinematic link put on its path before each step (``drive``).
"""

from __future__ import annotations

from .run import NewtonSemiEngine, NewtonXpbdEngine
from .settings import DEVICES, SemiSettings, XpbdSettings

__all__ = ["DEVICES", "NewtonSemiEngine", "NewtonXpbdEngine", "SemiSettings", "XpbdSettings"]
