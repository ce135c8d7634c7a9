"""Stepping DART: one world per run, every scene force applied each step, wall forces read from the contacts.

    >>> import numpy as np
    >>> from chatterbench.engines.dart_engine import DartSettings, run
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = run(load_scene("bouncing-ball", ["duration=0.6"]), DartSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g) + dt
    ('ok', 0.453)

Sample k is the state after k ``World.step`` calls. Each step applies the scene's forces as
joint forces computed from the state the step starts with (the scene's force model as an
affine map, ``reference.forces.ForceModel.body_forces``, as the PyBullet adapter does), then
DART integrates the velocities, detects collisions at the positions the step starts from,
solves the contact LCP (the impulses change the velocities) and integrates the positions.

Wall forces: DART stores each contact's impulse in its ``collision.Contact`` as a force,
``contact.force = normal * lambda / dt`` (``ContactConstraint::applyImpulse``), the force on
``collisionObject1`` in world coordinates; ``World.getLastCollisionResult()`` holds the step's
contacts. The force on body 2 along +x is ``force[0]`` when body 2's sphere is object 1 and
``-force[0]`` when it is object 2; the other object's shape node is named by its wall, and
the wall's force is that component pushing body 2 away from it (+x for the lower wall, -x for
the upper one). ``contact[wall][k]`` is True when that force was > 0 in step k: a contact
found but separating (lambda = 0) is no contact.
"""

from __future__ import annotations

import math
import time

import numpy as np

from chatterbench.reference.scene import Scene

from ..base import Recording, force_plan
from ..trajectory import Trajectory
from ..window import CHUNK
from .settings import DartSettings
from .world import BALL, DartWorld, build

FINITE_CHECK_EVERY = 1024  # [steps] how often the loop checks the state is finite (the base cuts at the first bad sample)


def _wall_forces(result, walls: tuple[str, ...]) -> dict[str, float]:
    """Per wall the force [N] the step's contacts pushed body 2 with (module docstring), summed over the wall's points."""
    out = dict.fromkeys(walls, 0.0)
    for c in result.getContacts():
        first = c.collisionObject1.getShapeFrame().getName()
        if first == BALL:
            fx, wall = float(c.force[0]), c.collisionObject2.getShapeFrame().getName()
        else:
            fx, wall = -float(c.force[0]), first
        out[wall] += fx if wall == "lower" else -fx
    return out


def _prescribed(scene: Scene, t: np.ndarray, dt: float) -> tuple[list[float], list[float], list[float]]:
    """Body 1's prescribed position [m] and velocity [m/s] at the step starts ``t``, and its mean velocity [m/s] over
    each step (the joint's command: the body then ends each step on its path)."""
    pr = scene.prescribed
    x = pr.position(np.append(t, t[-1] + dt))
    return x[:-1].tolist(), pr.velocity(t).tolist(), (np.diff(x) / dt).tolist()


def _simulate(w: DartWorld, run: Recording) -> None:
    """Step ``w`` ``run.n`` times, handing the samples to ``run`` chunk by chunk (``window.CHUNK`` steps) and adding
    the stepping time to ``run.wall_time``. The loop is the cost the benchmark measures: forces come as per-chunk
    lists and eight gains, the contacts are read only in steps where DART found one."""
    scene, dt, n = run.scene, run.settings.dt, run.n
    world, j1, j2, walls = w.world, w.joint1, w.joint2, w.walls
    gain = force_plan(scene, np.array([scene.initial.t]))[2]
    g10, g11, g12, g13, g20, g21, g22, g23 = (float(g) for g in gain.ravel())
    finite, prescribed = w.body1 == "finite", w.body1 == "prescribed"
    ini = scene.initial
    x1, v1, x2, v2 = float(ini.x1), float(ini.v1), float(ini.x1 + ini.y), float(ini.v1 + ini.vy)
    step, contacts = world.step, world.getLastCollisionResult  # a copy of the step's result each call
    for k0 in range(0, n, CHUNK):
        c = min(n, k0 + CHUNK) - k0
        starts = ini.t + dt * np.arange(k0, k0 + c)
        time1, time2 = (part.tolist() for part in force_plan(scene, starts)[:2])
        if prescribed:
            px, pv, mean = _prescribed(scene, starts, dt)
        x1s, v1s, x2s, v2s = [x1] * (c + 1), [v1] * (c + 1), [x2] * (c + 1), [v2] * (c + 1)  # [0]: the chunk's start
        touched: list[tuple[int, dict[str, float]]] = []
        last = c
        began = time.perf_counter()
        for j in range(c):
            if prescribed:
                x1, v1 = px[j], pv[j]  # the state the step starts with, for the forces on body 2
                j1.setPosition(0, x1)
                j1.setCommand(0, mean[j])
            elif finite:
                j1.setForce(0, time1[j] + g10 * x1 + g11 * v1 + g12 * x2 + g13 * v2)
            j2.setForce(0, time2[j] + g20 * x1 + g21 * v1 + g22 * x2 + g23 * v2)
            step()
            if finite:
                x1, v1 = j1.getPosition(0), j1.getVelocity(0)
                x1s[j + 1], v1s[j + 1] = x1, v1
            x2, v2 = j2.getPosition(0), j2.getVelocity(0)
            x2s[j + 1], v2s[j + 1] = x2, v2
            result = contacts()
            if result.getNumContacts():
                touched.append((j + 1, _wall_forces(result, walls)))
            if not (k0 + j) % FINITE_CHECK_EVERY and not math.isfinite(x1 + v1 + x2 + v2):
                last = j + 1  # the base cuts the run at the first bad sample among these
                break
        run.wall_time += time.perf_counter() - began
        first = 0 if k0 == 0 else 1  # the run's first chunk hands over the initial state too
        force = {wall: np.zeros(last + 1) for wall in walls}
        for j, pushed in touched:
            for wall, f in pushed.items():
                force[wall][j] = f
        force = {wall: f[first:] for wall, f in force.items()}
        cols = {"x1": np.array(x1s[first:last + 1]), "v1": np.array(v1s[first:last + 1])} if finite else {}
        t = ini.t + dt * np.arange(k0 + first, k0 + last + 1)
        if not run.add(t, force, x2=np.array(x2s[first:last + 1]), v2=np.array(v2s[first:last + 1]), **cols) or last < c:
            return


def simulate(run: Recording) -> None:
    """One run in its own DART world (``world.build``, then ``_simulate``)."""
    _simulate(build(run.scene, run.settings), run)


def bare_seconds(scene: Scene, settings: DartSettings, traj: Trajectory) -> float:
    """Seconds of DART's own loop over the adapter's run ``traj``: the same world, ``World.step`` with the forces the
    adapter applied (recomputed from its recorded states, in its operation order) and the two joint reads, nothing
    recorded and no contact read."""
    w = build(scene, settings)
    dt, n = settings.dt, len(traj.t) - 1
    starts = traj.t[:-1]
    time1, time2, g = force_plan(scene, starts)
    # summed as ``_simulate`` sums them (time part first, unlike ``base.replayed_forces``): the forces it applied
    s = [a[:-1] for a in (traj.x1, traj.v1, traj.x2, traj.v2)]
    f1 = (time1 + g[0, 0] * s[0] + g[0, 1] * s[1] + g[0, 2] * s[2] + g[0, 3] * s[3]).tolist()
    f2 = (time2 + g[1, 0] * s[0] + g[1, 1] * s[1] + g[1, 2] * s[2] + g[1, 3] * s[3]).tolist()
    if w.body1 == "prescribed":
        px, _, mean = _prescribed(scene, starts, dt)
    j1, j2, step = w.joint1, w.joint2, w.world.step
    finite, prescribed = w.body1 == "finite", w.body1 == "prescribed"
    began = time.perf_counter()
    for k in range(n):
        if prescribed:
            j1.setPosition(0, px[k])
            j1.setCommand(0, mean[k])
        elif finite:
            j1.setForce(0, f1[k])
        j2.setForce(0, f2[k])
        step()
        if finite:
            j1.getPosition(0), j1.getVelocity(0)
        j2.getPosition(0), j2.getVelocity(0)
    return time.perf_counter() - began
