"""Stepping PhysX: the adapter, one SAPIEN scene per run stepped by the base, contacts read from PhysX's reports.

    >>> import numpy as np
    >>> from chatterbench.engines.physx_engine import PhysxEngine, PhysxSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = PhysxEngine().run(load_scene("bouncing-ball", ["duration=0.5"]), PhysxSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g)
    ('ok', 0.451)

The base owns the run (``stepping.py``: forces, samples, time); this adapter builds the world
(``world.build``) and steps it. Sample k is the state after k ``PhysxCpuSystem.step`` calls; the contact flag and normal
force at sample k belong to the step that ended there: ``contact[wall][k]`` is True when that
wall pushed body 2 in that step, the force being PhysX's contact impulse / dt (its x part)
summed over the wall's contact points (a point below body 2's centre is the lower wall's).
The forces the base hands over are applied with ``add_force_torque`` each step; a prescribed
body 1 is given its kinematic target, its prescribed position at the step's end (``drive``).
The states are read in one ``PhysxCpuSystem.pack`` per step (13 float32 per dynamic body:
quaternion, position, linear and angular velocity; the layout is checked against the bodies'
own getters when the world is built), and the contacts only in steps that start with body 2
within the contact offsets of a wall (PhysX makes no contact farther away) and change its
velocity by more than its force does (an impulse under 4 float32 ulps of v2 counts as none:
measured, flags at 8 of feigin-pair's 40,213 samples at dt = 1e-3, forces under 5e-4 N).
PhysX steps in float32: the timestep itself is float32(dt) (relative 5e-8 off dt = 1e-3:
2e-6 s over the 40 s feigin-pair run).
"""

from __future__ import annotations

import math
import struct
from typing import Callable

import numpy as np

from chatterbench.reference.scene import Scene

from ..api import EngineAdapter
from .settings import PhysxSettings
from .world import PhysxWorld, build, sapien

# A step's change of v2 beyond what its force gives, above which the step is taken to have had a contact
# impulse and the contacts are read: relative to |v2| [1] (4 float32 ulps), plus an absolute floor [m/s].
IMPULSE_RELATIVE_TOLERANCE = 4.0 * 2.0**-23
IMPULSE_ABSOLUTE_TOLERANCE = 1e-12  # [m/s]
PACKED = 13  # float32 per dynamic body in PhysxCpuSystem.pack(): quaternion (4), position (3), velocities (3 + 3)
POSITION, VELOCITY = 4, 7  # offsets of x and of x' in a body's block


def _offsets(world: PhysxWorld) -> tuple[int | None, int]:
    """Where body 1's (None: not dynamic) and body 2's blocks start in ``pack()``, checked against their getters."""
    comps = list(world.system.rigid_dynamic_components)
    packed = np.frombuffer(world.system.pack(), np.float32)
    found = []
    for body in (None if world.kinematic else world.body1, world.body2):
        if body is None:
            found.append(None)
            continue
        i = PACKED * comps.index(body)
        if not (packed[i + POSITION] == body.entity_pose.p[0] and packed[i + VELOCITY] == body.linear_velocity[0]):
            raise RuntimeError("physx: PhysxCpuSystem.pack() has not the layout this adapter reads (SAPIEN changed?)")
        found.append(i)
    return found[0], found[1]


def _reader(world: PhysxWorld) -> tuple[Callable[[bytes], tuple[float, ...]], int | None, int]:
    """``read(system.pack())``: (x, x') of the dynamic bodies as Python floats, and where body 1's x (None: not
    dynamic) and body 2's x are in what it returns."""
    i1, i2 = _offsets(world)
    blocks = sorted(i for i in (i1, i2) if i is not None)
    fmt, at = "<", 0
    for off in (i + o for i in blocks for o in (POSITION, VELOCITY)):
        fmt += "x" * (4 * (off - at)) + "f"
        at = off + 1
    where = {i: 2 * blocks.index(i) for i in blocks}
    return struct.Struct(fmt).unpack_from, (None if i1 is None else where[i1]), where[i2]


def _contact_forces(contacts: list, x2: float, dt: float) -> tuple[float, float]:
    """The lower and upper walls' normal forces [N] on body 2 in the step just taken (impulse / dt)."""
    lower = upper = 0.0
    for contact in contacts:
        for point in contact.points:
            push = abs(float(point.impulse[0])) / dt
            if point.position[0] < x2:
                lower += push
            else:
                upper += push
    return lower, upper


class Stepped:
    """A world as its steps use it: the state reader, the force buffers, the band where a wall can push."""

    __slots__ = ("world", "system", "b1", "b2", "read", "j1", "j2", "f1", "f2", "torque", "lower", "upper", "band",
                 "kick", "dt", "x1", "x2", "v2", "upper_wall")

    def __init__(self, world: PhysxWorld, scene: Scene, settings: PhysxSettings) -> None:
        self.world, self.system, self.b1, self.b2 = world, world.system, world.body1, world.body2
        self.read, self.j1, self.j2 = _reader(world)
        self.f1, self.f2, self.torque = (np.zeros(3, np.float32) for _ in range(3))
        self.lower = scene.gap.lower
        self.upper = scene.gap.upper if scene.gap.upper is not None else math.inf
        self.upper_wall = "upper" in world.walls
        # PhysX makes a contact for a shape pair only within the two shapes' contact offsets (their sum) at the
        # step's start; 1e-6 m more covers float32 rounding. Outside that band no wall can push: contacts unread.
        self.band = 2.0 * (settings.contact_offset + settings.rest_offset) + 1e-6
        # Inside it, a step may still have no contact impulse: PhysX updates v2 += f2 dt / m2 (float32) plus the
        # impulse, so a velocity off that prediction by more than float32 rounding marks the steps worth a query.
        self.kick, self.dt = settings.dt / scene.mass2, settings.dt
        ini = scene.initial
        self.x1, self.x2, self.v2 = float(ini.x1), float(ini.x1) + ini.y, float(ini.v1) + ini.vy


class PhysxEngine(EngineAdapter):
    """PhysX (through SAPIEN) behind the engine contract (``base.EngineAdapter``): rigid impulses, float32,
    ``dt`` the cost lever."""

    name = "physx"
    package = "sapien"
    settings_type = PhysxSettings
    compliant = False
    precision = "float32"

    def build(self, scene: Scene, settings: PhysxSettings) -> Stepped:
        """The scene's own SAPIEN scene (``world.build``)."""
        return Stepped(build(scene, settings), scene, settings)

    def drive(self, w: Stepped, x1: float, v1: float, x1_end: float) -> None:
        """The kinematic body 1's target: where its path is at the step's end."""
        w.b1.kinematic_target = sapien.Pose([x1_end, 0.0, 0.0])
        w.x1 = x1

    def step(self, w: Stepped, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        """``PhysxCpuSystem.step`` with the forces applied; the state in one ``pack`` read; the walls' impulses where
        one can have pushed (module docstring)."""
        if w.j1 is not None:
            w.f1[0] = forces[0]
            w.b1.add_force_torque(w.f1, w.torque)
        w.f2[0] = forces[1]
        w.b2.add_force_torque(w.f2, w.torque)
        y = w.x2 - w.x1
        near = y - w.lower <= w.band or w.upper - y <= w.band
        if near:
            v = w.v2 + float(w.f2[0]) * w.kick
        w.system.step()
        state = w.read(w.system.pack())
        x1 = v1 = None
        if w.j1 is not None:
            x1 = w.x1 = state[w.j1]
            v1 = state[w.j1 + 1]
        x2 = w.x2 = state[w.j2]
        v2 = w.v2 = state[w.j2 + 1]
        if near and abs(v2 - v) > IMPULSE_RELATIVE_TOLERANCE * abs(v) + IMPULSE_ABSOLUTE_TOLERANCE:
            contacts = w.system.get_contacts()
            if contacts:
                lower, upper = _contact_forces(contacts, x2, w.dt)
                return (x1, v1, x2, v2), ((lower, upper) if w.upper_wall else (lower,))
        return (x1, v1, x2, v2), ()

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
