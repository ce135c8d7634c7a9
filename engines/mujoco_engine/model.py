"""The scene as a MuJoCo model: two slide joints, the gap as a joint range or as geoms, forces as springs and motors.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.mujoco_engine.model import build, MujocoSettings
    >>> model = build(load_scene("feigin-pair"), MujocoSettings(dt=1e-4))
    >>> model.nq, model.nu                     # x1 and y; one motor on x1 for the forcing
    (2, 1)

The layout and the contact law are in the package docstring; ``export.py`` writes the model as a complete MJCF file. Forces come from the scene's
one force model (``reference.forces.ForceModel``): each target's springs and dampers become
joint (body 1, coupling) or tendon (body 2: x2 = x1 + y) stiffness, damping and rest, its
constant and harmonic terms and the weights of the scene's gravity motor controls (MuJoCo's own
gravity stays 0 here; the exported file uses it, ``export.py``); a prescribed body 1 moves by
``Prescribed.position`` and enters y through the inertial force -m2 ``Prescribed.acceleration``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from chatterbench.reference.forces import ForceModel, Terms
from chatterbench.reference.scene import Scene

from .settings import INTEGRATORS, SOLVERS, MujocoSettings, SettingsError

BODY_INERTIA = 1.0  # rotational inertia of the bodies [kg m^2]; unused by slide joints
ONE_SIDED_RANGE = 1e9  # upper joint limit offset for a one-sided gap [m]
CONTACT_FORCE_BIT = 2  # mjtConDataField force bit for the contact sensor's intprm[0]


@dataclass(frozen=True)
class _Linear:
    """Springs and dampers of one target combined: -K (q - ref) - C q'."""

    stiffness: float = 0.0  # [N/m]
    ref: float = 0.0  # [m]
    damping: float = 0.0  # [N s/m]


def _linear(terms: Terms, shift: float = 0.0) -> _Linear:
    """The springs and dampers of one target of the scene's force model, the rest measured from ``shift`` [m]."""
    return _Linear(terms.stiffness, terms.rest - shift if terms.stiffness > 0 else 0.0, terms.damping)


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
    return spec_and_factor(scene, settings)[0]


def contact_law(scene: Scene, s: MujocoSettings) -> tuple[float, float]:
    """The contact's stiffness k = w0^2 [1/s^2] and damping b = 2 zeta w0 [1/s] before the impedance rescaling;
    SettingsError when w0 dt is past the integrator's stability limit for the scene's R."""
    zeta = s.zeta(scene.restitution)
    s.check_stability(zeta)
    w0 = s.w0
    return w0 * w0, 2.0 * zeta * w0


def spec_and_factor(scene: Scene, settings: MujocoSettings | None = None) -> tuple[mujoco.MjSpec, float]:
    """``build_spec``, and the factor d / d' its contact's solref was rescaled by (``_impedance_factor``)."""
    s = settings or MujocoSettings()
    k, b = contact_law(scene, s)

    spec = mujoco.MjSpec()
    spec.modelname = f"chatterbench-{scene.name}"
    spec.option.timestep = s.dt
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.integrator = INTEGRATORS[s.integrator]
    spec.option.solver = SOLVERS[s.solver]
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT | mujoco.mjtDisableBit.mjDSBL_AUTORESET
    spec.compiler.autolimits = False
    slide = mujoco.mjtJoint.mjJNT_SLIDE

    forces = ForceModel.from_scene(scene)
    finite = not scene.body1_infinite
    if finite:
        body1 = spec.worldbody.add_body(name="body1")
        j1 = body1.add_joint(name="x1", type=slide, axis=[1, 0, 0])
        lin1 = _linear(forces.body1)
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
    lin_c = _linear(forces.coupling)
    if finite:
        _set_linear(jy, lin_c)
        lin2 = _linear(forces.body2)
        if lin2.stiffness > 0 or lin2.damping > 0:
            tendon = spec.add_tendon(name="x2")
            tendon.wrap_joint("x1", 1.0)
            tendon.wrap_joint("y", 1.0)
            _set_linear(tendon, lin2)
    else:
        # x2 = x1(t) + y: a body-2 spring is a y spring about rest - x1_ref, plus a time part
        lin2 = _linear(forces.body2, shift=_body1_reference(scene))
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
            sensor.intprm = [CONTACT_FORCE_BIT, 0, 1]

    # MuJoCo regularises with R = (1 - d)/d * diagA, diagA an approximation of the exact
    # A = J M^-1 J' (from body_invweight0), so the realised stiffness and damping are
    # (d'/d) k, (d'/d) b with d' = A / (A + R): exact for the joint limit, ~0.7% low for the
    # geom contact at d = 0.99. Measure d' on the compiled model and rescale solref by d/d'.
    factor = _impedance_factor(compiled(spec, scene), scene, s)
    for obj in [jy] if s.gap_model == "limit" else [g for g in body1.geoms] + [ball]:
        _set_contact(obj, k * factor, b * factor, s.impedance, s.gap_model)

    for target, used in _actuated(scene).items():
        if used:
            act = spec.add_actuator(name=f"force_{target}", target=target, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.gear = [1, 0, 0, 0, 0, 0]
    return spec, factor


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
    if scene.gravity != 0.0:  # the weights m g: time terms of both bodies (ForceModel), motor controls here
        timed |= {"body1", "body2"}
    if scene.body1_infinite:
        # a prescribed body 1 always needs the inertial force -m2 x1''(t) on y
        return {"y": bool(timed) or scene.prescribed is not None}
    return {"x1": bool(timed & {"body1", "body2"}), "y": bool(timed & {"body2", "coupling"})}


def controls(scene: Scene, s: MujocoSettings, t: np.ndarray) -> np.ndarray:
    """Actuator controls [N] for steps starting at times t [s], shape (len(t), nu), in actuator order.

    Step k holds its control over [t_k, t_k + dt]: sampled at t_k, or at the midpoint for rk4.
    """
    ts = t + 0.5 * s.dt if s.integrator == "rk4" else t  # rk4 holds ctrl over the step: sample its midpoint
    forces = ForceModel.from_scene(scene)
    f1, f2, f12 = (terms.time_part(ts) for terms in (forces.body1, forces.body2, forces.coupling))
    cols = []
    used = _actuated(scene)
    if scene.body1_infinite:
        if used["y"]:
            u = f2 - f12
            p = scene.prescribed
            if p is not None:
                x1 = p.position(ts) - p.offset  # relative to the offset, the springref's reference
                lin2 = _linear(forces.body2)
                # x2 = x1(t) + y: body 2's springs and dampers see x1(t), and y the inertial force -m2 x1''
                u = u - lin2.stiffness * x1 - lin2.damping * p.velocity(ts) - scene.mass2 * p.acceleration(ts)
            cols.append(u)
    else:
        if used["x1"]:
            cols.append(f1 + f2)
        if used["y"]:
            cols.append(f2 - f12)
    return np.stack(cols, axis=1) if cols else np.zeros((len(t), 0))


def compiled(spec: mujoco.MjSpec, scene: Scene) -> mujoco.MjModel:
    """``spec.compile()``; a scene MuJoCo's compiler refuses (a mass below its mjMINVAL = 1e-15) is a SettingsError."""
    try:
        return spec.compile()
    except ValueError as exc:
        reason = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
        raise SettingsError(f"MuJoCo cannot build scene {scene.name!r} (mass1 = {scene.mass1:g}, mass2 = "
                            f"{scene.mass2:g} kg): {reason}") from None


def build(scene: Scene, settings: MujocoSettings | None = None) -> mujoco.MjModel:
    """Compile the scene's model; raises SettingsError for settings the scene cannot run with."""
    return compiled(build_spec(scene, settings), scene)
