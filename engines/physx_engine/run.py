"""Stepping PhysX: one SAPIEN scene per run, forces applied every step, contacts read from PhysX's reports.

    >>> import numpy as np
    >>> from chatterbench.engines.physx_engine import PhysxSettings, run
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = run(load_scene("bouncing-ball", ["duration=0.5"]), PhysxSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g)
    ('ok', 0.451)

Sample k is the state after k ``PhysxCpuSystem.step`` calls; the contact flag and normal
force at sample k belong to the step that ended there: ``contact[wall][k]`` is True when that
wall pushed body 2 in that step, the force being PhysX's contact impulse / dt (its x part)
summed over the wall's contact points (a point below body 2's centre is the lower wall's).
Every scene force is applied with ``add_force_torque`` each step, from the state the step
starts with (the scene's force model as an affine map, ``reference.forces.ForceModel.body_forces``);
a prescribed body 1 is given its kinematic target, its prescribed position at the step's end.
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
import time
from typing import Callable

import numpy as np

from chatterbench.reference.scene import Scene

from ..base import Recording, force_plan, replayed_forces
from ..trajectory import Trajectory
from ..window import CHUNK
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


def _simulate(world: PhysxWorld, run: Recording) -> None:
    """Step ``world`` ``run.n`` times, handing the samples to ``run`` chunk by chunk and adding the stepping
    time to ``run.wall_time``; the loop keeps Python work per step small (forces planned per chunk, one
    ``pack`` read per step, contacts read only in steps that can have had an impulse)."""
    scene, dt, n = run.scene, run.settings.dt, run.n
    t0, init = scene.initial.t, scene.initial
    x1, v1 = float(init.x1), float(init.v1)
    x2, v2 = x1 + init.y, v1 + init.vy
    system, b1, b2 = world.system, world.body1, world.body2
    read, j1, j2 = _reader(world)
    moving1 = j1 is not None
    prescribed = scene.prescribed if world.kinematic else None
    f1 = np.zeros(3, np.float32)
    f2 = np.zeros(3, np.float32)
    torque = np.zeros(3, np.float32)
    gain = force_plan(scene, np.array([t0]))[2]
    g10, g11, g12, g13, g20, g21, g22, g23 = (float(v) for v in gain.ravel())
    dep = bool(np.any(gain != 0.0))
    step, pack, contacts_of, isfinite = system.step, system.pack, system.get_contacts, math.isfinite
    # PhysX makes a contact for a shape pair only within the two shapes' contact offsets (their sum) at the
    # step's start; 1e-6 m more covers float32 rounding. Outside that band no wall can push: contacts unread.
    band = 2.0 * (run.settings.contact_offset + run.settings.rest_offset) + 1e-6
    # Inside it, a step may still have no contact impulse: PhysX updates v2 += f2 dt / m2 (float32) plus the
    # impulse, so a velocity off that prediction by more than float32 rounding marks the steps worth a query.
    kick = dt / scene.mass2
    lower_y, upper_y = scene.gap.lower, scene.gap.upper if scene.gap.upper is not None else math.inf
    for k0 in range(0, n + 1, CHUNK):
        k1 = min(n, k0 + CHUNK)  # this chunk: steps k0 .. k1 - 1, samples k0 (known) .. k1
        c = k1 - k0
        times = t0 + dt * np.arange(k0, k1 + 1)
        time1, time2 = (part.tolist() for part in force_plan(scene, times[:-1])[:2])
        if prescribed is not None:
            px, pv = prescribed.position(times).tolist(), prescribed.velocity(times).tolist()
        cols = [[x1] * (c + 1), [v1] * (c + 1), [x2] * (c + 1), [v2] * (c + 1)]
        x1s, v1s, x2s, v2s = cols
        lower, upper = np.zeros(c + 1), np.zeros(c + 1)
        last = c
        start = time.perf_counter()
        for j in range(c):
            if prescribed is not None:
                x1, v1 = px[j], pv[j]
                b1.kinematic_target = sapien.Pose([px[j + 1], 0.0, 0.0])  # where it is at the step's end
            if moving1:
                f1[0] = time1[j] + (g10 * x1 + g11 * v1 + g12 * x2 + g13 * v2 if dep else 0.0)
                b1.add_force_torque(f1, torque)
            f2[0] = time2[j] + (g20 * x1 + g21 * v1 + g22 * x2 + g23 * v2 if dep else 0.0)
            b2.add_force_torque(f2, torque)
            y = x2 - x1
            near = y - lower_y <= band or upper_y - y <= band
            if near:
                w2 = v2 + float(f2[0]) * kick
            step()
            state = read(pack())
            if moving1:
                x1 = x1s[j + 1] = state[j1]
                v1 = v1s[j + 1] = state[j1 + 1]
            x2 = x2s[j + 1] = state[j2]
            v2 = v2s[j + 1] = state[j2 + 1]
            if near and abs(v2 - w2) > IMPULSE_RELATIVE_TOLERANCE * abs(w2) + IMPULSE_ABSOLUTE_TOLERANCE:
                contacts = contacts_of()
                if contacts:
                    lower[j + 1], upper[j + 1] = _contact_forces(contacts, x2, dt)
            if not (j & 1023 or isfinite(x1 + v1 + x2 + v2)):
                last = j + 1
                break
        if prescribed is not None:
            x1, v1 = px[c], pv[c]
        run.wall_time += time.perf_counter() - start
        first = 0 if k0 == 0 else 1  # a later chunk's sample 0 is the last one of the chunk before
        cut = slice(first, last + 1)
        force = {"lower": lower[cut], "upper": upper[cut]}
        body1 = {"x1": np.array(x1s[cut]), "v1": np.array(v1s[cut])} if moving1 else {}
        go_on = run.add(times[cut], {w: force[w] for w in world.walls}, x2=np.array(x2s[cut]), v2=np.array(v2s[cut]),
                        **body1)
        if not go_on or last < c or k1 == n:
            break


def simulate(run: Recording) -> None:
    """One run in its own SAPIEN scene (``world.build``, then ``_simulate``)."""
    _simulate(build(run.scene, run.settings), run)


def bare_seconds(scene: Scene, settings: PhysxSettings, traj: Trajectory) -> float:
    """Seconds of the bare engine loop over the adapter's run ``traj`` of ``scene``: n x (``add_force_torque`` on
    each driven body, the kinematic target of a prescribed body 1, ``step``, the state read as the run reads it), the forces
    replayed from the run's recorded states (the least any driver has to do), no contacts read, nothing recorded."""
    world = build(scene, settings)
    forces1, forces2 = (f.astype(np.float32) for f in replayed_forces(scene, traj))
    targets = None
    if world.kinematic:
        targets = [sapien.Pose([x, 0.0, 0.0]) for x in scene.prescribed.position(traj.t).tolist()]
    b1, b2, system = world.body1, world.body2, world.system
    moving1 = b1 is not None and not world.kinematic
    step, pack, read = system.step, system.pack, _reader(world)[0]
    pushes = [(np.array([a, 0.0, 0.0], np.float32), np.array([b, 0.0, 0.0], np.float32)) for a, b in zip(forces1, forces2)]
    torque = np.zeros(3, np.float32)
    start = time.perf_counter()
    for k in range(len(traj.t) - 1):
        if targets is not None:
            b1.kinematic_target = targets[k + 1]
        f1, f2 = pushes[k]
        if moving1:
            b1.add_force_torque(f1, torque)
        b2.add_force_torque(f2, torque)
        step()
        read(pack())
    return time.perf_counter() - start
