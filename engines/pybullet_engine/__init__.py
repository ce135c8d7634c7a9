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
model), ``run`` (the stepping loop, contacts, the bare loop the benchmark compares with).

Promises:

- With the default ``PybulletSettings`` a single impact gives Newton's law (1.3):
  the relative speed is scaled by -R (within 0.01, see the tests) and m1 v1 + m2 v2 is kept.
  The five PyBullet defaults that break this are overridden (see ``PybulletSettings``).
- Each run opens its own ``p.DIRECT`` connection in a context manager and closes it, so runs
  can follow one another (or run in different threads' processes) in one interpreter.
"""

from __future__ import annotations

from chatterbench.reference.scene import Scene

from ..base import EngineAdapter, Recording
from ..trajectory import Trajectory
from . import run as _run
from .bullet import p
from .settings import PybulletSettings, settings_snippet
from .world import PybulletWorld, build, connect

__all__ = ["PybulletEngine", "PybulletSettings", "PybulletWorld", "build", "connect", "run", "settings_snippet"]


class PybulletEngine(EngineAdapter):
    """PyBullet behind the engine contract (``base.EngineAdapter``): rigid impulses, float64, ``dt`` the cost lever."""

    name = "pybullet"
    package = "pybullet"
    settings_type = PybulletSettings
    bytes_per_step = 125.0  # measured 88 B/step (feigin-pair, compact, 4.0e6 -> 8.0e6 steps: 600,884 -> 944,880 KiB)
    exports = ("scene.py",)  # a complete PyBullet script
    export_kind = "a Python script"

    def simulate(self, run: Recording) -> None:
        """Step the scene's world in its own client (``run.simulate``)."""
        _run.simulate(run)

    def bare_seconds(self, scene: Scene, settings: PybulletSettings, traj: Trajectory) -> float:
        """``stepSimulation`` and the two joint reads, replaying the run's forces (``run.bare_seconds``)."""
        return _run.bare_seconds(scene, settings, traj)

    def build(self, scene: Scene, settings: PybulletSettings | None = None) -> PybulletWorld:
        """Build ``scene`` in a fresh DIRECT client that stays open; close it with ``p.disconnect``."""
        settings = settings or PybulletSettings()
        return build(scene, settings, p.connect(p.DIRECT))

    def snippet(self, scene: Scene, settings: PybulletSettings | None = None) -> str:
        """The PyBullet calls these settings make, for the user's own bodies (``settings.settings_snippet``)."""
        return settings_snippet(settings or PybulletSettings(), scene.restitution)

    def export(self, scene: Scene, settings: PybulletSettings, command: str | None = None) -> dict[str, str]:
        """``scene.py``: the scene built and stepped with PyBullet alone (``export.scene_script``)."""
        from .export import scene_script

        return {self.exports[0]: scene_script(scene, settings)}

    def measurement(self) -> str:
        """One impact's e measured in the user's PyBullet world (``settings.measurement``)."""
        from .settings import measurement

        return measurement()

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us; the restitution velocity threshold (0: none) and the solver iterations,
        PyBullet's default (50) and fewer. Defaults first."""
        base = PybulletSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5),
                "pybullet.restitution_velocity_threshold": (base.restitution_velocity_threshold, 0.01, 0.1),
                "pybullet.num_solver_iterations": (base.num_solver_iterations, 10)}


def run(scene: Scene, settings: PybulletSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """``PybulletEngine().run``: one run, classified by the base (``base.EngineAdapter.run``)."""
    return PybulletEngine().run(scene, settings, compact_above)
