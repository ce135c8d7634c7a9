"""The PhysX adapter (SAPIEN 3.0.3, PhysX 5): a scene as two 1-D rigid bodies colliding with Newton restitution R.

    >>> from chatterbench.engines.physx_engine import PhysxEngine, PhysxSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = PhysxEngine().run(load_scene("bouncing-ball", ["duration=0.6"]), PhysxSettings(dt=1e-4))
    >>> round(float(traj.t[traj.contact["lower"].argmax()]), 4)  # first impact: sqrt(2/g) = 0.4515 s, within a step
    0.4514

PhysX resolves a contact with a velocity-level impulse (TGS, or PGS) and gives a bounce
Newton's restitution, the average of the two shapes' ``PhysxMaterial.restitution``, when
the relative normal speed is above the scene's ``bounce_threshold`` (PhysX's default 2 m/s;
below it the bounce is plastic). Modules: ``settings`` (``PhysxSettings``), ``world`` (the
SAPIEN scene: bodies locked to x, walls as shapes of body 1; SAPIEN's process-wide scene
settings), ``run`` (the stepping loop, contacts, the bare loop the benchmark compares with).

Promises:

- With the default ``PhysxSettings`` a single force-free impact gives Newton's law (1.3): the
  relative speed is scaled by -R within 1 % (see the tests), in float32.
- Each run builds its own scene with its own settings; runs with different settings follow
  one another in one process (``world.scene_config``).
"""

from __future__ import annotations

from chatterbench.reference.scene import Scene

from ..base import EngineAdapter, Recording
from ..trajectory import Trajectory
from . import run as _run
from .settings import PhysxSettings
from .world import PhysxWorld, build

__all__ = ["PhysxEngine", "PhysxSettings", "PhysxWorld", "build", "run"]


class PhysxEngine(EngineAdapter):
    """PhysX (through SAPIEN) behind the engine contract (``base.EngineAdapter``): rigid impulses, float32,
    ``dt`` the cost lever."""

    name = "physx"
    package = "sapien"
    settings_type = PhysxSettings
    compliant = False
    precision = "float32"

    def simulate(self, run: Recording) -> None:
        """Step the scene's world in its own SAPIEN scene (``run.simulate``)."""
        _run.simulate(run)

    def bare_seconds(self, scene: Scene, settings: PhysxSettings, traj: Trajectory) -> float:
        """``step`` and one state read per step, replaying the run's forces (``run.bare_seconds``)."""
        return _run.bare_seconds(scene, settings, traj)

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us; the bounce threshold (the adapter's, then PhysX's own 2 m/s and two between),
        TGS or PGS, and the solver iterations (the adapter's 1 / 1 first, then PhysX's 4 and SAPIEN's 10 position
        iterations). Defaults first."""
        base = PhysxSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5),
                "physx.bounce_threshold": (base.bounce_threshold, 0.01, 0.1, 2.0),
                "physx.enable_tgs": (base.enable_tgs, not base.enable_tgs),
                "physx.solver_position_iterations": (base.solver_position_iterations, 4, 10),
                "physx.solver_velocity_iterations": (base.solver_velocity_iterations, 4)}


def run(scene: Scene, settings: PhysxSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """``PhysxEngine().run``: one run, classified by the base (``base.EngineAdapter.run``)."""
    return PhysxEngine().run(scene, settings, compact_above)
