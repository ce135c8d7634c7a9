"""The MuJoCo adapter: a scene as a two-slide-joint MjSpec model, run in one ``mujoco.rollout`` call.

    >>> from chatterbench.engines.mujoco_engine import MujocoSettings, run
    >>> traj = run(load_scene("feigin-pair"), MujocoSettings(dt=1e-4, w0_dt=0.03))
    >>> traj.status, traj.contact["lower"].any(), traj.settings["zeta"]

The model (built with ``mujoco.MjSpec``; ``export_mjcf`` gives the MJCF to paste):

- ``body1`` on a slide joint ``x1`` along world x (finite mass); for ``mass1 = inf`` a
  static body at x1, or a mocap body when ``scene.prescribed`` moves it.
- ``body2`` a child of ``body1`` on a slide joint ``y``, so qpos = (x1, y) and y = x2 - x1
  is a coordinate, not a difference of two large numbers.
- The gap: ``gap_model = "limit"`` makes it the range of joint ``y`` (one limit row,
  ``jointlimitfrc`` sensor); ``"geom"`` puts box walls on body 1 and a sphere on body 2
  (a sphere so that a wall contact is one row: a box-box face contact gives four
  identical rows, which changes the effective impedance), read by ``contact`` sensors.
- No gravity, no friction (condim 1), contacts only wall-ball (contype/conaffinity);
  ``filterparent`` is disabled because the walls belong to body 2's parent.

Contact law. MuJoCo's direct ``solref = (-k, -b)`` with constant ``solimp`` d gives the
reference acceleration a_ref = -(b/d) v - (k/d^2) d r, and for one constraint row the
solver returns a = d a_ref + (1 - d) a_free, i.e. a = -b v - k r + (1 - d) a_free:
MuJoCo already divides by d (d = dmax) in the direct form. The one remaining scaling:
MuJoCo's regulariser uses an approximate diagA, so the realised d' = A / (A + efc_R)
differs from d (exactly equal for the joint limit, ~0.7% for the sphere-box contact);
``build`` measures d' on the compiled model and rescales solref by d / d'. The realised
relative oscillator is then x'' + 2 zeta w0 x' + w0^2 x = 0 for any impedance and either
gap model (both checked in the tests). What the impedance still does: external forces reach
the relative motion scaled by (1 - d) while the contact pushes, so a resting body sinks
(1 - d) a_free / w0^2, not a_free / w0^2. Here k = w0^2, b = 2 zeta w0 with
w0 = w0_dt / dt and zeta = ``damping_ratio_from_restitution(R)`` (force-only contact, so
R is not exp(-pi zeta / sqrt(1 - zeta^2))). The contact row is unilateral: the force is
clamped at zero, which is exactly where the force-only restitution ends the contact.

Forces. Springs and dampers become joint stiffness/damping/springref (body 1 on ``x1``,
coupling on ``y``) and a fixed tendon x2 = x1 + y (body 2 to ground). Constant and
harmonic forces become motor actuators on ``x1`` (F1 + F2) and ``y`` (F2 - F12) whose
controls are precomputed at t_k (the start of step k; the step midpoint for ``rk4``,
which holds ctrl over its stages). A prescribed body 1 enters the relative motion through
the exact inertial force -m2 x1''(t) on ``y``: MuJoCo gives mocap bodies zero velocity
and acceleration, so moving the mocap alone would leave y'' and the contact damping blind
to it. The mocap is still moved (through rollout's ``mjSTATE_MOCAP_POS`` controls) so the
model looks right; x1, v1 of an infinite body are reported from the scene's formula.

Promises: one ``mujoco.rollout`` call runs the whole trajectory; ``MujocoSettings``
refuses bad values up front (``SettingsError`` naming field, value and range), so
``run`` never raises from inside MuJoCo for a user mistake; a blow-up is reported as
``status = "diverged"`` with the samples before it (autoreset is disabled so MuJoCo
cannot hide it by resetting the state).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from chatterbench.reference.scene import Scene, did_you_mean

from .faults import FAULTS
from .restitution import contact_duration, damping_ratio_from_restitution
from .settings import SettingsError
from .trajectory import Trajectory

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}
SOLVERS = {
    "Newton": mujoco.mjtSolver.mjSOL_NEWTON,
    "PGS": mujoco.mjtSolver.mjSOL_PGS,
    "CG": mujoco.mjtSolver.mjSOL_CG,
}
GAP_MODELS = ("limit", "geom")
IMPEDANCE_RANGE = (1e-4, 0.9999)  # MuJoCo clamps solimp to [mjMINIMP, mjMAXIMP]
MAXVAL = 1e10  # MuJoCo's mjMAXVAL: larger |qpos|, |qvel| count as a blow-up [m, m/s]
BODY_INERTIA = 1.0  # rotational inertia of the bodies [kg m^2]; unused by slide joints
ONE_SIDED_RANGE = 1e9  # upper joint limit offset for a one-sided gap [m]
_CONTACT_FORCE_BIT = 2  # mjtConDataField force bit for the contact sensor's intprm[0]


def stability_limit(integrator: str, zeta: float) -> float:
    """Largest w0 dt for which a persistent contact (x'' + 2 zeta w0 x' + w0^2 x = 0) is stable.

    ``euler`` and ``implicitfast`` integrate constraint forces explicitly (semi-implicit
    Euler, v+ = v + h a, x+ = x + h v+): the step matrix has det = 1 - 2 zeta a and
    trace = 2 - 2 zeta a - a^2 (a = w0 dt); Jury's conditions give
    a < 2 (sqrt(1 + zeta^2) - zeta) and a < 1 / zeta. ``rk4``: the largest a with
    |P(a lambda)| <= 1 for both roots lambda, P the RK4 polynomial (found by bisection).
    """
    if integrator in ("euler", "implicitfast"):
        lim = 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta)
        return min(lim, 1.0 / zeta) if zeta > 0 else lim
    if zeta < 1.0:
        roots = [complex(-zeta, math.sqrt(1.0 - zeta * zeta))]
    else:
        sq = math.sqrt(zeta * zeta - 1.0)
        roots = [complex(-zeta + sq, 0.0), complex(-zeta - sq, 0.0)]

    def stable(a: float) -> bool:
        for lam in roots:
            z = a * lam
            if abs(1 + z + z * z / 2 + z**3 / 6 + z**4 / 24) > 1.0 + 1e-12:
                return False
        return True

    lo, hi = 0.0, 3.0 / max(1.0, abs(roots[-1]))
    while stable(hi):
        lo, hi = hi, 2.0 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


# the most permissive limit over zeta, for checks made before the scene (and its zeta) is known
_LOOSEST_LIMIT = {name: max(stability_limit(name, z / 100.0) for z in range(101)) for name in INTEGRATORS}


@contextlib.contextmanager
def _quiet_mujoco_log():
    """Silence MuJoCo's console and MUJOCO_LOG.TXT warnings while stepping: a blow-up is
    reported in the Trajectory (status, message with the warning names) instead."""
    saved = mujoco.MjLogConfig.get()
    quiet = mujoco.MjLogConfig.get()
    quiet.logto_console, quiet.logto_file = False, False
    quiet.set()
    try:
        yield
    finally:
        saved.set()


@dataclass(frozen=True)
class MujocoSettings:
    """How MuJoCo runs a scene (MuJoCo's own names where it has one)."""

    dt: float = 1e-4  # MuJoCo's timestep [s], > 0
    w0_dt: float = 0.03  # contact natural frequency times dt [-], > 0, <= stability limit
    integrator: str = "euler"  # "euler", "implicitfast" or "rk4"
    gap_model: str = "limit"  # "limit": joint range of y; "geom": wall boxes vs a ball
    solver: str = "Newton"  # MuJoCo's constraint solver: "Newton" (exact for one row), "PGS" (~35% faster), "CG"
    impedance: float = 0.99  # constant solimp d [-], in [1e-4, 0.9999]
    allow_unstable: bool = False  # accept w0_dt above the integrator's stability limit
    ball_radius: float = 0.01  # radius of body 2's sphere in the geom model [m], > 0
    wall_thickness: float = 0.01  # thickness of the wall boxes in the geom model [m], > 0
    plastic_zeta_w0_dt: float = 0.5  # for R = 0: zeta w0 dt; 0.5 stops the approach in one Euler step [-]
    fault: str = ""  # test-only: "segfault", "hang" or "raise" (engines/faults.py)

    def __post_init__(self) -> None:
        for name in ("dt", "w0_dt", "impedance", "ball_radius", "wall_thickness", "plastic_zeta_w0_dt"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SettingsError(f"mujoco.{name} = {value!r}: must be a finite number")
            object.__setattr__(self, name, float(value))
        for name in ("dt", "w0_dt", "ball_radius", "wall_thickness", "plastic_zeta_w0_dt"):
            if getattr(self, name) <= 0.0:
                raise SettingsError(f"mujoco.{name} = {getattr(self, name)!r}: must be > 0")
        if not isinstance(self.allow_unstable, bool):
            raise SettingsError(f"mujoco.allow_unstable = {self.allow_unstable!r}: must be true or false")
        if self.fault not in FAULTS:
            raise SettingsError(f"mujoco.fault = {self.fault!r}: must be one of {', '.join(repr(f) for f in FAULTS)} (test-only)")
        if self.integrator not in INTEGRATORS:
            raise SettingsError(
                f"mujoco.integrator = {self.integrator!r}: must be one of {', '.join(INTEGRATORS)}"
                + did_you_mean(str(self.integrator), list(INTEGRATORS))
            )
        if self.solver not in SOLVERS:
            raise SettingsError(
                f"mujoco.solver = {self.solver!r}: must be one of {', '.join(SOLVERS)}"
                + did_you_mean(str(self.solver), list(SOLVERS))
            )
        if self.gap_model not in GAP_MODELS:
            raise SettingsError(
                f"mujoco.gap_model = {self.gap_model!r}: must be one of {', '.join(GAP_MODELS)}"
                + did_you_mean(str(self.gap_model), GAP_MODELS)
            )
        lo, hi = IMPEDANCE_RANGE
        if not lo <= self.impedance <= hi:
            raise SettingsError(f"mujoco.impedance = {self.impedance!r}: must be in [{lo}, {hi}] (MuJoCo's solimp range)")
        # the scene's zeta is not known here: refuse what no zeta allows; build() checks
        # again with the scene's own zeta
        loosest = _LOOSEST_LIMIT[self.integrator]
        if self.w0_dt > loosest and not self.allow_unstable:
            raise SettingsError(
                f"mujoco.w0_dt = {self.w0_dt!r}: must be in (0, {loosest:.4g}], the stability limit of "
                f"{self.integrator} for any contact damping (0.1 or less keeps the restitution within ~2%); "
                "set mujoco.allow_unstable=true to run it anyway"
            )

    @property
    def w0(self) -> float:
        """Contact natural frequency [rad/s]."""
        return self.w0_dt / self.dt

    def check_stability(self, zeta: float) -> None:
        """Raise SettingsError when w0_dt exceeds the integrator's stability limit for ``zeta``."""
        limit = stability_limit(self.integrator, zeta)
        if self.w0_dt > limit and not self.allow_unstable:
            raise SettingsError(
                f"mujoco.w0_dt = {self.w0_dt!r}: must be in (0, {limit:.4g}], the stability limit of "
                f"{self.integrator} for a contact with damping ratio {zeta:.4g} (0.1 or less keeps "
                "the restitution within ~2%); set mujoco.allow_unstable=true to run it anyway"
            )

    def zeta(self, restitution: float) -> float:
        """Contact damping ratio for Newton's R (R = 0: zeta = plastic_zeta_w0_dt / w0_dt)."""
        if restitution == 0.0:
            return self.plastic_zeta_w0_dt / self.w0_dt
        return damping_ratio_from_restitution(restitution)


# -- building -------------------------------------------------------------------------


@dataclass(frozen=True)
class _Linear:
    """Springs and dampers of one target combined: -K (q - ref) - C q'."""

    stiffness: float = 0.0  # [N/m]
    ref: float = 0.0  # [m]
    damping: float = 0.0  # [N s/m]


def _combine(scene: Scene, on: str, shift: float = 0.0) -> _Linear:
    """Sum the springs (rest - shift) and dampers acting on ``on``; sum k_i (q - r_i) = K (q - sum k_i r_i / K)."""
    k = sum(f.stiffness for f in scene.forces if f.kind == "spring" and f.on == on)
    kr = sum(f.stiffness * (f.rest - shift) for f in scene.forces if f.kind == "spring" and f.on == on)
    c = sum(f.damping for f in scene.forces if f.kind == "damper" and f.on == on)
    return _Linear(k, kr / k if k > 0 else 0.0, c)


def _set_inertial(body: Any, mass: float) -> None:
    """Explicit mass at the body origin (ipos must be set, or ``to_xml`` drops the inertial)."""
    body.explicitinertial = True
    body.mass = mass
    body.inertia = [BODY_INERTIA] * 3
    body.ipos = [0.0, 0.0, 0.0]
    body.iquat = [1.0, 0.0, 0.0, 0.0]


def _set_linear(obj: Any, lin: _Linear) -> None:
    """Joint or tendon spring-damper; MuJoCo 4 takes [linear, polynomial...] coefficient triples."""
    obj.stiffness = [lin.stiffness, 0.0, 0.0]
    obj.damping = [lin.damping, 0.0, 0.0]
    if isinstance(obj, mujoco.MjsTendon):
        obj.springlength = [lin.ref, lin.ref]
    else:
        obj.springref = lin.ref


def _time_force(scene: Scene, on: str, t: np.ndarray) -> np.ndarray:
    """Sum of the constant and harmonic terms on ``on`` at times t [N], shape of t."""
    out = np.zeros_like(t)
    for f in scene.forces:
        if f.on != on:
            continue
        if f.kind == "constant":
            out += f.value
        elif f.kind == "harmonic":
            out += f.amplitude * np.sin(f.omega * t + f.phase)
    return out


def _body1_reference(scene: Scene) -> float:
    """Where an infinite body 1 sits on average [m]: its fixed x1 or the prescribed offset."""
    return scene.prescribed.offset if scene.prescribed is not None else scene.initial.x1


def _set_contact(obj: Any, k: float, b: float, d: float, gap_model: str) -> None:
    solref = [-k, -b]
    solimp = [d, d, 0.001, 0.5, 2.0]
    if gap_model == "limit":
        obj.solref_limit = solref
        obj.solimp_limit = solimp
    else:
        obj.solref = solref
        obj.solimp = solimp


def build_spec(scene: Scene, settings: MujocoSettings | None = None) -> mujoco.MjSpec:
    """The scene as an ``mujoco.MjSpec`` (see the module docstring for the layout)."""
    s = settings or MujocoSettings()
    zeta = s.zeta(scene.restitution)
    s.check_stability(zeta)
    w0 = s.w0
    k, b = w0 * w0, 2.0 * zeta * w0

    spec = mujoco.MjSpec()
    spec.modelname = f"chatterbench-{scene.name}"
    spec.option.timestep = s.dt
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.integrator = INTEGRATORS[s.integrator]
    spec.option.solver = SOLVERS[s.solver]
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT | mujoco.mjtDisableBit.mjDSBL_AUTORESET
    spec.compiler.autolimits = False
    slide = mujoco.mjtJoint.mjJNT_SLIDE

    finite = not scene.body1_infinite
    if finite:
        body1 = spec.worldbody.add_body(name="body1")
        j1 = body1.add_joint(name="x1", type=slide, axis=[1, 0, 0])
        lin1 = _combine(scene, "body1")
        _set_linear(j1, lin1)
        _set_inertial(body1, scene.mass1)
    else:
        body1 = spec.worldbody.add_body(name="body1", pos=[_body1_reference(scene), 0, 0])
        if scene.prescribed is not None:
            body1.mocap = True
            body1.pos = [scene.initial.x1, 0, 0]

    body2 = body1.add_body(name="body2")
    _set_inertial(body2, scene.mass2)
    jy = body2.add_joint(name="y", type=slide, axis=[1, 0, 0])
    lin_c = _combine(scene, "coupling")
    if finite:
        _set_linear(jy, lin_c)
        lin2 = _combine(scene, "body2")
        if lin2.stiffness > 0 or lin2.damping > 0:
            tendon = spec.add_tendon(name="x2")
            tendon.wrap_joint("x1", 1.0)
            tendon.wrap_joint("y", 1.0)
            _set_linear(tendon, lin2)
    else:
        # x2 = x1(t) + y: a body-2 spring is a y spring about rest - x1_ref, plus a time part
        lin2 = _combine(scene, "body2", shift=_body1_reference(scene))
        kk = lin_c.stiffness + lin2.stiffness
        ref = (lin_c.stiffness * lin_c.ref + lin2.stiffness * lin2.ref) / kk if kk > 0 else 0.0
        _set_linear(jy, _Linear(kk, ref, lin_c.damping + lin2.damping))

    lower, upper = scene.gap.lower, scene.gap.upper
    if s.gap_model == "limit":
        jy.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        jy.range = [lower, upper if upper is not None else lower + ONE_SIDED_RANGE]
        jy.margin = 0.0
        _set_contact(jy, k, b, s.impedance, "limit")
        spec.add_sensor(name="limit_y", type=mujoco.mjtSensor.mjSENS_JOINTLIMITFRC, objtype=mujoco.mjtObj.mjOBJ_JOINT, objname="y")
    else:
        r, h = s.ball_radius, 0.5 * s.wall_thickness
        box, side = mujoco.mjtGeom.mjGEOM_BOX, 2.0 * r
        ball = body2.add_geom(name="ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0])
        ball.contype, ball.conaffinity = 0, 1
        walls = {"lower": lower - r - h}
        if upper is not None:
            walls["upper"] = upper + r + h
        ball.density = 0.0  # the body's explicit mass is the scene's
        for wall, x in walls.items():
            g = body1.add_geom(name=wall, type=box, size=[h, side, side], pos=[x, 0, 0])
            g.contype, g.conaffinity, g.density = 1, 0, 0.0
            for geom in (g, ball):
                geom.condim = 1
                geom.margin = 0.0
                geom.gap = 0.0
                _set_contact(geom, k, b, s.impedance, "geom")
            sensor = spec.add_sensor(
                name=f"contact_{wall}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                objtype=mujoco.mjtObj.mjOBJ_GEOM, objname=wall, reftype=mujoco.mjtObj.mjOBJ_GEOM, refname="ball",
            )
            sensor.intprm = [_CONTACT_FORCE_BIT, 0, 1]

    # MuJoCo regularises with R = (1 - d)/d * diagA, diagA an approximation of the exact
    # A = J M^-1 J' (from body_invweight0), so the realised stiffness and damping are
    # (d'/d) k, (d'/d) b with d' = A / (A + R): exact for the joint limit, ~0.7% low for the
    # geom contact at d = 0.99. Measure d' on the compiled model and rescale solref by d/d'.
    factor = _impedance_factor(spec.compile(), scene, s)
    for obj in [jy] if s.gap_model == "limit" else [g for g in body1.geoms] + [ball]:
        _set_contact(obj, k * factor, b * factor, s.impedance, s.gap_model)

    for target, used in _actuated(scene).items():
        if used:
            act = spec.add_actuator(name=f"force_{target}", target=target, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.gear = [1, 0, 0, 0, 0, 0]
    return spec


def _impedance_factor(model: mujoco.MjModel, scene: Scene, s: MujocoSettings) -> float:
    """d / d' = d (A + R) / A for the contact row, probed just inside the lower wall.

    The row's Jacobian is +-e_y in joint space, so A = (M^-1)_yy exactly; R is MuJoCo's efc_R.
    """
    data = mujoco.MjData(model)
    data.qpos[-1] = scene.gap.lower - 1e-3 * s.ball_radius
    mujoco.mj_forward(model, data)
    if data.nefc != 1:  # pragma: no cover - the model has exactly one row there
        return 1.0
    e_y = np.zeros((1, model.nv))
    e_y[0, -1] = 1.0
    minv_e = np.empty((1, model.nv))
    mujoco.mj_solveM(model, data, minv_e, e_y)
    a_exact = float(minv_e[0, -1])
    return s.impedance * (a_exact + float(data.efc_R[0])) / a_exact


def _actuated(scene: Scene) -> dict[str, bool]:
    """Which joints need a motor for time-dependent forces (insertion order = ctrl order)."""
    timed = {f.on for f in scene.forces if f.kind in ("constant", "harmonic")}
    if scene.body1_infinite:
        # a prescribed body 1 always needs the inertial force -m2 x1''(t) on y
        return {"y": bool(timed) or scene.prescribed is not None}
    return {"x1": bool(timed & {"body1", "body2"}), "y": bool(timed & {"body2", "coupling"})}


def controls(scene: Scene, s: MujocoSettings, t: np.ndarray) -> np.ndarray:
    """Actuator controls [N] for steps starting at times t [s], shape (len(t), nu), in actuator order.

    Step k holds its control over [t_k, t_k + dt]: sampled at t_k, or at the midpoint for rk4.
    """
    ts = t + 0.5 * s.dt if s.integrator == "rk4" else t  # rk4 holds ctrl over the step: sample its midpoint
    f1, f2, f12 = (_time_force(scene, on, ts) for on in ("body1", "body2", "coupling"))
    cols = []
    used = _actuated(scene)
    if scene.body1_infinite:
        if used["y"]:
            u = f2 - f12
            p = scene.prescribed
            if p is not None:
                arg = p.omega * ts + p.phase
                x1 = p.amplitude * np.sin(arg)  # relative to the offset, the springref's reference
                v1 = p.amplitude * p.omega * np.cos(arg)
                a1 = -p.amplitude * p.omega**2 * np.sin(arg)
                lin2 = _combine(scene, "body2")
                u = u - lin2.stiffness * x1 - lin2.damping * v1 - scene.mass2 * a1  # x2 = x1(t) + y; inertial force
            cols.append(u)
    else:
        if used["x1"]:
            cols.append(f1 + f2)
        if used["y"]:
            cols.append(f2 - f12)
    return np.stack(cols, axis=1) if cols else np.zeros((len(t), 0))


def build(scene: Scene, settings: MujocoSettings | None = None) -> mujoco.MjModel:
    """Compile the scene's model; raises SettingsError for settings the scene cannot run with."""
    return build_spec(scene, settings).compile()


def export_mjcf(scene: Scene, settings: MujocoSettings | None = None) -> str:
    """The model as an MJCF string (``spec.to_xml()``), to paste into MuJoCo's viewer."""
    spec = build_spec(scene, settings)
    spec.compile()
    return spec.to_xml()


# -- running --------------------------------------------------------------------------


@dataclass
class _Prepared:
    """A compiled model with everything ``rollout`` needs, built before the clock starts."""

    model: mujoco.MjModel
    data: mujoco.MjData
    initial_state: np.ndarray  # (1, nstate)
    control: np.ndarray | None  # (1, nstep, ncontrol) or None
    control_spec: int
    nstep: int  # steps rolled out: n + 1 (the last gives the final sample's sensors)
    t: np.ndarray  # (n + 1,) sample times [s]


def _n_steps(scene: Scene, dt: float) -> int:
    return max(1, int(math.ceil(scene.duration / dt - 1e-9)))


def _prepare(scene: Scene, s: MujocoSettings, n: int) -> _Prepared:
    model = build(scene, s)
    data = mujoco.MjData(model)
    ini = scene.initial
    data.time = ini.t
    if scene.body1_infinite:
        data.qpos[0], data.qvel[0] = ini.y, ini.vy
    else:
        data.qpos[:] = [ini.x1, ini.y]
        data.qvel[:] = [ini.v1, ini.vy]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state0, spec)

    t = ini.t + s.dt * np.arange(n + 1)
    parts = []
    control_spec = 0
    if model.nu:
        parts.append(controls(scene, s, t))
        control_spec |= mujoco.mjtState.mjSTATE_CTRL
    if model.nmocap:  # mocap_pos comes after ctrl in mjtState order; held over step k at x1(t_{k})
        mpos = np.zeros((n + 1, 3))
        mpos[:, 0] = scene.prescribed.offset + scene.prescribed.amplitude * np.sin(scene.prescribed.omega * t + scene.prescribed.phase)
        parts.append(mpos)
        control_spec |= mujoco.mjtState.mjSTATE_MOCAP_POS
    control = np.ascontiguousarray(np.concatenate(parts, axis=1)[None]) if parts else None
    return _Prepared(model, data, state0[None], control, int(control_spec) or int(mujoco.mjtState.mjSTATE_CTRL), n + 1, t)


def _rollout(p: _Prepared) -> tuple[np.ndarray, np.ndarray]:
    state, sensordata = mj_rollout.rollout(
        p.model, p.data, p.initial_state, p.control, control_spec=p.control_spec, nstep=p.nstep
    )
    return state[0], sensordata[0]


def _settings_record(scene: Scene, s: MujocoSettings) -> dict[str, Any]:
    zeta = s.zeta(scene.restitution)
    return {
        **dataclasses.asdict(s),
        "w0": s.w0,
        "zeta": zeta,
        "solref": [-s.w0**2, -2.0 * zeta * s.w0],
        "solimp": [s.impedance, s.impedance, 0.001, 0.5, 2.0],
        "contact_duration": contact_duration(zeta, s.w0),
        "contact_time": contact_duration(zeta, s.w0),  # [s] the extraction's contact time scale
        "mujoco_version": mujoco.__version__,
    }


def _failed(scene: Scene, record: dict[str, Any], status: str, message: str) -> Trajectory:
    ini = scene.initial
    one = lambda v: np.array([float(v)])  # noqa: E731
    walls = scene.gap.walls
    return Trajectory(
        engine="mujoco", t=one(ini.t), x1=one(ini.x1), x2=one(ini.x1 + ini.y), v1=one(ini.v1), v2=one(ini.v1 + ini.vy),
        contact={w: np.zeros(1, bool) for w in walls}, normal_force={w: np.zeros(1) for w in walls},
        wall_time=0.0, settings=record, status=status, message=message,
    )


def run(scene: Scene, settings: MujocoSettings | None = None) -> Trajectory:
    """Simulate ``scene.duration`` seconds from ``scene.initial`` (see ``trajectory.py`` for shapes).

    Raises
    ------
    SettingsError
        Settings the scene cannot run with (checked before MuJoCo is called). Everything
        that goes wrong inside MuJoCo is returned as ``status = "error"`` instead.
    """
    s = settings or MujocoSettings()
    record = _settings_record(scene, s)
    n = _n_steps(scene, s.dt)
    build_spec(scene, s)  # settings errors surface here, as SettingsError, before MuJoCo runs
    try:
        p = _prepare(scene, s, n)
        with _quiet_mujoco_log():
            start = time.perf_counter()
            state, sensordata = _rollout(p)
            wall = time.perf_counter() - start
    except Exception as exc:  # an engine failure is a result, not a crash
        return _failed(scene, record, "error", f"{type(exc).__name__}: {exc}")
    return _trajectory(scene, s, p, state, sensordata, wall, record)


def _signature(p: _Prepared) -> tuple:
    """What must agree for runs to share one ``rollout`` call: sizes, steps, control layout."""
    return (p.model.signature, p.initial_state.shape[1], p.nstep, p.control_spec,
            None if p.control is None else p.control.shape[2])


def run_batch(jobs: list[tuple[Scene, MujocoSettings]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs, each group of compatible models in one ``rollout`` call.

    Runs whose compiled models share a size signature, step count and control layout (they
    may differ in anything rollout takes per model: restitution, masses, gap, initial
    state and time, forcing, w0 dt, solver options, integrator) go to ``mujoco.rollout`` as
    one batch (a list of models); the others run alone. Each trajectory is the one ``run``
    gives, bit for bit; its ``wall_time`` is its share of its batch's stepping time (batch
    wall / batch size) and ``settings["batch_size"]`` says how many shared the call.
    A batch in which MuJoCo raised a warning (a possible blow-up: the warnings are counted
    per MjData, not per run) is rerun one run at a time, so that a diverged run is
    classified alone. Raises SettingsError, like ``run``, before anything runs.
    """
    for scene, s in jobs:
        build_spec(scene, s)  # settings errors first, for every job
    out: list[Trajectory | None] = [None] * len(jobs)
    groups: dict[tuple, list[tuple[int, _Prepared]]] = {}
    for i, (scene, s) in enumerate(jobs):
        try:
            p = _prepare(scene, s, _n_steps(scene, s.dt))
        except Exception as exc:  # an engine failure is a result, not a crash
            out[i] = _failed(scene, _settings_record(scene, s), "error", f"{type(exc).__name__}: {exc}")
            continue
        groups.setdefault(_signature(p), []).append((i, p))
    for members in groups.values():
        if len(members) == 1:
            i, _ = members[0]
            out[i] = run(*jobs[i])
            continue
        ps = [p for _, p in members]
        data = mujoco.MjData(ps[0].model)
        try:
            with _quiet_mujoco_log():
                start = time.perf_counter()
                state, sensordata = mj_rollout.rollout(
                    [p.model for p in ps], data, np.concatenate([p.initial_state for p in ps]),
                    None if ps[0].control is None else np.concatenate([p.control for p in ps]),
                    control_spec=ps[0].control_spec, nstep=ps[0].nstep)
                wall = time.perf_counter() - start
        except Exception:  # rerun alone: each run's own failure is then its own result
            state = None
        if state is None or any(w.number > 0 for w in data.warning):
            for i, _ in members:
                out[i] = run(*jobs[i])
            continue
        for k, (i, p) in enumerate(members):
            scene, s = jobs[i]
            record = {**_settings_record(scene, s), "batch_size": len(members)}
            out[i] = _trajectory(scene, s, p, state[k], sensordata[k], wall / len(members), record)
    return out  # type: ignore[return-value]


def _trajectory(scene, s, p: _Prepared, state, sensordata, wall, record) -> Trajectory:
    model, n = p.model, p.nstep - 1
    nq = model.nq
    ini = scene.initial
    # sample 0 is the initial state; rollout row k is the state after step k + 1
    qpos = np.concatenate([p.initial_state[:, 1 : 1 + nq], state[:n, 1 : 1 + nq]])
    qvel = np.concatenate([p.initial_state[:, 1 + nq : 1 + 2 * nq], state[:n, 1 + nq : 1 + 2 * nq]])
    t = p.t
    # rows of sensordata are computed at the start of each step, i.e. at samples 0..n
    sens = sensordata[: n + 1]

    status, message = "ok", ""
    bad = ~(np.isfinite(qpos).all(axis=1) & np.isfinite(qvel).all(axis=1) & np.isfinite(sens).all(axis=1))
    bad |= (np.abs(qpos) > MAXVAL).any(axis=1) | (np.abs(qvel) > MAXVAL).any(axis=1)
    times = np.concatenate([[ini.t], state[:n, 0]])
    bad |= np.abs(times - t) > 1e-6 * max(s.dt, abs(t[-1]) * 1e-3)  # a reset would rewind time
    warned = [w for w in ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")
              if p.data.warning[int(getattr(mujoco.mjtWarning, w))].number > 0]
    if bad.any() or warned:
        first = int(np.argmax(bad)) if bad.any() else len(t)
        status = "diverged"
        message = (f"non-finite or huge state at t = {t[first]:.6g} s (sample {first}); "
                   f"MuJoCo warnings: {', '.join(warned) or 'none'}; w0_dt = {s.w0_dt}, integrator = {s.integrator}")
        keep = slice(0, first)
        qpos, qvel, sens, t = qpos[keep], qvel[keep], sens[keep], t[keep]

    if scene.body1_infinite:
        if scene.prescribed is not None:
            pr = scene.prescribed
            x1 = pr.offset + pr.amplitude * np.sin(pr.omega * t + pr.phase)
            v1 = pr.amplitude * pr.omega * np.cos(pr.omega * t + pr.phase)
        else:
            x1, v1 = np.full(len(t), ini.x1), np.zeros(len(t))
        y, vy = qpos[:, 0], qvel[:, 0]
    else:
        x1, v1, y, vy = qpos[:, 0], qvel[:, 0], qpos[:, 1], qvel[:, 1]

    walls = scene.gap.walls
    if s.gap_model == "limit":
        f = np.maximum(sens[:, 0], 0.0)
        if len(walls) == 2:
            upper_side = y > 0.5 * (scene.gap.lower + scene.gap.upper)  # only the wall y is beyond can push
            force = {"lower": np.where(upper_side, 0.0, f), "upper": np.where(upper_side, f, 0.0)}
        else:
            force = {"lower": f}
    else:
        force = {w: np.maximum(sens[:, 3 * i], 0.0) for i, w in enumerate(walls)}
    return Trajectory(
        engine="mujoco", t=t, x1=x1, x2=x1 + y, v1=v1, v2=v1 + vy,
        contact={w: force[w] > 0.0 for w in walls}, normal_force=force,
        wall_time=wall, settings=record, status=status, message=message,
    )


def benchmark(scene: Scene, settings: MujocoSettings | None = None, n_steps: int = 200_000, repeats: int = 3) -> dict[str, Any]:
    """Steps per second of ``run`` (all adapter work: build, controls, rollout, arrays) and of the
    bare ``mujoco.rollout`` on the same model and controls, measured in the same call (best of
    ``repeats``).

    Returns a dict with ``adapter_steps_per_s``, ``raw_steps_per_s``, ``ratio`` (adapter / raw),
    ``n_steps``, ``repeats``, ``scene``, ``mujoco_version``.
    """
    if isinstance(n_steps, bool) or not isinstance(n_steps, int) or n_steps < 1:
        raise ValueError(f"n_steps = {n_steps!r}: must be an integer >= 1")
    s = settings or MujocoSettings()
    short = dataclasses.replace(scene, duration=n_steps * s.dt)
    n = _n_steps(short, s.dt)
    p = _prepare(short, s, n)
    raw, adapter = math.inf, math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        _rollout(p)
        raw = min(raw, time.perf_counter() - start)
        start = time.perf_counter()
        traj = run(short, s)
        adapter = min(adapter, time.perf_counter() - start)
    return {
        "scene": scene.name,
        "n_steps": n,
        "repeats": repeats,
        "adapter_steps_per_s": n / adapter,
        "raw_steps_per_s": p.nstep / raw,
        "ratio": (n / adapter) / (p.nstep / raw),
        "status": traj.status,
        "mujoco_version": mujoco.__version__,
    }


class MujocoEngine:
    """The MuJoCo adapter behind the ``Engine`` protocol."""

    name = "mujoco"
    settings_type = MujocoSettings

    def build(self, scene: Scene, settings: MujocoSettings | None = None) -> mujoco.MjModel:
        """The compiled ``MjModel`` for ``scene``."""
        return build(scene, settings)

    def run(self, scene: Scene, settings: MujocoSettings | None = None) -> Trajectory:
        """Simulate ``scene``; see the module-level ``run``."""
        return run(scene, settings)
