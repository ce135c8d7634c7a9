"""The PyBullet world of a scene: two prismatic multibodies, the walls on body 1, a sphere for body 2.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.pybullet_engine.world import build, PybulletSettings
    >>> with build(load_scene("feigin-pair"), PybulletSettings()) as world:
    ...     world.walls, world.link1, world.x2
    (('lower', 'upper'), 0, 0.0)

Body 1 and body 2 each slide on one prismatic joint along world x (no gravity, no
friction, no damping, default velocity motors off); body 1 carries one wall box per gap
limit, placed so that they touch exactly when y = x2 - x1 reaches ``gap.lower`` (and
``gap.upper``). Only body 1's walls and body 2 can collide. A fixed body 1 is the static
base itself (exactly infinite mass); a prescribed one is a heavy slider moved every step. Each
world has a ``p.DIRECT`` client of its own while it lives; ``close()`` (or leaving a ``with`` block)
hands it back to the process's idle clients, and the next world built takes one of those instead of
connecting anew (a connect costs 2 ms, and a tune's strikes are thousands of runs of a few hundred
steps): an idle client whose bodies are the ones the scene and settings make (``Bodies``: every value
the build reads but the initial state) keeps them and is only set to the scene's initial state
(``resetJointState``); any other is reset (``resetSimulation``, then every parameter and body made
again). Made anew, the bodies cost 0.8 ms (two ``createMultiBody`` and the reset), kept 2 us; a
strike's few hundred steps cost 2.5 ms. A reused client, its bodies kept or made anew, gives the runs
of a fresh one bit for bit, whatever the run before it left (body 2 pressed on a wall, contact points
with their impulses): ``tests/engines/test_pybullet.py``.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

from chatterbench.reference.scene import Scene

from .bullet import p
from .settings import PybulletSettings

# Geometry of the model [m]. Not physics: the bodies are 1-D, these sizes only have to keep
# the wall faces larger than body 2 so that it always meets a face. Body 2 is a sphere, not a
# box: a sphere on a face is one contact point where a box face on a face is four, which makes
# both the solver and getContactPoints cheaper (the benchmark's 80 % needs it) and gives the
# same bounces (checked: identical trajectories for the single impact and the bouncing ball).
BODY2_HALF = 0.05  # radius of body 2, its half extent along x
WALL_HALF = 0.05  # half thickness of each wall along x
WALL_SIDE = 0.2  # half extent of each wall across x
IDLE_CLIENTS = 4  # connected clients a process keeps for its next worlds; beyond these, close() disconnects

_idle: list["_Client"] = []  # the clients of closed worlds, each still connected (this process's own)
_idle_lock = threading.Lock()


@dataclass(frozen=True)
class Bodies:
    """Every value the bodies of a world are made from, the initial state aside (``bodies_of``): two worlds with
    equal ``Bodies`` differ only in where the bodies start."""

    lower: float  # [m] gap.lower
    upper: float | None  # [m] gap.upper (None: no upper wall)
    static_x1: float | None  # [m] a fixed body 1 is the static base, placed at x1; None: body 1 slides
    mass1: float  # [kg] body 1's mass (mass1_inf standing in for an infinite one); 0 for the static base
    mass2: float  # [kg]
    restitution: float  # [-] R, carried by body 2
    settings: PybulletSettings  # every engine parameter and body property


@dataclass
class _Client:
    """A connected client, the bodies it holds and their ids."""

    cid: int
    bodies: Bodies | None = None  # None: nothing built in it yet
    body1: int = -1
    body2: int = -1
    link1: int = -1


@dataclass
class PybulletWorld:
    """A built PyBullet world for one scene (valid until ``close``), and what its steps keep."""

    client: int  # physics client id
    held: "_Client"  # the client and what it holds, handed back by close()
    body1: int  # multibody id of body 1 (walls)
    body2: int  # multibody id of body 2 (the sphere)
    link1: int  # body 1's colliding link: 0 (prismatic) or -1 (fixed base)
    walls: tuple[str, ...]  # wall names, as in scene.gap.walls
    x1: float  # [m] body 1 at the start of the next step (the walls' place: which steps can touch)
    x2: float  # [m] body 2 at the start of the next step
    v2: float  # [m/s] body 2's velocity then
    stepping: bool = False  # a step under way: forces applied, the state not read yet (set by the adapter's step)

    def close(self) -> None:
        """Hand the world's client to the idle ones (disconnect it when ``IDLE_CLIENTS`` are idle); the world is gone.
        Its bodies are kept for a next scene with the same ones only after a whole last step and a finite state: a step
        cut short leaves its external forces on the bodies for the next ``stepSimulation``, and a blown-up run may
        leave what ``resetJointState`` does not reset; such a client is reset and built anew."""
        cid, self.client = self.client, -1
        if cid < 0:
            return
        if self.stepping or not math.isfinite(self.x1 + self.x2 + self.v2):
            self.held.bodies = None
        with _idle_lock:
            if len(_idle) < IDLE_CLIENTS:
                _idle.append(self.held)
                return
        p.disconnect(physicsClientId=cid)

    def __enter__(self) -> "PybulletWorld":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def build(scene: Scene, settings: PybulletSettings) -> PybulletWorld:
    """The two bodies of ``scene`` in a ``p.DIRECT`` client of its own (an idle one holding these bodies, or another
    one reset, or a new one), set to ``scene.initial`` (close the world)."""
    wanted = bodies_of(scene, settings)
    client = _idle_client(wanted)
    if client is None:
        raise RuntimeError("pybullet: could not open a DIRECT connection")
    try:
        if client.bodies != wanted:
            _make(scene, settings, client, wanted)
        return _start(scene, client)
    except BaseException:
        p.disconnect(physicsClientId=client.cid)
        raise


def bodies_of(scene: Scene, settings: PybulletSettings) -> Bodies:
    """What ``scene``'s bodies are made from with ``settings``, the initial state aside (``Bodies``)."""
    static = scene.body1_infinite and scene.prescribed is None
    mass1 = 0.0 if static else (scene.mass1 if math.isfinite(scene.mass1) else settings.mass1_inf)
    return Bodies(lower=float(scene.gap.lower), upper=None if scene.gap.upper is None else float(scene.gap.upper),
                  static_x1=float(scene.initial.x1) if static else None, mass1=float(mass1),
                  mass2=float(scene.mass2), restitution=float(scene.restitution), settings=settings)


def _idle_client(wanted: Bodies) -> _Client | None:
    """An idle client (``_idle``) holding ``wanted``'s bodies (the last closed); else a new ``p.DIRECT`` one while
    fewer than ``IDLE_CLIENTS`` are idle (so that each keeps its bodies); else the one closed longest ago (None: no
    client could be opened)."""
    while True:
        with _idle_lock:
            same = [k for k, c in enumerate(_idle) if c.bodies == wanted]
            if same:
                client = _idle.pop(same[-1])
            else:
                client = _idle.pop(0) if _idle and len(_idle) >= IDLE_CLIENTS else None
        if client is None:
            cid = p.connect(p.DIRECT)
            return _Client(cid) if cid >= 0 else None
        if p.isConnected(physicsClientId=client.cid):
            return client


def _make(scene: Scene, settings: PybulletSettings, client: _Client, wanted: Bodies) -> None:
    """Make ``scene``'s bodies in ``client`` anew (``_bodies``)."""
    client.bodies = None
    client.body1, client.body2, client.link1 = _bodies(scene, settings, client.cid)
    client.bodies = wanted


def _start(scene: Scene, client: _Client) -> PybulletWorld:
    """``client``'s bodies, made or kept, set to ``scene.initial``: the world."""
    init, cid = scene.initial, client.cid
    if client.link1 == 0:
        p.resetJointState(client.body1, 0, init.x1, init.v1, physicsClientId=cid)
    p.resetJointState(client.body2, 0, init.x1 + init.y, init.v1 + init.vy, physicsClientId=cid)
    return PybulletWorld(client=cid, held=client, body1=client.body1, body2=client.body2, link1=client.link1,
                         walls=scene.gap.walls, x1=float(init.x1), x2=float(init.x1) + init.y,
                         v2=float(init.v1) + init.vy)


def _bodies(scene: Scene, settings: PybulletSettings, cid: int) -> tuple[int, int, int]:
    """Create the two bodies of ``scene`` in the open client ``cid`` (reset first): body 1's id, body 2's id, body 1's
    colliding link (-1: the static base)."""
    p.resetSimulation(physicsClientId=cid)
    p.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)
    p.setPhysicsEngineParameter(**settings.engine_parameters(), physicsClientId=cid)

    # Wall boxes in body 1's frame: the lower wall's +x face sits at lower - BODY2_HALF, so it
    # meets body 2's -x side (at x2 - BODY2_HALF) exactly when x2 - x1 = lower; likewise upper.
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
    return body1, body2, link1
