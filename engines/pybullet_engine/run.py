"""Stepping PyBullet: the adapter, its world (one ``p.DIRECT`` client per run) stepped by the base, contacts read where they act.

    >>> import numpy as np
    >>> from chatterbench.engines.pybullet_engine import PybulletEngine, PybulletSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = PybulletEngine().run(load_scene("bouncing-ball"), PybulletSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g)
    ('ok', 0.453)

The base owns the run (``stepping.py``: forces, samples, time); this adapter builds the world
(``world.build``) and steps it. Sample k is the state after k ``stepSimulation`` calls; the
contact force at sample k belongs to the step that ended there: a wall's force is PyBullet's
``appliedImpulse / dt`` summed over the wall's contact points (> 0: it pushed body 2). Each
step applies the forces the base hands over as external forces on the bodies that ever feel
one, and reads the contact points only where a wall can have pushed: the step starts with
body 2 within ``contact_processing_threshold`` of a wall and changes its momentum by more
than the force does.
"""

from __future__ import annotations

import math

from chatterbench.reference.scene import Scene

from ..api import EngineAdapter
from ..stepping import forces_on
from .bullet import p
from .settings import PybulletSettings, settings_snippet
from .world import PybulletWorld, build

# A step's velocity change of body 2 beyond what its forces give, above which the step is taken
# to have had a contact impulse and the contact points are read: relative to |v2| [1], plus an
# absolute floor [m/s]. Rounding in Bullet's v += F dt / m is about 1e-16 relative; an impulse
# below these moves v2 by less than 1e-12 |v2| + 1e-15 m/s and is reported as no contact.
IMPULSE_RELATIVE_TOLERANCE = 1e-12
IMPULSE_ABSOLUTE_TOLERANCE = 1e-15  # [m/s]
_ORIGIN = (0.0, 0.0, 0.0)
_LINK_FRAME = p.LINK_FRAME


class Stepped:
    """A world as its steps use it: the ids, which bodies feel forces, the band where a wall can push."""

    __slots__ = ("world", "cid", "b1", "b2", "l1", "on1", "on2", "lower", "upper", "band", "kick", "upper_wall")

    def __init__(self, world: PybulletWorld, scene: Scene, settings: PybulletSettings) -> None:
        self.world, self.cid, self.b1, self.b2, self.l1 = world, world.client, world.body1, world.body2, world.link1
        self.on1, self.on2 = forces_on(scene, settings.dt)
        self.lower = scene.gap.lower
        self.upper = scene.gap.upper if scene.gap.upper is not None else math.inf
        self.upper_wall = "upper" in world.walls
        # A contact enters the solver only if the step starts with the bodies within
        # contact_processing_threshold of a wall (collision detection runs on the positions the step
        # starts from); 1e-9 m more covers rounding in the sphere-box distance.
        self.band = settings.contact_processing_threshold + 1e-9
        # Bullet updates v2 += f2 dt / m2 plus the contact impulse: a velocity off that prediction by
        # more than rounding marks the steps worth a contact query.
        self.kick = settings.dt / scene.mass2

    def close(self) -> None:
        self.world.close()


class PybulletEngine(EngineAdapter):
    """PyBullet behind the engine contract (``base.EngineAdapter``): rigid impulses, float64, ``dt`` the cost lever."""

    name = "pybullet"
    package = "pybullet"
    settings_type = PybulletSettings
    bytes_per_step = 125.0  # measured 88 B/step (feigin-pair, compact, 4.0e6 -> 8.0e6 steps: 600,884 -> 944,880 KiB)
    exports = ("scene.py",)  # a complete PyBullet script
    export_kind = "a Python script"

    def build(self, scene: Scene, settings: PybulletSettings) -> Stepped:
        """The scene's world in its own client (``world.build``)."""
        return Stepped(build(scene, settings), scene, settings)

    def drive(self, w: Stepped, x1: float, v1: float, x1_end: float) -> None:
        """The prescribed body 1 (a heavy slider) set to its path's state at the step's start."""
        p.resetJointState(w.b1, 0, x1, v1, physicsClientId=w.cid)
        w.world.x1 = x1

    def step(self, w: Stepped, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        """``stepSimulation`` with the forces applied; the joints read; the walls' pushes where one can have pushed."""
        f1, f2 = forces
        world, cid = w.world, w.cid
        world.stepping = True  # until the state is read: a world left here is not kept (world.close)
        # pybullet's arguments by position (physicsClientId last): each call parses no keyword, 0.15 us a call
        if w.on1:
            p.applyExternalForce(w.b1, w.l1, (f1, 0.0, 0.0), _ORIGIN, _LINK_FRAME, cid)
        if w.on2:
            p.applyExternalForce(w.b2, 0, (f2, 0.0, 0.0), _ORIGIN, _LINK_FRAME, cid)
        y = world.x2 - world.x1
        near = y - w.lower <= w.band or w.upper - y <= w.band
        if near:
            w2 = world.v2 + (f2 if w.on2 else 0.0) * w.kick
        p.stepSimulation(cid)
        x1 = v1 = None
        if w.l1 >= 0:
            x1, v1, _, _ = p.getJointState(w.b1, 0, cid)
            world.x1 = x1
        x2, v2, _, _ = p.getJointState(w.b2, 0, cid)
        world.x2, world.v2, world.stepping = x2, v2, False
        if near and abs(v2 - w2) > IMPULSE_RELATIVE_TOLERANCE * abs(w2) + IMPULSE_ABSOLUTE_TOLERANCE:
            return (x1, v1, x2, v2), _pushes(p.getContactPoints(w.b1, w.b2, physicsClientId=cid), w.upper_wall)
        return (x1, v1, x2, v2), ()

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


def _pushes(points, upper_wall: bool) -> tuple[float, ...]:
    """The lower (and upper) wall's force [N] on body 2 in the step, from its contact points.

    Body 1 is bodyA: contactNormalOnB points from body 2 towards body 1. The lower wall lies on
    body 2's -x side, the upper wall on its +x side, so the normal's x sign names the wall; a
    point counts where the wall pushed during the step (normal force > 0).
    """
    lower = upper = 0.0
    for pt in points or ():
        if pt[9] > 0.0:
            if pt[7][0] < 0.0:
                lower += pt[9]
            elif upper_wall:
                upper += pt[9]
    return (lower, upper) if upper_wall else (lower,)
