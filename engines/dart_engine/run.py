"""Stepping DART: the adapter, one world per run stepped by the base, wall forces read from the contacts.

    >>> import numpy as np
    >>> from chatterbench.engines.dart_engine import DartEngine, DartSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = DartEngine().run(load_scene("bouncing-ball", ["duration=0.6"]), DartSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g) + dt
    ('ok', 0.453)

The base owns the run (``stepping.py``: forces, samples, time); this adapter builds the world
(``world.build``) and steps it. Sample k is the state after k ``World.step`` calls. Each step
applies the forces the base hands over as joint forces, then DART integrates the velocities, detects collisions at the positions the step starts from,
solves the contact LCP (the impulses change the velocities) and integrates the positions.

Wall forces: DART stores each contact's impulse in its ``collision.Contact`` as a force,
``contact.force = normal * lambda / dt`` (``ContactConstraint::applyImpulse``), the force on
``collisionObject1`` in world coordinates; ``World.getLastCollisionResult()`` holds the step's
contacts. The force on body 2 along +x is ``force[0]`` when body 2's sphere is object 1 and
``-force[0]`` when it is object 2; the other object's shape node is named by its wall, and
the wall's force is that component pushing body 2 away from it (+x for the lower wall, -x for
the upper one). ``contact[wall][k]`` is True when that force was > 0 in step k: a contact
found but separating (lambda = 0) is no contact.

A prescribed body 1 (``drive``) is set to its path's position at each step's start and
commanded the mean velocity over the step, so that it ends the step on its path.
"""

from __future__ import annotations

from chatterbench.reference.scene import Scene

from ..api import EngineAdapter
from .settings import BOUNCE_THRESHOLD, DartSettings, settings_snippet
from .world import BALL, DartWorld, build


def _wall_forces(result, walls: tuple[str, ...]) -> tuple[float, ...]:
    """Per wall the force [N] the step's contacts pushed body 2 with (module docstring), summed over the wall's points."""
    out = dict.fromkeys(walls, 0.0)
    for c in result.getContacts():
        first = c.collisionObject1.getShapeFrame().getName()
        if first == BALL:
            fx, wall = float(c.force[0]), c.collisionObject2.getShapeFrame().getName()
        else:
            fx, wall = -float(c.force[0]), first
        out[wall] += fx if wall == "lower" else -fx
    return tuple(out.values())


class DartEngine(EngineAdapter):
    """DART behind the engine contract (``base.EngineAdapter``): rigid impulses, float64, ``dt`` the cost lever."""

    name = "dart"
    package = "dartpy"
    settings_type = DartSettings
    compliant = False
    precision = "float64"
    force_sum = "in order"  # this adapter's loop summed the force term by term before the base owned it

    def build(self, scene: Scene, settings: DartSettings) -> DartWorld:
        """The scene's own DART world (``world.build``)."""
        return build(scene, settings)

    def drive(self, w: DartWorld, x1: float, v1: float, x1_end: float) -> None:
        """Body 1's VELOCITY joint at its path's position, commanded the mean velocity over the step."""
        w.joint1.setPosition(0, x1)
        w.joint1.setCommand(0, (x1_end - x1) / w.dt)

    def step(self, w: DartWorld, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        """``World.step`` with the forces as joint forces; the joints read; the walls' forces where DART found a
        contact (module docstring)."""
        j1, j2 = w.joint1, w.joint2
        finite = w.body1 == "finite"
        if finite:
            j1.setForce(0, forces[0])
        j2.setForce(0, forces[1])
        w.world.step()
        x1 = v1 = None
        if finite:
            x1, v1 = j1.getPosition(0), j1.getVelocity(0)
        state = (x1, v1, j2.getPosition(0), j2.getVelocity(0))
        result = w.world.getLastCollisionResult()  # a copy of the step's result
        return state, (_wall_forces(result, w.walls) if result.getNumContacts() else ())

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
