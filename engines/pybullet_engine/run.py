"""Stepping PyBullet: one ``p.DIRECT`` client per run, forces applied every step, contacts read where they act.

    >>> import numpy as np
    >>> from chatterbench.engines.pybullet_engine import PybulletSettings, run
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = run(load_scene("bouncing-ball"), PybulletSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g)
    ('ok', 0.453)

Sample k is the state after k ``stepSimulation`` calls; the contact flag and normal force
at sample k belong to the step that ended there: ``contact[wall][k]`` is True when that wall
pushed body 2 in that step (PyBullet normal force > 0), the force being PyBullet's
``appliedImpulse / dt`` summed over the wall's contact points. Every scene force is applied
as an external force each step, from the state the step starts with (the scene's force
model as an affine map, ``reference.forces.ForceModel.body_forces``). The samples go to the
run's ``base.Recording`` a chunk of ``window.CHUNK`` steps at a time, so a long run comes back
compact and never holds more than a chunk of Python floats; the base classifies the run.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from chatterbench.reference.scene import Scene

from ..base import Recording, force_plan, replayed_forces
from ..trajectory import Trajectory
from ..window import CHUNK
from .bullet import p
from .settings import PybulletSettings
from .world import PybulletWorld, build, connect


# A step's velocity change of body 2 beyond what its forces give, above which the step is taken
# to have had a contact impulse and the contact points are read: relative to |v2| [1], plus an
# absolute floor [m/s]. Rounding in Bullet's v += F dt / m is about 1e-16 relative; an impulse
# below these moves v2 by less than 1e-12 |v2| + 1e-15 m/s and is reported as no contact.
IMPULSE_RELATIVE_TOLERANCE = 1e-12
IMPULSE_ABSOLUTE_TOLERANCE = 1e-15  # [m/s]


@dataclass(frozen=True)
class _ForcePlan:
    """Scene forces as (time part per step) + (matrix @ state): exact, since every term is affine.

    ``time1[k]``, ``time2[k]`` [N] are the forces on body 1 and body 2 at the start of step k
    with the state set to zero; ``gain`` (2 x 4) maps the state (x1, v1, x2, v2) to the rest.
    """

    time1: np.ndarray  # shape (n,), [N]
    time2: np.ndarray  # shape (n,), [N]
    gain: np.ndarray  # shape (2, 4), [N/m, N s/m]
    on1: bool  # body 1 ever feels a force
    on2: bool  # body 2 ever feels a force
    state_dependent: bool  # gain is not zero


def _force_plan(scene: Scene, t: np.ndarray) -> _ForcePlan:
    """The scene's force model as the affine map the loop applies (``ForceModel.body_forces``)."""
    time1, time2, gain = force_plan(scene, t)
    return _ForcePlan(
        time1=time1,
        time2=time2,
        gain=gain,
        on1=bool(np.any(time1 != 0.0) or np.any(gain[0] != 0.0)),
        on2=bool(np.any(time2 != 0.0) or np.any(gain[1] != 0.0)),
        state_dependent=bool(np.any(gain != 0.0)),
    )


def _force_flags(scene: Scene, t0: float, dt: float, n: int) -> tuple[bool, bool, bool]:
    """``_ForcePlan``'s on1, on2 and state_dependent over the whole run, planned chunk by chunk."""
    on1 = on2 = dep = False
    for k0 in range(0, max(n, 1), CHUNK):
        plan = _force_plan(scene, t0 + dt * np.arange(k0, min(n, k0 + CHUNK)))
        on1, on2, dep = on1 or plan.on1, on2 or plan.on2, dep or plan.state_dependent
    return on1, on2, dep


def _simulate(world: PybulletWorld, run: Recording) -> None:
    """Step ``world`` ``run.n`` times, handing the samples to ``run`` chunk by chunk and adding the stepping
    time to ``run.wall_time``; PyBullet's own error is raised once the samples before it are recorded.

    The loop is the cost the benchmark measures, so it keeps Python work per step small:
    forces come from a plan precomputed per chunk from the scene's force model (time part as a
    list, state part as eight gains), states go into preallocated lists, the finiteness check
    runs every 1024 steps, and contact points are read only for steps that start near a wall and
    change body 2's momentum by more than the forces do (so the wall pushed). Between chunks
    (``window.CHUNK`` steps) the samples become arrays, contacts become flags and forces, and
    the recording keeps what it keeps: the memory of a run does not grow with its length.
    """
    scene, settings, n = run.scene, run.settings, run.n
    cid = world.client
    dt = settings.dt
    t0 = scene.initial.t
    init = scene.initial
    x1, v1 = float(init.x1), float(init.v1)
    x2, v2 = x1 + init.y, v1 + init.vy

    b1, b2, l1 = world.body1, world.body2, world.link1
    lower = scene.gap.lower
    upper = scene.gap.upper if scene.gap.upper is not None else math.inf
    # A contact enters the solver only if the step starts with the bodies within
    # contact_processing_threshold of a wall (collision detection runs on the positions the
    # step starts from); 1e-9 m more covers rounding in the sphere-box distance. Outside that band
    # getContactPoints would return nothing the solver used, so it is skipped.
    band = settings.contact_processing_threshold + 1e-9
    # Near a wall a step may still have no contact impulse (a chattering body spends about
    # half its steps just apart). Bullet updates v2 += f2 dt / m2 plus the contact impulse, so a
    # velocity off that prediction by more than rounding marks the steps worth a query.
    kick = dt / scene.mass2
    rel_tol = IMPULSE_RELATIVE_TOLERANCE
    prescribed = scene.prescribed if scene.body1_infinite else None
    on1, on2, dep = _force_flags(scene, t0, dt, n)
    gain = _force_plan(scene, t0 + dt * np.arange(1)).gain  # the state part does not depend on time
    g10, g11, g12, g13, g20, g21, g22, g23 = (float(v) for v in gain.ravel())
    moving1 = l1 >= 0

    step = p.stepSimulation
    joint = p.getJointState
    push = p.applyExternalForce
    points = p.getContactPoints
    reset = p.resetJointState
    frame = p.LINK_FRAME
    origin = (0.0, 0.0, 0.0)
    isfinite = math.isfinite
    failure: Exception | None = None
    k = 0
    for k0 in range(0, n + 1, CHUNK):
        k1 = min(n, k0 + CHUNK)  # this chunk: steps k0 .. k1 - 1, samples k0 (known) .. k1
        c = k1 - k0
        times = t0 + dt * np.arange(k0, k1 + 1)
        plan = _force_plan(scene, times[:-1])
        time1, time2 = plan.time1.tolist(), plan.time2.tolist()
        if prescribed is not None:
            px, pv = prescribed.position(times[:-1]).tolist(), prescribed.velocity(times[:-1]).tolist()
        x1s, v1s, x2s, v2s = [x1] * (c + 1), [v1] * (c + 1), [x2] * (c + 1), [v2] * (c + 1)
        contacts: list[tuple[int, tuple]] = []  # (position in the chunk, getContactPoints result), only near walls
        last = c  # the chunk's last position with a sample
        stop = False
        start = time.perf_counter()
        try:
            for j in range(c):
                k = k0 + j
                if prescribed is not None:
                    x1 = px[j]
                    v1 = pv[j]
                    reset(b1, 0, x1, v1, physicsClientId=cid)
                if on1:
                    f = time1[j]
                    if dep:
                        f += g10 * x1 + g11 * v1 + g12 * x2 + g13 * v2
                    push(b1, l1, (f, 0.0, 0.0), origin, frame, physicsClientId=cid)
                f2 = 0.0
                if on2:
                    f2 = time2[j]
                    if dep:
                        f2 += g20 * x1 + g21 * v1 + g22 * x2 + g23 * v2
                    push(b2, 0, (f2, 0.0, 0.0), origin, frame, physicsClientId=cid)
                y = x2 - x1
                near = y - lower <= band or upper - y <= band
                if near:
                    w2 = v2 + f2 * kick
                step(physicsClientId=cid)
                if moving1:
                    x1, v1, _, _ = joint(b1, 0, physicsClientId=cid)
                    x1s[j + 1] = x1
                    v1s[j + 1] = v1
                x2, v2, _, _ = joint(b2, 0, physicsClientId=cid)
                x2s[j + 1] = x2
                v2s[j + 1] = v2
                if near and abs(v2 - w2) > rel_tol * abs(w2) + IMPULSE_ABSOLUTE_TOLERANCE:
                    contacts.append((j + 1, points(b1, b2, physicsClientId=cid)))
                if not k & 1023 and not isfinite(x1 + v1 + x2 + v2):
                    last, stop = j + 1, True
                    break
        except p.error as exc:
            failure, last, stop = exc, k - k0, True
        run.wall_time += time.perf_counter() - start
        if not _record(world, run, k0, times, (x1s, v1s, x2s, v2s), contacts, last) or stop or k1 == n:
            break
    if failure is not None:
        raise failure


def _record(world: PybulletWorld, run: Recording, k0: int, times: np.ndarray, states: tuple, contacts: list,
            last: int) -> bool:
    """Hand positions 0 (for the first chunk; later ones start at 1) .. ``last`` of a chunk to ``run``, the wall
    forces from the contact points read; whether to go on (the base cuts at a blow-up)."""
    first = 0 if k0 == 0 else 1
    cols = [np.array(col[first:last + 1]) for col in states]
    m = len(cols[0])
    force = {w: np.zeros(m) for w in world.walls}
    # Body 1 is bodyA: contactNormalOnB points from body 2 towards body 1. The lower wall lies
    # on body 2's -x side, the upper wall on its +x side, so the normal's x sign names the wall.
    for j, pts in contacts:
        i = j - first
        if i >= m:
            break
        for pt in pts or ():
            wall = "lower" if pt[7][0] < 0.0 else "upper"
            if wall in force and pt[9] > 0.0:  # the wall pushed during the step
                force[wall][i] += pt[9]
    body1 = {"x1": cols[0], "v1": cols[1]} if world.link1 >= 0 else {}  # a static body 1: the base fills it in
    return run.add(times[first:first + m], force, x2=cols[2], v2=cols[3], **body1)


def simulate(run: Recording) -> None:
    """One run in its own ``p.DIRECT`` client (``world.build``, then ``_simulate``)."""
    with connect() as cid:
        _simulate(build(run.scene, run.settings, cid), run)


def _raw_loop(scene: Scene, settings: PybulletSettings, world: PybulletWorld, forces: tuple[list, list], n: int) -> float:
    """Seconds for the bare engine loop: n x (stepSimulation + the two getJointState reads).

    The bodies still have to be driven, or the engine steps a world at rest (much cheaper
    than the real one); so the loop also applies ``forces`` (per-step lists, computed
    beforehand) and the prescribed motion, the least any driver has to do.
    """
    cid, b1, b2, l1 = world.client, world.body1, world.body2, world.link1
    step, joint, push, reset = p.stepSimulation, p.getJointState, p.applyExternalForce, p.resetJointState
    frame, origin = p.LINK_FRAME, (0.0, 0.0, 0.0)
    f1, f2 = forces
    plan = _force_plan(scene, scene.initial.t + settings.dt * np.arange(n + 1))
    on1, on2 = plan.on1, plan.on2
    pr = scene.prescribed if scene.body1_infinite else None
    if pr is not None:
        tt = scene.initial.t + settings.dt * np.arange(n + 1)
        px, pv = pr.position(tt).tolist(), pr.velocity(tt).tolist()
    start = time.perf_counter()
    for k in range(n):
        if pr is not None:
            reset(b1, 0, px[k], pv[k], physicsClientId=cid)
        if on1:
            push(b1, l1, (f1[k], 0.0, 0.0), origin, frame, physicsClientId=cid)
        if on2:
            push(b2, 0, (f2[k], 0.0, 0.0), origin, frame, physicsClientId=cid)
        step(physicsClientId=cid)
        if l1 >= 0:
            joint(b1, l1, physicsClientId=cid)
        joint(b2, 0, physicsClientId=cid)
    return time.perf_counter() - start


def bare_seconds(scene: Scene, settings: PybulletSettings, traj: Trajectory) -> float:
    """Seconds of the bare engine loop (``_raw_loop``) over the adapter's run ``traj`` of ``scene``.

    Both loops step the same trajectory: the raw loop replays the forces the adapter applied
    (recomputed from its recorded states, bit for bit), so the two differ only by the
    adapter's own work (force evaluation, recording, contact queries).
    """
    f1, f2 = replayed_forces(scene, traj)  # summed as the adapter loop sums them: identical
    with connect() as cid:
        return _raw_loop(scene, settings, build(scene, settings, cid), (f1.tolist(), f2.tolist()), len(traj.t) - 1)
