"""DART adapter: runs a ``Scene`` as two prismatic skeletons whose shapes collide through DART's LCP with Newton's R.

    >>> from chatterbench.engines.dart_engine import DartEngine, DartSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = DartEngine().run(load_scene("bouncing-ball", ["duration=0.6"]), DartSettings(dt=1e-4))
    >>> traj.status, round(float(traj.t[traj.contact["lower"].argmax()]), 4)      # first impact: sqrt(2/g) = 0.4515 s
    ('ok', 0.4516)

DART (dartpy 6.20, the Dynamic Animation and Robotics Toolkit) is a rigid-impulse engine:
each step it finds the contacts at the positions the step starts from and solves one boxed
LCP (Dantzig, PGS as the fallback) for the contact impulses, with Newton's restitution as
the target normal velocity (-R times the approach speed). Modules: ``settings``
(``DartSettings``, DART's defaults beside the adapter's, the constants DART fixes at compile
time), ``world`` (the model: walls as collision shapes on body 1, a sphere for body 2), ``run``
(the adapter: one step, the wall forces from DART's contacts; the base runs the loop).

Promises:

- With the default ``DartSettings`` a single impact whose rebound R v_in exceeds DART's fixed
  0.1 m/s gives Newton's law (1.3): e = R - (1 + R) 1e-5 (DART's constraint force mixing) and
  m1 v1 + m2 v2 kept; a slower rebound is dropped (e = 0) whatever the settings, since that
  threshold is compiled into DART (``settings``). On the bouncing ball the 6th rebound is
  dropped and the ball rests before the Zeno point: ``compare bouncing-ball --engines dart``
  is ``early`` (README, "DART's fixed threshold").
- Each run builds its own ``dartpy.simulation.World``, which nothing else holds: runs can
  follow one another in one interpreter.
"""

from __future__ import annotations

from .run import DartEngine
from .settings import BOUNCE_THRESHOLD, COLLISION_DETECTORS, LCP_SOLVERS, DartSettings, settings_snippet
from .world import DartWorld, build

__all__ = ["BOUNCE_THRESHOLD", "COLLISION_DETECTORS", "LCP_SOLVERS", "DartEngine", "DartSettings", "DartWorld",
           "build", "settings_snippet"]
