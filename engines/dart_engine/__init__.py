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
(the stepping loop, the wall forces from DART's contacts, the bare loop of the benchmark).

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

from chatterbench.reference.scene import Scene

from ..base import EngineAdapter, Recording
from ..trajectory import Trajectory
from . import run as _run
from .settings import BOUNCE_THRESHOLD, COLLISION_DETECTORS, LCP_SOLVERS, DartSettings, settings_snippet
from .world import DartWorld, build

__all__ = ["BOUNCE_THRESHOLD", "COLLISION_DETECTORS", "LCP_SOLVERS", "DartEngine", "DartSettings", "DartWorld",
           "build", "run", "settings_snippet"]


class DartEngine(EngineAdapter):
    """DART behind the engine contract (``base.EngineAdapter``): rigid impulses, float64, ``dt`` the cost lever."""

    name = "dart"
    package = "dartpy"
    settings_type = DartSettings
    compliant = False
    precision = "float64"

    def simulate(self, run: Recording) -> None:
        """Step the scene's world (``run.simulate``)."""
        _run.simulate(run)

    def bare_seconds(self, scene: Scene, settings: DartSettings, traj: Trajectory) -> float:
        """``World.step`` and the two joint reads, replaying the run's forces (``run.bare_seconds``)."""
        return _run.bare_seconds(scene, settings, traj)

    def snippet(self, scene: Scene, settings: DartSettings | None = None) -> str:
        """The dartpy calls these settings make, for the user's own world and shapes (``settings.settings_snippet``)."""
        return settings_snippet(settings or DartSettings(), scene.restitution)

    def record(self, scene: Scene, settings: DartSettings) -> dict:
        """DART's compiled-in rebound threshold [m/s], which no setting changes, beside the settings."""
        return {"bounce_threshold": BOUNCE_THRESHOLD}

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us; the LCP solver (Dantzig, DART's default, or PGS), the collision detector
        (FCL, DART's default, or DART's own) and split impulse. Defaults first."""
        base = DartSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5),
                "dart.lcp_solver": (base.lcp_solver, "pgs"),
                "dart.collision_detector": (base.collision_detector, "dart"),
                "dart.split_impulse": (base.split_impulse, True)}


def run(scene: Scene, settings: DartSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """``DartEngine().run``: one run, classified by the base (``base.EngineAdapter.run``)."""
    return DartEngine().run(scene, settings, compact_above)
