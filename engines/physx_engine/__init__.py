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
settings), ``run`` (the adapter: one step, the state read, the contacts; the base runs the loop).

Promises:

- With the default ``PhysxSettings`` a single force-free impact gives Newton's law (1.3): the
  relative speed is scaled by -R within 1 % (see the tests), in float32.
- Each run builds its own scene with its own settings; runs with different settings follow
  one another in one process (``world.scene_config``).
"""

from __future__ import annotations

from .run import PhysxEngine
from .settings import PhysxSettings
from .world import PhysxWorld, build

__all__ = ["PhysxEngine", "PhysxSettings", "PhysxWorld", "build"]
