"""PyBullet adapter: runs a ``Scene`` as two prismatic multibodies that collide with Newton restitution R.

    >>> from chatterbench.engines.pybullet_engine import PybulletEngine, PybulletSettings
    >>> traj = PybulletEngine().run(load_scene("bouncing-ball"), PybulletSettings(dt=1e-4))
    >>> traj.contact["lower"].argmax() * traj.dt          # first impact, about 0.4515 s

The model is the smallest PyBullet world that is Feigin's system (1967, section 1): body 1
and body 2 each slide on one prismatic joint along world x (no gravity, no friction, no
damping, default velocity motors off), body 2 is a sphere and body 1 carries one wall box per
gap limit, placed so that they touch exactly when y = x2 - x1 reaches ``gap.lower``
(and ``gap.upper``). Only body 1's walls and body 2 can collide. Every scene force is applied
as an external force each step, computed from the state the step starts from.

Promises:

- With the default ``PybulletSettings`` a single impact gives Newton's law (1.3):
  the relative speed is scaled by -R (within 0.01, see the tests) and m1 v1 + m2 v2 is kept.
  The five PyBullet defaults that break this are overridden (see ``PybulletSettings``).
- Each run opens its own ``p.DIRECT`` connection in a context manager and closes it, so runs
  can follow one another (or run in different threads' processes) in one interpreter.
- Sample k of the trajectory is the state after k ``stepSimulation`` calls; the contact flag
  and normal force at sample k belong to the step that ended there. ``contact[wall][k]`` is
  True when that wall pushed body 2 in that step (PyBullet normal force > 0); normal force is
  PyBullet's ``appliedImpulse / dt`` summed over the wall's contact points.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np


def _import_quietly():
    """Import pybullet without the ``pybullet build time: ...`` line its C code writes to
    stderr at import (it would be a second line under every one-line CLI message)."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no usable fd 2: nothing to protect
        import pybullet

        return pybullet
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
        import pybullet
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return pybullet


p = _import_quietly()

from chatterbench.engines.faults import FAULTS
from chatterbench.engines.settings import SettingsError
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.forces import evaluate_forces
from chatterbench.reference.scene import Scene

NAME = "pybullet"

# Geometry of the model [m]. Not physics: the bodies are 1-D, these sizes only have to keep
# the wall faces larger than body 2 so that it always meets a face. Body 2 is a sphere, not a
# box: a sphere on a face is one contact point where a box face on a face is four, which makes
# both the solver and getContactPoints cheaper (the benchmark's 80 % needs it) and gives the
# same bounces (checked: identical trajectories for the single impact and the bouncing ball).
BODY2_HALF = 0.05  # radius of body 2, its half extent along x
WALL_HALF = 0.05  # half thickness of each wall along x
WALL_SIDE = 0.2  # half extent of each wall across x

# A step's velocity change of body 2 beyond what its forces give, above which the step is taken
# to have had a contact impulse and the contact points are read: relative to |v2| [1], plus an
# absolute floor [m/s]. Rounding in Bullet's v += F dt / m is about 1e-16 relative; an impulse
# below these moves v2 by less than 1e-12 |v2| + 1e-15 m/s and is reported as no contact.
IMPULSE_RELATIVE_TOLERANCE = 1e-12
IMPULSE_ABSOLUTE_TOLERANCE = 1e-15  # [m/s]


@dataclass(frozen=True)
class PybulletSettings:
    """PyBullet parameters that change a bounce, under snake_case versions of PyBullet's names.

    The defaults make one impact follow Newton's law with the scene's R. PyBullet's own
    defaults, and what each does to the bounce sequence, are listed in the comments.
    """

    dt: float = 1e-4  # fixedTimeStep [s], > 0
    # Relative normal speed [m/s] below which restitution is zero (PyBullet: 0.2). Bounces
    # slower than this stick at once: the bouncing ball rests at 1.33 s, before its Zeno
    # time 1.355 s, and the feigin-pair chatter becomes a few plastic impacts.
    restitution_velocity_threshold: float = 0.0
    # Distance [m] below which a contact point enters the solver (PyBullet: 1e30, every point
    # the narrowphase reports). Meant to keep "speculative" points of bodies still apart out of
    # the solver; this sphere-on-box model reports none (checked up to 0.1 m), so here it
    # changes nothing, but 0 keeps it safe for other shapes.
    contact_processing_threshold: float = 0.0
    # Baumgarte factor pushing penetrating contacts apart, 0..1 (PyBullet: 0.2). Above 0 the
    # push adds separating speed contact_erp * depth / dt on top of R: a 1 m/s impact at
    # dt = 1e-4 (depth 1e-4 m) rebounds with 0.70 instead of R = 0.5.
    contact_erp: float = 0.0
    # Penetration [m] the solver tolerates (PyBullet: 1e-5). Bounces whose one-step
    # penetration is near this size lose their rebound: from the 4th impact on the bouncing
    # ball lands early (by 8 ms, then 12, 31 ms) and comes to rest at 1.30 s, before Zeno.
    contact_slop: float = 0.0
    # Share of the last step's contact impulse used as the solver's start, 0..1 (PyBullet:
    # 0.85). Can carry a bounce's impulse into the next step; with these prismatic multibodies
    # it changed nothing measurable (identical trajectories), 0 keeps it out of the question.
    warm_starting_factor: float = 0.0
    num_solver_iterations: int = 50  # numSolverIterations, >= 1 (PyBullet: 50)
    solver_residual_threshold: float = 1e-7  # solverResidualThreshold, >= 0 (PyBullet: 1e-7)
    erp: float = 0.2  # joint (non-contact) error reduction, 0..1 (PyBullet: 0.2)
    use_split_impulse: bool = True  # useSplitImpulse (PyBullet: True)
    split_impulse_penetration_threshold: float = -0.04  # [m], <= 0 (PyBullet: -0.04)
    contact_breaking_threshold: float = 0.02  # distance [m] a manifold point survives, > 0
    # Joint speed clamp [m/s] (PyBullet's maxJointVelocity: 100). Velocities above it are cut
    # silently, so free flight faster than 100 m/s would be wrong; 1e10 means no clamp.
    max_joint_velocity: float = 1e10
    mass1_inf: float = 1e6  # mass [kg] standing in for a prescribed infinite body 1, > 0
    fault: str = ""  # test-only: "segfault", "hang" or "raise" (engines/faults.py, via registry)

    def __post_init__(self) -> None:
        def check(name: str, ok: bool, allowed: str) -> None:
            if not ok:
                raise SettingsError(f"pybullet.{name} = {getattr(self, name)!r}: must be {allowed}")

        def number(name: str) -> float:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SettingsError(f"pybullet.{name} = {value!r}: must be a finite number")
            object.__setattr__(self, name, float(value))
            return float(value)

        check("dt", number("dt") > 0.0, "> 0 [s]")
        check("restitution_velocity_threshold", number("restitution_velocity_threshold") >= 0.0, ">= 0 [m/s]")
        check("contact_processing_threshold", number("contact_processing_threshold") >= 0.0, ">= 0 [m]")
        check("contact_erp", 0.0 <= number("contact_erp") <= 1.0, "in [0, 1]")
        check("contact_slop", number("contact_slop") >= 0.0, ">= 0 [m]")
        check("warm_starting_factor", 0.0 <= number("warm_starting_factor") <= 1.0, "in [0, 1]")
        n = self.num_solver_iterations
        check("num_solver_iterations", isinstance(n, int) and not isinstance(n, bool) and n >= 1, "an integer >= 1")
        check("solver_residual_threshold", number("solver_residual_threshold") >= 0.0, ">= 0")
        check("erp", 0.0 <= number("erp") <= 1.0, "in [0, 1]")
        check("use_split_impulse", isinstance(self.use_split_impulse, bool), "true or false")
        check("split_impulse_penetration_threshold", number("split_impulse_penetration_threshold") <= 0.0, "<= 0 [m]")
        check("contact_breaking_threshold", number("contact_breaking_threshold") > 0.0, "> 0 [m]")
        check("max_joint_velocity", number("max_joint_velocity") > 0.0, "> 0 [m/s]")
        check("mass1_inf", number("mass1_inf") > 0.0, "> 0 [kg]")
        if self.fault not in FAULTS:
            raise SettingsError(
                f"pybullet.fault = {self.fault!r}: must be one of {', '.join(repr(f) for f in FAULTS)} (test-only)"
            )

    def engine_parameters(self) -> dict[str, Any]:
        """Keyword arguments for ``p.setPhysicsEngineParameter``."""
        return {
            "fixedTimeStep": self.dt,
            "numSubSteps": 0,
            "numSolverIterations": self.num_solver_iterations,
            "solverResidualThreshold": self.solver_residual_threshold,
            "restitutionVelocityThreshold": self.restitution_velocity_threshold,
            "erp": self.erp,
            "contactERP": self.contact_erp,
            "contactSlop": self.contact_slop,
            "warmStartingFactor": self.warm_starting_factor,
            "useSplitImpulse": int(self.use_split_impulse),
            "splitImpulsePenetrationThreshold": self.split_impulse_penetration_threshold,
            "contactBreakingThreshold": self.contact_breaking_threshold,
        }

    def dynamics(self, restitution: float) -> dict[str, Any]:
        """Keyword arguments for ``p.changeDynamics`` on a colliding link.

        ``maxJointVelocity`` is not among them: PyBullet 3.2.7 then drops the restitution
        (rebound 0); it goes in a call of its own, ``joint_limits``.
        """
        return {
            "restitution": restitution,
            "lateralFriction": 0.0,
            "rollingFriction": 0.0,
            "spinningFriction": 0.0,
            "linearDamping": 0.0,
            "angularDamping": 0.0,
            "contactProcessingThreshold": self.contact_processing_threshold,
            # A sleeping body ignores small forces: a resting ball would not feel a later push.
            "activationState": p.ACTIVATION_STATE_DISABLE_SLEEPING,
        }


    def joint_limits(self) -> dict[str, Any]:
        """Keyword arguments for a separate ``p.changeDynamics`` call on each prismatic link."""
        return {"maxJointVelocity": self.max_joint_velocity}


def settings_snippet(settings: PybulletSettings, restitution: float = 0.5) -> str:
    """The PyBullet calls these settings make, as Python a user can paste into their own setup.

    ``body`` / ``wall`` stand for the user's two colliding bodies (link index 0 here); the
    combined restitution is the product of the two bodies' values, so one carries R.
    """
    def call(fn: str, head: str, kwargs: dict[str, Any]) -> str:
        names = {p.ACTIVATION_STATE_DISABLE_SLEEPING: "p.ACTIVATION_STATE_DISABLE_SLEEPING"}
        args = "".join(
            f"\n    {k}={names[v] if k == 'activationState' else repr(v)}," for k, v in kwargs.items()
        )
        return f"p.{fn}({head}{args}\n)"

    wall = settings.dynamics(1.0)
    body = settings.dynamics(restitution)
    return "\n".join(
        [
            "import pybullet as p",
            "",
            call("setPhysicsEngineParameter", "", settings.engine_parameters()),
            call("changeDynamics", "body, 0,", body),
            call("changeDynamics", "wall, 0,", wall),
            "# separately: passed together with restitution, PyBullet 3.2.7 drops the restitution",
            call("changeDynamics", "body, 0,", settings.joint_limits()),
            call("changeDynamics", "wall, 0,", settings.joint_limits()),
            "",
        ]
    )


@dataclass
class PybulletWorld:
    """A built PyBullet world for one scene (valid while its connection is open)."""

    client: int  # physics client id
    body1: int  # multibody id of body 1 (walls)
    body2: int  # multibody id of body 2 (the sphere)
    link1: int  # body 1's colliding link: 0 (prismatic) or -1 (fixed base)
    walls: tuple[str, ...]  # wall names, as in scene.gap.walls


@contextlib.contextmanager
def connect() -> Iterator[int]:
    """Open a private ``p.DIRECT`` physics client and close it on exit."""
    client = p.connect(p.DIRECT)
    if client < 0:
        raise RuntimeError("pybullet: could not open a DIRECT connection")
    try:
        yield client
    finally:
        p.disconnect(physicsClientId=client)


def build(scene: Scene, settings: PybulletSettings, client: int) -> PybulletWorld:
    """Create the two bodies of ``scene`` in the open ``client`` and set them to ``scene.initial``."""
    cid = client
    p.resetSimulation(physicsClientId=cid)
    p.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)
    p.setPhysicsEngineParameter(**settings.engine_parameters(), physicsClientId=cid)

    # Wall boxes in body 1's frame: the lower wall's +x face sits at lower - BODY2_HALF, so it
    # meets body 2's -x side (at x2 - BODY2_HALF) exactly when x2 - x1 = lower; likewise upper.
    walls = scene.gap.walls
    centres = [(scene.gap.lower - BODY2_HALF - WALL_HALF, 0.0, 0.0)]
    if scene.gap.upper is not None:
        centres.append((scene.gap.upper + BODY2_HALF + WALL_HALF, 0.0, 0.0))
    wall_shape = p.createCollisionShapeArray(
        shapeTypes=[p.GEOM_BOX] * len(centres),
        halfExtents=[[WALL_HALF, WALL_SIDE, WALL_SIDE]] * len(centres),
        collisionFramePositions=centres,
        physicsClientId=cid,
    )
    ball_shape = p.createCollisionShape(p.GEOM_SPHERE, radius=BODY2_HALF, physicsClientId=cid)

    def slider(shape: int, mass: float) -> int:
        # A fixed, shapeless base at the origin and one link on a prismatic joint along x:
        # the joint position is the body's x.
        return p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            linkMasses=[mass],
            linkCollisionShapeIndices=[shape],
            linkVisualShapeIndices=[-1],
            linkPositions=[[0.0, 0.0, 0.0]],
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]],
            linkInertialFramePositions=[[0.0, 0.0, 0.0]],
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]],
            linkParentIndices=[0],
            linkJointTypes=[p.JOINT_PRISMATIC],
            linkJointAxis=[[1.0, 0.0, 0.0]],
            physicsClientId=cid,
        )

    init = scene.initial
    if scene.body1_infinite and scene.prescribed is None:
        # A fixed body 1 is the static (mass 0) base itself: exactly infinite mass.
        body1 = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=wall_shape,
            basePosition=[init.x1, 0.0, 0.0],
            physicsClientId=cid,
        )
        link1 = -1
    else:
        mass1 = scene.mass1 if math.isfinite(scene.mass1) else settings.mass1_inf
        body1 = slider(wall_shape, mass1)
        link1 = 0
    body2 = slider(ball_shape, scene.mass2)

    for body, link in ((body1, link1), (body2, 0)):
        # Combined restitution is the product of the two bodies' values: body 2 carries R.
        r = scene.restitution if body == body2 else 1.0
        p.changeDynamics(body, link, **settings.dynamics(r), physicsClientId=cid)
        if link == 0:
            p.changeDynamics(body, link, **settings.joint_limits(), physicsClientId=cid)
            p.setJointMotorControl2(body, 0, p.VELOCITY_CONTROL, targetVelocity=0.0, force=0.0, physicsClientId=cid)
    # The two shapeless bases never touch anything; only the links (and a static body 1) collide.
    if link1 == 0:
        p.resetJointState(body1, 0, init.x1, init.v1, physicsClientId=cid)
    p.resetJointState(body2, 0, init.x1 + init.y, init.v1 + init.vy, physicsClientId=cid)
    return PybulletWorld(client=cid, body1=body1, body2=body2, link1=link1, walls=walls)


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
    """Split ``evaluate_forces`` into its time part (vectorised over ``t``) and its state matrix."""

    def bodies(tt, x1, v1, x2, v2):
        f1, f2, f12 = evaluate_forces(scene, tt, x1, v1, x2 - x1, v2 - v1)
        # Scene convention: body 1 feels F1 + F12, body 2 feels F2 - F12.
        return np.asarray(f1 + f12, dtype=float), np.asarray(f2 - f12, dtype=float)

    zeros = np.zeros_like(t)
    b1, b2 = bodies(t, zeros, zeros, zeros, zeros)
    time1 = np.broadcast_to(b1, t.shape).astype(float)
    time2 = np.broadcast_to(b2, t.shape).astype(float)
    gain = np.zeros((2, 4))
    t0 = float(t[0]) if t.size else 0.0
    base = bodies(t0, 0.0, 0.0, 0.0, 0.0)
    for j in range(4):
        unit = [0.0] * 4
        unit[j] = 1.0
        col = bodies(t0, *unit)
        gain[0, j] = float(col[0] - base[0])
        gain[1, j] = float(col[1] - base[1])
    if scene.body1_infinite:
        time1[:] = 0.0  # an infinite body 1 is moved by its prescription, not by forces
        gain[0, :] = 0.0
    return _ForcePlan(
        time1=time1,
        time2=time2,
        gain=gain,
        on1=bool(np.any(time1 != 0.0) or np.any(gain[0] != 0.0)),
        on2=bool(np.any(time2 != 0.0) or np.any(gain[1] != 0.0)),
        state_dependent=bool(np.any(gain != 0.0)),
    )


def n_steps_for(scene: Scene, settings: PybulletSettings) -> int:
    """Number of engine steps covering ``scene.duration`` (rounded to the nearest step)."""
    return max(1, int(round(scene.duration / settings.dt)))


def _simulate(scene: Scene, settings: PybulletSettings, world: PybulletWorld, n: int) -> dict[str, Any]:
    """Step ``world`` n times; return raw per-step records and the stepping wall time.

    The loop is the cost the benchmark measures, so it keeps Python work per step small:
    forces come from a plan precomputed with ``evaluate_forces`` (time part as a list, state
    part as eight gains), states go into preallocated lists, the finiteness check runs every
    1024 steps, and contact points are read only for steps that start near a wall and change
    body 2's momentum by more than the forces do (so the wall pushed).
    """
    cid = world.client
    dt = settings.dt
    t = scene.initial.t + dt * np.arange(n + 1)
    plan = _force_plan(scene, t)
    init = scene.initial
    x1, v1 = float(init.x1), float(init.v1)
    x2, v2 = x1 + init.y, v1 + init.vy
    x1s, v1s, x2s, v2s = [x1] * (n + 1), [v1] * (n + 1), [x2] * (n + 1), [v2] * (n + 1)
    contacts: list[tuple[int, tuple]] = []  # (sample, getContactPoints result), only near walls

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
    if prescribed is not None:
        px = (prescribed.offset + prescribed.amplitude * np.sin(prescribed.omega * t + prescribed.phase)).tolist()
        pv = (prescribed.amplitude * prescribed.omega * np.cos(prescribed.omega * t + prescribed.phase)).tolist()
    time1, time2 = plan.time1.tolist(), plan.time2.tolist()
    g10, g11, g12, g13, g20, g21, g22, g23 = (float(v) for v in plan.gain.ravel())
    on1, on2, dep = plan.on1, plan.on2, plan.state_dependent
    moving1 = l1 >= 0

    step = p.stepSimulation
    joint = p.getJointState
    push = p.applyExternalForce
    points = p.getContactPoints
    reset = p.resetJointState
    frame = p.LINK_FRAME
    origin = (0.0, 0.0, 0.0)
    isfinite = math.isfinite
    status, message = "ok", ""
    last = n
    k = 0
    start = time.perf_counter()
    try:
        for k in range(n):
            if prescribed is not None:
                x1 = px[k]
                v1 = pv[k]
                reset(b1, 0, x1, v1, physicsClientId=cid)
            if on1:
                f = time1[k]
                if dep:
                    f += g10 * x1 + g11 * v1 + g12 * x2 + g13 * v2
                push(b1, l1, (f, 0.0, 0.0), origin, frame, physicsClientId=cid)
            f2 = 0.0
            if on2:
                f2 = time2[k]
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
                x1s[k + 1] = x1
                v1s[k + 1] = v1
            x2, v2, _, _ = joint(b2, 0, physicsClientId=cid)
            x2s[k + 1] = x2
            v2s[k + 1] = v2
            if near and abs(v2 - w2) > rel_tol * abs(w2) + IMPULSE_ABSOLUTE_TOLERANCE:
                contacts.append((k + 1, points(b1, b2, physicsClientId=cid)))
            if not k & 1023 and not isfinite(x1 + v1 + x2 + v2):
                last = k + 1
                break
    except p.error as exc:
        status, message = "error", f"pybullet: {exc}"
        last = k
    wall_time = time.perf_counter() - start
    return {
        "t": t, "x1": np.array(x1s), "v1": np.array(v1s), "x2": np.array(x2s), "v2": np.array(v2s),
        "contacts": contacts, "last": last, "status": status, "message": message, "wall_time": wall_time,
    }


def _trajectory(scene: Scene, settings: PybulletSettings, world: PybulletWorld, raw: dict[str, Any]) -> Trajectory:
    last = raw["last"]
    cols = {k: raw[k][: last + 1] for k in ("t", "x1", "v1", "x2", "v2")}
    status, message = raw["status"], raw["message"]
    finite = np.isfinite(cols["x1"]) & np.isfinite(cols["v1"]) & np.isfinite(cols["x2"]) & np.isfinite(cols["v2"])
    if not finite.all():
        bad = int(np.argmin(finite))
        cols = {k: v[:bad] for k, v in cols.items()}
        status, message = "diverged", f"non-finite state at sample {bad} (t = {raw['t'][bad]:.6g} s)"
    n = len(cols["t"])
    contact = {w: np.zeros(n, dtype=bool) for w in world.walls}
    force = {w: np.zeros(n) for w in world.walls}
    # Body 1 is bodyA: contactNormalOnB points from body 2 towards body 1. The lower wall lies
    # on body 2's -x side, the upper wall on its +x side, so the normal's x sign names the wall.
    for k, pts in raw["contacts"]:
        if k >= n:
            break
        for pt in pts or ():
            wall = "lower" if pt[7][0] < 0.0 else "upper"
            if wall not in contact:
                continue
            if pt[9] > 0.0:  # the wall pushed during the step
                contact[wall][k] = True
                force[wall][k] += pt[9]
    return Trajectory(
        engine=NAME,
        t=cols["t"], x1=cols["x1"], x2=cols["x2"], v1=cols["v1"], v2=cols["v2"],
        contact=contact, normal_force=force, wall_time=raw["wall_time"],
        settings=dataclasses.asdict(settings), status=status, message=message,
    )


def run(scene: Scene, settings: PybulletSettings | None = None) -> Trajectory:
    """Simulate ``scene.duration`` seconds from ``scene.initial``; see the module docstring.

    Returns
    -------
    Trajectory
        ``status`` "ok"; "diverged" with the finite samples when the state blew up; "error"
        with PyBullet's message (and no steps) when the engine refused the model.
    """
    settings = settings or PybulletSettings()
    n = n_steps_for(scene, settings)
    try:
        with connect() as cid:
            world = build(scene, settings, cid)
            raw = _simulate(scene, settings, world, n)
            return _trajectory(scene, settings, world, raw)
    except p.error as exc:
        init = scene.initial
        one = lambda v: np.array([float(v)])  # noqa: E731
        walls = scene.gap.walls
        return Trajectory(
            engine=NAME, t=one(init.t), x1=one(init.x1), x2=one(init.x1 + init.y), v1=one(init.v1),
            v2=one(init.v1 + init.vy), contact={w: np.zeros(1, dtype=bool) for w in walls},
            normal_force={w: np.zeros(1) for w in walls}, wall_time=0.0,
            settings=dataclasses.asdict(settings), status="error", message=f"pybullet: {exc}",
        )


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
        px = (pr.offset + pr.amplitude * np.sin(pr.omega * tt + pr.phase)).tolist()
        pv = (pr.amplitude * pr.omega * np.cos(pr.omega * tt + pr.phase)).tolist()
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


def benchmark(scene: Scene, settings: PybulletSettings | None = None, n_steps: int = 20000, repeat: int = 3) -> dict[str, float]:
    """Steps per second of the adapter and of the bare engine loop, measured in one process.

    Both loops step the same trajectory: the raw loop replays the forces the adapter applied
    (recomputed from its recorded states, bit for bit), so the two differ only by the
    adapter's own work (force evaluation, recording, contact queries). Each is run ``repeat``
    times, interleaved, and the fastest run counts (as ``timeit`` does: slower runs measure
    the machine's other load, not the code).

    Returns
    -------
    dict
        ``adapter_steps_per_s``, ``raw_steps_per_s``, ``ratio`` (adapter / raw), ``n_steps``.
    """
    settings = settings or PybulletSettings()
    if isinstance(n_steps, bool) or not isinstance(n_steps, int) or n_steps < 1:
        raise ValueError(f"n_steps = {n_steps!r}: must be an integer >= 1")
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"repeat = {repeat!r}: must be an integer >= 1")
    best_adapter = best_raw = math.inf
    with connect() as cid:
        for _ in range(repeat):
            world = build(scene, settings, cid)
            raw = _simulate(scene, settings, world, n_steps)
            best_adapter = min(best_adapter, raw["wall_time"])
            plan = _force_plan(scene, raw["t"])
            states = np.stack([raw["x1"], raw["v1"], raw["x2"], raw["v2"]])
            g = plan.gain
            pr = scene.prescribed if scene.body1_infinite else None
            if pr is not None:  # the adapter used the prescription, not the recorded x1, v1
                states[0] = pr.offset + pr.amplitude * np.sin(pr.omega * raw["t"] + pr.phase)
                states[1] = pr.amplitude * pr.omega * np.cos(pr.omega * raw["t"] + pr.phase)
            # Same operation order as the adapter loop, so the replayed forces are identical.
            f1, f2 = (
                plan.time1 + (g[i, 0] * states[0] + g[i, 1] * states[1] + g[i, 2] * states[2] + g[i, 3] * states[3])
                for i in (0, 1)
            )
            world = build(scene, settings, cid)
            best_raw = min(best_raw, _raw_loop(scene, settings, world, (f1.tolist(), f2.tolist()), n_steps))
    adapter, bare = n_steps / best_adapter, n_steps / best_raw
    return {"adapter_steps_per_s": adapter, "raw_steps_per_s": bare, "ratio": adapter / bare, "n_steps": float(n_steps)}


class PybulletEngine:
    """The PyBullet adapter as an ``Engine``: ``build`` returns the world, ``run`` a Trajectory."""

    name = NAME

    def build(self, scene: Scene, settings: PybulletSettings | None = None) -> PybulletWorld:
        """Build ``scene`` in a fresh DIRECT client that stays open; close it with ``p.disconnect``."""
        settings = settings or PybulletSettings()
        cid = p.connect(p.DIRECT)
        return build(scene, settings, cid)

    def run(self, scene: Scene, settings: PybulletSettings | None = None) -> Trajectory:
        """Simulate ``scene``; see ``run``."""
        return run(scene, settings)
