"""PyBullet adapter: runs a ``Scene`` as two prismatic multibodies that collide with Newton restitution R.

    >>> from chatterbench.engines.pybullet_engine import PybulletEngine, PybulletSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = PybulletEngine().run(load_scene("bouncing-ball"), PybulletSettings(dt=1e-4))
    >>> round(float(traj.t[traj.contact["lower"].argmax()]), 4)      # first impact: sqrt(2/g) = 0.4515 s
    0.4516

The model is the smallest PyBullet world that is Feigin's system (1967, section 1): body 1
and body 2 each slide on one prismatic joint along world x, body 2 is a sphere and body 1
carries one wall box per gap limit (``world.py``). Modules: ``bullet`` (PyBullet, imported
once, quietly), ``settings`` (``PybulletSettings``, the paste-able calls), ``world`` (the
model), ``run`` (the adapter: one step, the contacts; the base runs the loop), ``export`` (the
scene as a script for PyBullet alone).

Promises:

- With the default ``PybulletSettings`` a single impact gives Newton's law (1.3):
  the relative speed is scaled by -R (within 0.01, see the tests) and m1 v1 + m2 v2 is kept.
  The five PyBullet defaults that break this are overridden (see ``PybulletSettings``).
- Each run opens its own ``p.DIRECT`` connection and closes it (the world's ``close``), so
  runs can follow one another (or run in different threads' processes) in one interpreter.
"""

from __future__ import annotations

from .run import PybulletEngine
from .settings import PybulletSettings, settings_snippet
from .world import PybulletWorld, build

__all__ = ["PybulletEngine", "PybulletSettings", "PybulletWorld", "build", "settings_snippet"]
