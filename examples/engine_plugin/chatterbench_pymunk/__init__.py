"""pymunk (Chipmunk 2D) as a chatterbench engine: two bodies on the x axis, the walls segments on body 1.

    >>> from chatterbench.engines import make_settings, run_engine
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = run_engine("pymunk", load_scene("bouncing-ball"), make_settings("pymunk", dt=1e-3))
    >>> traj.status, round(float(traj.t[traj.contact["lower"].argmax()]), 2)   # first impact: sqrt(2 / g) = 0.45 s
    ('ok', 0.45)

What an engine writes (chatterbench's ``docs/how-to/plugin.md`` says the rest), all of it
imported from ``chatterbench.engines.api``: a frozen settings dataclass with a checked ``dt``
(``check_dt``), and an ``EngineAdapter`` subclass that names itself, its package and its
settings and writes ``build`` (the scene as the engine's world, at the scene's initial state),
``step`` (one step under the forces the base hands over: the state after it, and what each
wall pushed body 2 with) and ``drive`` (a prescribed body 1); its ``tuning_space`` is the
optional ``TuningSpace`` capability. chatterbench's base applies the scene's forces, records
the samples, times the run, classifies failures and runs the benchmark. ``pyproject.toml``
declares the adapter in the entry-point group ``chatterbench.engines``; ``python -m pytest
--chatterbench-engine pymunk``, in any folder, runs chatterbench's contract suite against it.

The model: body 2 a circle of radius ``RADIUS`` whose centre is x2, body 1 a body at x1 carrying
one vertical segment per wall, placed so that the circle touches the lower segment exactly when
y = x2 - x1 = ``gap.lower`` (and the upper one at ``gap.upper``). No gravity (the scene's forces,
gravity included, come from the base each step), no friction, no rotation (infinite moments).
Chipmunk's restitution is the product of the two shapes' elasticities: the walls carry 1, the
circle R. An infinite body 1 is a static body (at rest) or a kinematic one (prescribed). A wall's
force is the arbiter's impulse over the step [N]. ``rest_velocity`` makes impacts slower than it
plastic (as many engines' restitution thresholds do): the ball stops bouncing early.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from chatterbench.engines.api import EngineAdapter, check_dt, check_integer, check_number

RADIUS = 0.05  # [m] body 2's circle; not physics, the gap is measured from its surface


@dataclass(frozen=True)
class PymunkSettings:
    """pymunk's settings, checked when made (``--set pymunk.rest_velocity=0.5``)."""

    dt: float = 1e-3  # [s] the step, > 0
    iterations: int = 10  # Chipmunk's solver iterations per step, >= 1 (pymunk's default)
    rest_velocity: float = 0.0  # [m/s] impacts slower than this do not bounce, >= 0 (0: every impact gives R)

    def __post_init__(self) -> None:
        check_dt("pymunk", self.dt)
        check_integer("pymunk.iterations", self.iterations, lo=1)
        check_number("pymunk.rest_velocity", self.rest_velocity, lo=0.0, unit=" [m/s]")


class World:
    """One run's pymunk space, its two bodies, the walls' segments by name, and what ``step`` needs."""

    def __init__(self, scene, settings: PymunkSettings) -> None:
        ini, gap = scene.initial, scene.gap
        self.space = pymunk.Space()  # no gravity: the base applies every scene force
        self.space.iterations = settings.iterations
        self.space.collision_slop = 0.0  # Chipmunk's default lets shapes overlap by 0.1 m unpushed
        self.finite = not scene.body1_infinite
        if self.finite:
            self.body1 = pymunk.Body(scene.mass1, math.inf)
        else:
            self.body1 = pymunk.Body(body_type=pymunk.Body.STATIC if scene.prescribed is None else pymunk.Body.KINEMATIC)
        self.body1.position, self.body1.velocity = (ini.x1, 0.0), (ini.v1, 0.0)
        self.walls = {}  # segment -> wall name
        for wall, x in (("lower", gap.lower - RADIUS), ("upper", None if gap.upper is None else gap.upper + RADIUS)):
            if x is not None:
                segment = pymunk.Segment(self.body1, (x, -1.0), (x, 1.0), 0.0)
                segment.elasticity = 1.0
                self.walls[segment] = wall
        self.body2 = pymunk.Body(scene.mass2, math.inf)
        self.body2.position, self.body2.velocity = (ini.x1 + ini.y, 0.0), (ini.v1 + ini.vy, 0.0)
        self.ball = pymunk.Circle(self.body2, RADIUS)
        self.ball.elasticity = self.restitution = scene.restitution
        self.space.add(self.body1, *self.walls, self.body2, self.ball)
        self.dt, self.rest_velocity, self.order = settings.dt, settings.rest_velocity, gap.walls


class PymunkEngine(EngineAdapter):
    """pymunk behind chatterbench's engine contract: rigid impulses, float64, ``dt`` the cost lever."""

    name = "pymunk"  # the entry point's name
    package = "pymunk"  # the distribution whose version is reported
    settings_type = PymunkSettings

    def build(self, scene, settings: PymunkSettings) -> World:
        return World(scene, settings)

    def drive(self, world: World, x1: float, v1: float, x1_end: float) -> None:
        # a kinematic body moves at its velocity: from x1 now to x1_end at the step's end
        world.body1.position = (x1, 0.0)
        world.body1.velocity = ((x1_end - x1) / world.dt, 0.0)

    def step(self, world: World, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        f1, f2 = forces
        if world.finite:
            world.body1.force = (f1, 0.0)
        world.body2.force = (f2, 0.0)
        if world.rest_velocity:
            slow = abs(world.body2.velocity.x - world.body1.velocity.x) < world.rest_velocity
            world.ball.elasticity = 0.0 if slow else world.restitution
        world.space.step(world.dt)
        x1, v1 = (world.body1.position.x, world.body1.velocity.x) if world.finite else (None, None)
        state = (x1, v1, world.body2.position.x, world.body2.velocity.x)
        arbiters = []
        world.body2.each_arbiter(arbiters.append)
        if not arbiters:
            return state, ()
        push = dict.fromkeys(world.order, 0.0)  # per wall, in the scene's order
        for arbiter in arbiters:
            for shape in arbiter.shapes:
                if shape in world.walls:
                    push[world.walls[shape]] += abs(arbiter.total_impulse.x) / world.dt
        return state, tuple(push.values())

    def tuning_space(self, scene) -> dict[str, tuple]:
        """What ``chatterbench tune`` searches (``api.TuningSpace``): dt [s] from coarse to fine, then each setting's
        values in its own unit, defaults first."""
        return {"dt": (1e-3, 3e-4, 1e-4), "pymunk.iterations": (10, 30), "pymunk.rest_velocity": (0.0, 0.1)}
