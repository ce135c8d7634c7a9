"""The PhysX world of a scene (SAPIEN 3): body 2 a sphere, body 1 the walls, both locked to motion along x.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.physx_engine.world import build, PhysxSettings
    >>> world = build(load_scene("feigin-pair"), PhysxSettings())
    >>> world.walls, world.body1 is not None, world.kinematic
    (('lower', 'upper'), True, False)

One SAPIEN ``Scene`` with a ``PhysxCpuSystem`` and no renderer, no gravity (every scene force
is applied by the run), no friction, no damping. Body 2 is a dynamic sphere whose linear y,
z and angular axes are locked (``set_locked_motion_axes``), so it moves along world x only.
Body 1 carries one wall box per gap limit, placed so that they touch body 2 exactly when
y = x2 - x1 reaches ``gap.lower`` (and ``gap.upper``): a dynamic body locked the same way
when its mass is finite, a static actor when it is infinite and at rest (exactly infinite
mass), a kinematic body moved to its prescribed position every step when it is prescribed.

SAPIEN's scene settings are process-wide and read once, when a ``PhysxCpuSystem`` is made
(``sapien.physx.set_scene_config``): ``scene_config`` sets this run's, makes the system and
puts the previous settings back, so runs with different settings follow one another in one
process, each keeping its own (a system made at bounce threshold 2.0 m/s still makes a 1 m/s
impact plastic after another is made at 1e-3 m/s and stepped beside it; ``tests/engines/test_physx.py``).

Restitution: PhysX combines the two shapes' restitutions by averaging them (``PhysxMaterial``
has no combine mode in SAPIEN 3), so both body 2 and the walls carry the scene's R.
"""

from __future__ import annotations

import contextlib
import warnings
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from chatterbench.reference.scene import Scene

from .settings import PhysxSettings


def _import_quietly():
    """Import sapien without its ``Failed to find system libvulkan`` warning (the renderer is never used)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import sapien
        import sapien.physx

    return sapien


sapien = _import_quietly()
physx = sapien.physx

# Geometry of the model [m], as in the PyBullet adapter: not physics, the wall faces only have
# to be larger than body 2 so that it always meets a face.
BODY2_HALF = 0.05  # radius of body 2, its half extent along x
WALL_HALF = 0.05  # half thickness of each wall along x
WALL_SIDE = 0.2  # half extent of each wall across x
ONLY_X = [False, True, True, True, True, True]  # locked linear y, z and all angular axes


@dataclass
class PhysxWorld:
    """A built PhysX world for one scene; it lives as long as this object."""

    scene: Any  # sapien.Scene (keeps the system and its bodies alive)
    system: Any  # its sapien.physx.PhysxCpuSystem
    body1: Any  # body 1's rigid component: dynamic, kinematic, or None for a static body 1
    body2: Any  # body 2's PhysxRigidDynamicComponent
    kinematic: bool  # body 1 is prescribed (a kinematic body moved every step)
    walls: tuple[str, ...]  # wall names, as in scene.gap.walls


@contextlib.contextmanager
def scene_config(settings: PhysxSettings) -> Iterator[None]:
    """Make SAPIEN's process-wide scene settings ``settings.scene_config()`` (no gravity) inside, the previous ones after."""
    saved = physx.get_scene_config()
    physx.set_scene_config(gravity=np.zeros(3, np.float32), **settings.scene_config())
    try:
        yield
    finally:
        physx.set_scene_config(saved)


def _configure(obj: Any, values: dict[str, Any]) -> None:
    for key, value in values.items():
        setattr(obj, key, value)


def _body(component: Any, shapes: list[tuple[Any, float]], settings: PhysxSettings, x: float) -> Any:
    """An entity at x holding ``component`` with ``shapes`` (shape, offset along x [m])."""
    for shape, offset in shapes:
        shape.local_pose = sapien.Pose([offset, 0.0, 0.0])
        _configure(shape, settings.shape_config())
        component.attach(shape)
    entity = sapien.Entity()
    entity.add_component(component)
    entity.set_pose(sapien.Pose([x, 0.0, 0.0]))
    return entity


def _set_up(body: Any, mass: float, settings: PhysxSettings, v: float) -> None:
    """A dynamic body in the scene: its mass, the 1-D lock, the body settings and its velocity [m/s]."""
    body.set_locked_motion_axes(ONLY_X)
    body.mass = mass
    _configure(body, settings.body_config())
    body.linear_velocity = np.array([v, 0.0, 0.0], np.float32)


def build(scene: Scene, settings: PhysxSettings) -> PhysxWorld:
    """The world of ``scene`` at ``scene.initial`` (module docstring)."""
    with scene_config(settings):
        system = physx.PhysxCpuSystem()
    world = sapien.Scene([system])
    system.timestep = settings.dt
    material = physx.PhysxMaterial(0.0, 0.0, scene.restitution)  # static, dynamic friction, restitution
    init = scene.initial
    # Wall boxes in body 1's frame: the lower wall's +x face sits at lower - BODY2_HALF - 2 rest_offset, so it
    # meets body 2 (its -x side at x2 - BODY2_HALF, each shape's rest offset counting) when x2 - x1 = lower.
    back = 2.0 * settings.rest_offset
    walls = [(physx.PhysxCollisionShapeBox(np.array([WALL_HALF, WALL_SIDE, WALL_SIDE], np.float32), material),
              scene.gap.lower - BODY2_HALF - WALL_HALF - back)]
    if scene.gap.upper is not None:
        walls.append((physx.PhysxCollisionShapeBox(np.array([WALL_HALF, WALL_SIDE, WALL_SIDE], np.float32), material),
                      scene.gap.upper + BODY2_HALF + WALL_HALF + back))
    fixed = scene.body1_infinite and scene.prescribed is None
    kinematic = scene.body1_infinite and scene.prescribed is not None
    body1 = physx.PhysxRigidStaticComponent() if fixed else physx.PhysxRigidDynamicComponent()
    world.add_entity(_body(body1, walls, settings, init.x1))
    if kinematic:
        body1.kinematic = True  # infinite mass, moved to its prescribed position each step
    elif not fixed:
        _set_up(body1, scene.mass1, settings, init.v1)
    body2 = physx.PhysxRigidDynamicComponent()
    world.add_entity(_body(body2, [(physx.PhysxCollisionShapeSphere(BODY2_HALF, material), 0.0)], settings,
                           init.x1 + init.y))
    _set_up(body2, scene.mass2, settings, init.v1 + init.vy)
    return PhysxWorld(scene=world, system=system, body1=None if fixed else body1, body2=body2, kinematic=kinematic,
                      walls=scene.gap.walls)
