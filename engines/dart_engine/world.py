"""The DART world of a scene: two skeletons on prismatic joints along x, the walls on body 1, a sphere for body 2.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.dart_engine.world import build, DartSettings
    >>> world = build(load_scene("feigin-pair"), DartSettings())
    >>> world.walls, world.body1, world.world.getCollisionDetector().getType()
    (('lower', 'upper'), 'finite', 'fcl')

Body 1 and body 2 are each a skeleton of one body node on a prismatic joint along world x
(the joint position is the body's x; no gravity, no friction, no damping, no joint limits).
Body 1 carries one wall box per gap limit, placed so that a wall's face meets the sphere of
body 2 exactly when y = x2 - x1 reaches ``gap.lower`` (and ``gap.upper``). The walls are
collision shapes, not joint limits: DART's joint limit constraint has no restitution (a
prismatic joint driven into its limit at 1 m/s stops dead, measured rebound 1e-9 m/s), so
only a contact between shapes can give Newton's R.

Restitution: DART's contact coefficient is the product of the two shapes' coefficients
(``ContactSurface``: restitutionCoeffA * restitutionCoeffB) and a shape's default is 0 (no
bounce at all); body 2's sphere carries the scene's R and every wall 1, so the product is R.

Body 1 of infinite mass: fixed, its skeleton is not mobile (``setMobile(False)``: DART gives it
no dynamics, exactly infinite mass); prescribed, its joint is a VELOCITY actuator (DART's
kinematic joint: the body follows the commanded velocity whatever the contact impulse,
exactly infinite mass too), set each step to the prescribed position and to the mean
prescribed velocity over the step (``run.DartEngine.drive``), so it ends each step exactly on its path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import dartpy as dart

from chatterbench.reference.scene import Scene

from .settings import DartSettings

# Geometry of the model [m]. Not physics: the bodies are 1-D, these sizes only keep each wall
# face larger than body 2 so that it always meets a face (a sphere on a face: one contact point).
BODY2_RADIUS = 0.05  # radius of body 2's sphere, its half extent along x
WALL_HALF = 0.05  # half thickness of each wall along x
WALL_SIDE = 0.2  # half extent of each wall across x
BALL = "body2"  # the shape node name of body 2's sphere; the walls' shape nodes are named by their wall

_DETECTORS = {"fcl": dart.collision.FCLCollisionDetector, "dart": dart.collision.DARTCollisionDetector,
              "bullet": dart.collision.BulletCollisionDetector, "ode": dart.collision.OdeCollisionDetector}


@dataclass
class DartWorld:
    """A built DART world for one scene (``world.step()`` advances it by ``settings.dt``)."""

    world: Any  # dartpy.simulation.World
    joint1: Any  # body 1's PrismaticJoint (its position is x1 [m])
    joint2: Any  # body 2's PrismaticJoint (its position is x2 [m])
    body1: str  # "finite", "fixed" (not mobile) or "prescribed" (kinematic VELOCITY joint)
    walls: tuple[str, ...]  # wall names, as in scene.gap.walls (also the walls' shape node names)
    dt: float  # [s] the world's time step


def _collider(body: Any, shape: Any, name: str, offset: float, restitution: float) -> None:
    """A frictionless collision shape on ``body`` at ``offset`` [m] along x with its restitution coefficient."""
    node = body.createShapeNode(shape)
    node.setName(name)
    node.setRelativeTranslation([offset, 0.0, 0.0])
    node.createCollisionAspect()
    node.createDynamicsAspect()
    node.getDynamicsAspect().setRestitutionCoeff(restitution)
    node.getDynamicsAspect().setFrictionCoeff(0.0)


def _slider(name: str, mass: float, x: float, v: float) -> tuple[Any, Any, Any]:
    """A skeleton of one body of ``mass`` [kg] on a prismatic joint along world x, at ``x`` [m] moving at ``v`` [m/s]."""
    skeleton = dart.dynamics.Skeleton(name)
    joint, body = skeleton.createPrismaticJointAndBodyNodePair()
    joint.setAxis([1.0, 0.0, 0.0])
    body.setMass(mass)
    joint.setPosition(0, x)
    joint.setVelocity(0, v)
    return skeleton, joint, body


def configure(world: Any, settings: DartSettings) -> None:
    """Apply ``settings`` to a DART world (what ``settings.settings_snippet`` shows a user)."""
    world.setTimeStep(settings.dt)
    world.setCollisionDetector(_DETECTORS[settings.collision_detector]())
    solver = world.getConstraintSolver()
    option = dart.constraint.PgsBoxedLcpSolverOption()
    option.mMaxIteration = settings.pgs_iterations
    pgs = solver.getSecondaryBoxedLcpSolver()  # DART's own PGS instance: Python cannot construct one
    pgs.setOption(option)
    if settings.lcp_solver == "pgs":
        solver.setSecondaryBoxedLcpSolver(None)  # first, or DART refuses a primary equal to the secondary
        solver.setBoxedLcpSolver(pgs)
    elif not settings.pgs_fallback:
        solver.setSecondaryBoxedLcpSolver(None)
    solver.setSplitImpulseEnabled(settings.split_impulse)


def build(scene: Scene, settings: DartSettings) -> DartWorld:
    """The DART world of ``scene`` (module docstring), its bodies at ``scene.initial``."""
    world = dart.simulation.World()
    world.setGravity([0.0, 0.0, 0.0])  # every scene force, gravity included, is applied by run.py each step
    configure(world, settings)
    ini, gap = scene.initial, scene.gap
    if not scene.body1_infinite:
        kind, mass1 = "finite", scene.mass1
    else:
        kind, mass1 = ("fixed" if scene.prescribed is None else "prescribed"), 1.0  # the mass is never used
    skeleton1, joint1, body1 = _slider("body1", mass1, ini.x1, ini.v1)
    # Wall boxes in body 1's frame: the lower wall's +x face at lower - BODY2_RADIUS meets body 2's -x side
    # (at x2 - BODY2_RADIUS) exactly when x2 - x1 = lower; the upper wall likewise on the other side.
    box = [2.0 * WALL_HALF, 2.0 * WALL_SIDE, 2.0 * WALL_SIDE]
    _collider(body1, dart.dynamics.BoxShape(box), "lower", gap.lower - BODY2_RADIUS - WALL_HALF, 1.0)
    if gap.upper is not None:
        _collider(body1, dart.dynamics.BoxShape(box), "upper", gap.upper + BODY2_RADIUS + WALL_HALF, 1.0)
    if kind == "fixed":
        skeleton1.setMobile(False)
    elif kind == "prescribed":
        joint1.setActuatorType(dart.dynamics.ActuatorType.VELOCITY)
    skeleton2, joint2, body2 = _slider("body2", scene.mass2, ini.x1 + ini.y, ini.v1 + ini.vy)
    _collider(body2, dart.dynamics.SphereShape(BODY2_RADIUS), BALL, 0.0, scene.restitution)
    world.addSkeleton(skeleton1)
    world.addSkeleton(skeleton2)
    return DartWorld(world=world, joint1=joint1, joint2=joint2, body1=kind, walls=gap.walls, dt=settings.dt)
