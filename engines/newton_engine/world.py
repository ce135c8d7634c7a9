"""The Newton world of a scene: body 2 a sphere, body 1 the walls, each on a prismatic joint along x; one step captured.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.newton_engine.world import build
    >>> from chatterbench.engines.newton_engine.settings import XpbdSettings
    >>> w = build(load_scene("feigin-pair"), XpbdSettings(device="cpu"), "xpbd")
    >>> w.walls, w.finite1, w.device
    (('lower', 'upper'), True, 'cpu')

One ``newton.ModelBuilder`` model (Newton 1.8, on warp) with x as its up axis, so the scene's
gravity, when in the model (``gravity_in_model``), is the vector (g, 0, 0). Body 2 is a sphere of
radius ``BODY2_HALF`` on a prismatic joint along world x. Body 1 carries one box per gap limit,
its face where the sphere touches it exactly when y = x2 - x1 reaches ``gap.lower`` (``upper``):
on a prismatic joint when its mass is finite, static shapes of the world (body -1, exactly
infinite mass) when it is infinite and at rest, a kinematic link on the joint put on its path
before each step (``drive``) when it is prescribed. No friction (``mu = 0``, ``kf = 0``), no adhesion, no angular
damping; shapes have no density (the masses are the scene's, exactly), inertia only so that the
solvers can invert it (nothing turns: every force is along x through the centres).

One step is ``CollisionPipeline.collide`` then the solver's ``step`` from state A to state B,
then B copied back to A: the same arrays every step, so the step is captured once as a warp
graph (CUDA, and warp's CPU device from warp 1.17) and replayed with one launch (about 30 us a step on
the CPU device where the Python launches cost 1 ms). The forces go into ``state.body_f`` and the
state is read from ``state.body_q`` / ``body_qd`` through numpy views (no copy on the CPU device).
"""

from __future__ import annotations

import functools
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from chatterbench.reference.scene import Scene

from .. import warp_cache
from ..api import SettingsError
from ..warp_cache import cache_entries, compile_lock

BODY2_HALF = 0.05  # [m] radius of body 2 (geometry only: the walls are placed around it)
WALL_HALF = 0.5  # [m] half thickness of each wall along x: deeper than a soft contact sinks (semi-implicit)
WALL_SIDE = 0.5  # [m] half extent of each wall across x: the nearest face stays the +x one
DETECT_GAP = 0.01  # [m] contact detection distance (Newton's shape ``gap``): contacts found this far ahead
INERTIA = 1e-3  # [kg m^2] each moving body's (diagonal) inertia: never used along x, only inverted
# A step's velocity change of body 2 beyond what its forces give above which a wall pushed (XPBD): relative to
# |v2| + |f2 dt / m2| [-], plus a floor [m/s]. Newton steps in float32 (rounding 6e-8 relative); a push below these
# moves v2 by less than 1e-5 of its size and is reported as none.
IMPULSE_RELATIVE_TOLERANCE = 1e-5
IMPULSE_ABSOLUTE_TOLERANCE = 1e-7  # [m/s]


@functools.cache
def modules() -> tuple[Any, Any]:
    """``(warp, newton)`` imported once, quietly: warp's banner and per-module load lines off, and its initialisation
    run with file descriptor 2 on /dev/null (without a CUDA driver warp's C code writes a warning there, a second line
    under every one-line message of the command line); the engine layer prints nothing."""
    import warp as wp

    wp.config.quiet = True
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)
    # nothing here differentiates a run: warp builds the forward kernels only (a cold compile of XPBD's took 12.6 s
    # instead of 26.7 s, semi-implicit's 9.7 s instead of 14.8 s on this 2-core machine; the kernels run the same)
    wp.config.enable_backward = False
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no usable fd 2: nothing to protect
        wp.init()
    else:
        try:
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 2)
            os.close(null)
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
    import newton

    return wp, newton


def device_name(device: str) -> str:
    """The warp device for a settings' ``device``: "auto" is cuda where warp finds a GPU, else cpu; SettingsError for
    cuda where there is none."""
    wp, _ = modules()
    gpus = wp.get_cuda_device_count()
    if device == "auto":
        return "cuda" if gpus else "cpu"
    if device == "cuda" and not gpus:
        raise SettingsError("newton device = 'cuda': warp finds no CUDA device here (use 'cpu' or 'auto')")
    return device


@dataclass(frozen=True)
class KernelLoad(warp_cache.KernelLoad):
    """Newton's kernels for one solver on a device (``warp_cache.KernelLoad``): ``Newton (xpbd) compiled its kernels
    for device cpu in 14.3 s (cache: ...)``."""

    solver: str = ""

    @property
    def engine(self) -> str:  # type: ignore[override]
        return f"Newton ({self.solver})"


@functools.cache
def load_kernels(solver: str, device: str) -> KernelLoad:
    """Build a one-ball world of ``solver`` on ``device`` and step it once, timed: every module a run's step uses is
    loaded (compiled the first time on a machine, then read from warp's cache); once per process, under a lock on
    warp's cache shared by every process (``warp_cache.compile_lock``; the time includes any wait for another's
    compile)."""
    from chatterbench.reference.scene import load_scene

    from .settings import SemiSettings, XpbdSettings

    wp, _ = modules()
    cache = str(wp.config.kernel_cache_dir or "")
    start = time.perf_counter()
    with compile_lock(cache, "newton"):
        before = cache_entries(cache)
        settings = XpbdSettings(device=device) if solver == "xpbd" else SemiSettings(device=device)
        world = build(load_scene("feigin-pair", ["duration=0.001"]), settings, solver, capture=False)
        world.launch()
        wp.synchronize()
        compiled = cache_entries(cache) > before
    return KernelLoad(device, time.perf_counter() - start, compiled, cache, solver=solver)


class World:
    """A scene's Newton model, solver and states, and its step (module docstring)."""

    def __init__(self, scene: Scene, settings: Any, solver: str, capture: bool = True) -> None:
        wp, newton = modules()
        self.device = device_name(settings.device)
        self.walls = scene.gap.walls
        self.finite1 = not scene.body1_infinite
        self.dt = settings.dt
        g = scene.gravity if settings.gravity_in_model else 0.0
        # the weights [N] Newton's model adds (gravity in it): taken off the forces the base hands over
        self.weight1 = scene.mass1 * g if self.finite1 else 0.0
        self.weight2 = scene.mass2 * g
        # model length units per metre (``length_unit``): lengths, speeds, accelerations and forces x L, masses as they are
        self.L = L = float(getattr(settings, "length_unit", 1.0))
        builder = newton.ModelBuilder(up_axis=newton.Axis.X, gravity=(g * L, 0.0, 0.0))
        cfg = shape_config(newton, scene, settings, solver)
        ini = scene.initial
        identity = wp.quat_identity()
        faces = [("lower", L * (scene.gap.lower - BODY2_HALF - WALL_HALF))]
        if scene.gap.upper is not None:
            faces.append(("upper", L * (scene.gap.upper + BODY2_HALF + WALL_HALF)))
        half, side = L * WALL_HALF, L * WALL_SIDE
        inertia = wp.mat33(np.eye(3) * INERTIA)
        joints = []
        # a prescribed body 1 is a kinematic link, moved by ``drive`` (its mass 1 kg is never used)
        self.kinematic = scene.prescribed is not None
        if self.finite1 or self.kinematic:
            body1 = builder.add_link(xform=wp.transform(wp.vec3(L * ini.x1, 0.0, 0.0), identity),
                                     mass=1.0 if self.kinematic else scene.mass1, inertia=inertia, label="body1",
                                     is_kinematic=self.kinematic)
            for _, centre in faces:
                builder.add_shape_box(body1, xform=wp.transform(wp.vec3(centre, 0.0, 0.0), identity), hx=half, hy=side,
                                      hz=side, cfg=cfg)
            joints.append(builder.add_joint_prismatic(-1, body1, axis=newton.Axis.X))
        else:
            for _, centre in faces:
                builder.add_shape_box(-1, xform=wp.transform(wp.vec3(L * ini.x1 + centre, 0.0, 0.0), identity),
                                      hx=half, hy=side, hz=side, cfg=cfg)
        body2 = builder.add_link(xform=wp.transform(wp.vec3(L * (ini.x1 + ini.y), 0.0, 0.0), identity), mass=scene.mass2,
                                 inertia=inertia, label="body2")
        builder.add_shape_sphere(body2, radius=L * BODY2_HALF, cfg=cfg)
        joints.append(builder.add_joint_prismatic(-1, body2, axis=newton.Axis.X))
        for j in joints:
            builder.add_articulation([j])
        self.model = model = builder.finalize(device=self.device)
        self.i1, self.i2 = (0, 1) if self.finite1 or self.kinematic else (None, 0)
        if solver == "xpbd":
            self.solver = newton.solvers.SolverXPBD(
                model, iterations=settings.iterations, rigid_contact_relaxation=settings.rigid_contact_relaxation,
                rigid_contact_restitution_iterations=settings.restitution_iterations, angular_damping=0.0,
                enable_restitution=True)
        else:
            self.solver = newton.solvers.SolverSemiImplicit(model, angular_damping=0.0)
        self.a, self.b, self.control = model.state(), model.state(), model.control()
        qd = self.a.body_qd.numpy().copy()  # a copy: on the CPU device numpy() is a view, which the warm-up step moves
        if self.i1 is not None:
            qd[self.i1, 0] = L * ini.v1
        qd[self.i2, 0] = L * (ini.v1 + ini.vy)
        self.a.body_qd.assign(qd)
        self.pipeline = newton.CollisionPipeline(model)
        self.contacts = self.pipeline.contacts()
        self.a.clear_forces()
        # numpy views of the arrays every step writes and reads (the CPU device: the arrays' own memory)
        self.q, self.qd, self.f = self.a.body_q.numpy(), self.a.body_qd.numpy(), self.a.body_f.numpy()
        self.graph = None
        if capture:
            self.launch()  # loads every module the step uses (a capture cannot), then back to the initial state
            self.a.body_q.assign(model.body_q)
            self.a.body_qd.assign(qd)
            with wp.ScopedDevice(self.device), wp.ScopedCapture() as captured:
                self._one()
            self.graph = captured.graph
        self.views = self.device == "cpu"

    def _one(self) -> None:
        wp, _ = modules()
        self.pipeline.collide(self.a, self.contacts)
        self.solver.step(self.a, self.b, self.control, self.contacts, self.dt)
        wp.copy(self.a.body_q, self.b.body_q)
        wp.copy(self.a.body_qd, self.b.body_qd)

    def launch(self) -> None:
        """One step: the captured graph, or the step's launches one by one."""
        if self.graph is None:
            self._one()
        else:
            modules()[0].capture_launch(self.graph)

    def push(self, f1: float, f2: float) -> None:
        """The forces [N] along x on body 1 and body 2 for the next step, the model's gravity taken off (it adds it)."""
        if self.finite1:
            self.f[self.i1, 0] = (f1 - self.weight1) * self.L
        self.f[self.i2, 0] = (f2 - self.weight2) * self.L
        if not self.views:
            self.a.body_f.assign(self.f)

    def drive(self, x1: float, v1: float) -> None:
        """Body 1, kinematic, put at ``x1`` [m] with velocity ``v1`` [m/s] for the next step (its path's state at the
        step's start)."""
        self.q[self.i1, 0], self.qd[self.i1, 0] = x1 * self.L, v1 * self.L
        if not self.views:
            self.a.body_q.assign(self.q)
            self.a.body_qd.assign(self.qd)

    def state(self) -> tuple[float, float, float, float]:
        """(x1, v1, x2, v2) [m, m/s] after the last step (x1, v1 nan for an infinite body 1)."""
        if not self.views:
            self.q, self.qd = self.a.body_q.numpy(), self.a.body_qd.numpy()
        q, qd, L = self.q, self.qd, self.L
        i2 = self.i2
        if self.finite1:
            return float(q[0, 0]) / L, float(qd[0, 0]) / L, float(q[i2, 0]) / L, float(qd[i2, 0]) / L
        return math.nan, math.nan, float(q[i2, 0]) / L, float(qd[i2, 0]) / L


def shape_config(newton: Any, scene: Scene, settings: Any, solver: str) -> Any:
    """Every shape's ``ShapeConfig``: the scene's R (XPBD averages the two shapes': both carry R), ke and kd of the
    penalty contact (the semi-implicit solver averages them too), no friction, no density, the detection gap."""
    ke = kd = 0.0
    if solver == "semi":
        from .penalty import ke_kd, relative_mass

        ke, kd = ke_kd(settings.w0, settings.zeta(scene.restitution), relative_mass(scene.mass1, scene.mass2))
    return newton.ModelBuilder.ShapeConfig(density=0.0, mu=0.0, kf=0.0, ka=0.0, restitution=scene.restitution,
                                           ke=ke, kd=kd, gap=DETECT_GAP * getattr(settings, "length_unit", 1.0),
                                           margin=0.0)


def build(scene: Scene, settings: Any, solver: str, capture: bool = True) -> World:
    """The world of ``scene`` at ``scene.initial`` for ``solver`` ("xpbd" or "semi") (module docstring)."""
    return World(scene, settings, solver, capture)
