"""The scene as files that run with plain MuJoCo: the full MJCF model, starting where the scene starts, and a runner.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.mujoco_engine.export import model_xml, runner_script, MujocoSettings
    >>> import mujoco
    >>> xml = model_xml(load_scene("bouncing-ball"), MujocoSettings(dt=3e-4, w0_dt=0.1))
    >>> model = mujoco.MjModel.from_xml_string(xml)
    >>> data = mujoco.MjData(model)             # no reset: the ball 1 m up, MuJoCo's gravity along the slide axis
    >>> float(data.qpos[0]), model.opt.gravity.tolist(), model.nkey, model.opt.timestep
    (1.0, [-9.81, 0.0, 0.0], 1, 0.0003)

``model_xml`` is the run's model (``model.build_spec``: the same bodies, joints, contact law
and springs) as a user loads it (``exported_spec``): its default state is the scene's start
(joint ``ref`` and body positions make qpos0 the initial position), the scene's ``gravity`` is
MuJoCo's ``<option gravity>`` along x (the same acceleration on every body that moves), a
constant force a motor's bias (force = ctrl + the constant: ctrl carries only what changes
with time), and keyframe ``initial`` holds the initial time, position, velocity, the
controls at the initial time and the mocap position. Written by ``MjSpec.to_xml`` with every
number put back at full precision (``to_xml`` keeps 6 digits; a contact law that chatters
amplifies the 7th into another bounce); names the XML cannot hold escaped (``printable``); the
comment at the top never holds ``--``; the command that wrote the file is kept in a custom text
``chatterbench.command``. Promises: the file compiles to the exported spec's ``MjModel``
(``mj_saveModel`` bytes identical: checked on every call), and ``MjData`` + ``mj_step`` with no
reset give the run's trajectory for a scene that starts at rest with constant forces (the
ball: bit for bit with the joint-limit gap; with the geom pair the ball's world position adds
one rounding, 3e-12 m over the run); ``mj_resetDataKeyframe(m, d, 0)`` adds an initial
velocity; a time-dependent force (a harmonic force or a prescribed body 1) needs the few lines
of the comment and ``runner_script`` that set ``data.ctrl`` (and ``data.mocap_pos``) before
each step.

``runner_script`` is a Python program (``mujoco`` only) that loads the model file beside it,
steps it for the scene's duration from keyframe 0, records every sample and prints the
impacts of the run as the judge finds them (``impact_lines``): one line each, ``impact t=...
v_in=... v_out=... e=...``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from chatterbench.reference.forces import ForceModel
from chatterbench.reference.scene import Scene, scene_from_dict

from ..export import printable
from ..base import n_steps
from ..impact_lines import (acceleration_line, docstring, flight_band, force_lines, record_lines, report_lines,
                            setup_lines)
from .model import _actuated, build_spec, compiled
from .settings import MujocoSettings, SettingsError

KEYFRAME = "initial"
COMMAND_TEXT = "chatterbench.command"  # the <custom><text> that holds the command that wrote the file, exactly
# XML attribute -> MjSpec attribute where the two names differ (the rest are MuJoCo's own, the same)
_SPEC_NAMES = {"solreflimit": "solref_limit", "solimplimit": "solimp_limit", "diaginertia": "inertia"}


def num(v: float) -> str:
    """A number as text that reads back to the same double (``repr``; whole numbers without ``.0``)."""
    v = float(v)
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def comment_text(text: str) -> str:
    """``text`` safe inside an XML comment (``--`` is not allowed there)."""
    while "--" in text:
        text = text.replace("--", "- -")
    return text.rstrip("-")


def harmonic_controls(scene: Scene, s: MujocoSettings) -> list[tuple[float, list[tuple[float, float, float]]]]:
    """Each motor's control as (constant [N], [(amplitude [N], omega [rad/s], phase [rad]), ...]): the control
    at time t is constant + sum A sin(omega t + phase), what ``model.controls`` computes (to rounding)."""
    f = ForceModel.from_scene(scene)
    b1, b2, c = f.body1, f.body2, f.coupling
    neg = [(-a, w, ph) for a, w, ph in c.harmonics]
    used = _actuated(scene)
    cols = []
    if scene.body1_infinite:
        if used["y"]:
            const, harm = b2.constant - c.constant, [*b2.harmonics, *neg]
            p = scene.prescribed
            if p is not None:  # -K2 (x1 - offset) - C2 x1' - m2 x1'': x2 = x1(t) + y (model.controls)
                a, w, ph = p.amplitude, p.omega, p.phase
                harm += [(-b2.stiffness * a, w, ph), (-b2.damping * a * w, w, ph + 0.5 * math.pi),
                         (scene.mass2 * a * w * w, w, ph)]
            cols.append((const, harm))
    else:
        if used["x1"]:
            cols.append((b1.constant + b2.constant, [*b1.harmonics, *b2.harmonics]))
        if used["y"]:
            cols.append((b2.constant - c.constant, [*b2.harmonics, *neg]))
    return [(k, [h for h in harm if h[0] != 0.0]) for k, harm in cols]


def time_dependent(scene: Scene) -> bool:
    """Whether a run sets controls or the mocap every step (a harmonic force or a prescribed body 1)."""
    return scene.prescribed is not None or any(f.kind == "harmonic" for f in scene.forces)


def gravity(scene: Scene) -> float:
    """MuJoCo's gravity [m/s^2] along the slide axis x for ``scene``: its ``gravity`` (the same acceleration on every
    body that moves; an infinite body 1 is fixed or a mocap, which gravity does not move)."""
    return scene.gravity


def exported_scene(scene: Scene) -> Scene:
    """``scene`` as the exported model has it: a name XML can hold (``printable``) and no ``gravity`` (the model's
    ``<option gravity>`` is that acceleration; the motors carry every other force)."""
    data = scene.to_dict()
    data["name"] = printable(scene.name)
    data["gravity"] = 0.0
    return scene_from_dict(data)


def exported_spec(scene: Scene, s: MujocoSettings) -> mujoco.MjSpec:
    """The run's model (``model.build_spec``) as a user loads and steps it without a reset (module docstring).

    The same bodies, joints, contact law and springs, with MuJoCo gravity the scene's
    ``gravity``, every constant force a motor's bias (force = ctrl +
    the constant: ctrl carries only the time-dependent part), body and joint ``ref`` positions
    so that qpos0 is the scene's initial position, and keyframe 0 ``initial`` with the initial
    time, position, velocity, the controls at the initial time and the mocap position.
    """
    own = exported_scene(scene)
    spec = build_spec(own, s)
    g = gravity(scene)
    spec.option.gravity = [g, 0.0, 0.0]
    ini = scene.initial
    _start_at(spec.body("body2"), spec.joint("y"), ini.y)
    if not scene.body1_infinite:
        _start_at(spec.body("body1"), spec.joint("x1"), ini.x1)
    columns = harmonic_controls(own, s)
    for act, (const, _) in zip(spec.actuators, columns):
        if const != 0.0:  # the constant part of the force: the motor's bias, there whatever ctrl is
            act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
            act.biasprm = [const] + [0.0] * 9
    qpos, qvel = ([ini.y], [ini.vy]) if scene.body1_infinite else ([ini.x1, ini.y], [ini.v1, ini.vy])
    key = spec.add_key(name=KEYFRAME, time=ini.t, qpos=qpos, qvel=qvel)
    if columns:
        t = ini.t + (0.5 * s.dt if s.integrator == "rk4" else 0.0)
        key.ctrl = [sum(a * math.sin(w * t + ph) for a, w, ph in harm) for _, harm in columns]
    if scene.prescribed is not None:
        key.mpos = [float(scene.prescribed.position(ini.t)), 0.0, 0.0]
    return spec


def _start_at(body: mujoco.MjsBody, joint: mujoco.MjsJoint, q0: float) -> None:
    """Put ``body`` at joint position ``q0`` [m] in its parent's frame, with ``ref`` = q0: qpos0 is q0 and the joint
    position keeps its meaning (the body sits at ``pos`` + (q - ref) along the axis, the range and springs unchanged)."""
    joint.ref = q0
    body.pos = [float(body.pos[0]) + q0, float(body.pos[1]), float(body.pos[2])]


def _full_precision(root: ET.Element, spec: mujoco.MjSpec) -> None:
    """Rewrite every numeric attribute of ``root`` from ``spec``'s doubles (``to_xml`` keeps 6 digits)."""
    parents = {child: parent for parent in root.iter() for child in parent}
    finders = {"body": spec.body, "joint": spec.joint, "geom": spec.geom, "key": spec.key, "fixed": spec.tendon,
               "general": spec.actuator}
    for el in root.iter():
        names = dict(_SPEC_NAMES)
        if el.tag == "option":
            obj = spec.option
        elif el.tag == "inertial":
            obj = spec.body(parents[el].get("name"))
            names["pos"] = "ipos"
        elif el.tag in finders and el.get("name") is not None:
            obj = finders[el.tag](el.get("name"))
        else:
            continue
        for attr, text in list(el.attrib.items()):
            tokens = text.split()
            try:
                [float(t) for t in tokens]
            except ValueError:
                continue  # names, keywords, booleans
            value = getattr(obj, names.get(attr, attr), None)
            if value is None:
                continue
            values = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
            if len(values) >= len(tokens):
                el.set(attr, " ".join(num(v) for v in values[:len(tokens)]))


def _model_bytes(model: mujoco.MjModel) -> bytes:
    buf = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return buf.tobytes()


def _control_lines(scene: Scene, s: MujocoSettings, indent: str = "", time: str = "data.time") -> list[str]:
    """The Python lines that set the exported model's motors (their time-dependent part; the constant part is
    their bias) and the mocap before each step, at the step's start ``time`` (an expression)."""
    if not time_dependent(scene):
        return []
    half = f" + {num(0.5 * s.dt)}" if s.integrator == "rk4" else ""
    lines = [f"{indent}tc = {time}{half}" + ("  # rk4 holds ctrl over the step: its midpoint" if half else "")]
    for i, (_, harm) in enumerate(harmonic_controls(exported_scene(scene), s)):
        if harm:
            terms = " + ".join(f"{num(a)} * math.sin({num(w)} * tc + {num(ph)})" for a, w, ph in harm)
            lines.append(f"{indent}data.ctrl[{i}] = {terms}")
    p = scene.prescribed
    if p is not None:
        lines.append(f"{indent}data.mocap_pos[0, 0] = {num(p.offset)} + {num(p.amplitude)} * math.sin({num(p.omega)} * "
                     f"{time} + {num(p.phase)})")
    return lines


def _header(scene: Scene, s: MujocoSettings) -> str:
    forced = _control_lines(scene, s, "       ")
    g = gravity(scene)
    lines = [
        f" chatterbench: scene {printable(scene.name)} (Newton's R = {scene.restitution:g}) for MuJoCo "
        f"{mujoco.__version__}, timestep {num(s.dt)} s,",
        f" contact stiffness w0 dt = {num(s.w0_dt)}, integrator {s.integrator}, gap as a "
        f"{'joint limit on y' if s.gap_model == 'limit' else 'geom pair (walls on body1, ball on body2)'}.",
        " y = x2 - x1 is joint y (body2 inside body1), along x; "
        + (f"gravity {num(g)} m/s^2 along x (the scene's gravity);" if g else "no gravity;"),
        " every other force is a joint or tendon spring or a motor (actuators force_*; a constant force is the",
        " motor's bias). The model's default state is the scene's initial position (joint ref = qpos0):",
        " MjData(model) starts there. Keyframe 0 adds the initial time, velocity and controls:",
        "     mujoco.mj_resetDataKeyframe(model, data, 0)",
    ]
    if forced:
        lines += [" The scene's forces change with time: before every mujoco.mj_step(model, data), set (import math)",
                  *forced, " as run.py beside it does (chatterbench tune --out writes both)."]
    else:
        lines += [" then mujoco.mj_step(model, data) repeatedly reproduces chatterbench's run."]
    lines.append(f" The scene lasts {num(scene.duration)} s.")
    return comment_text("\n".join(lines)) + "\n"


def model_xml(scene: Scene, settings: MujocoSettings | None = None, command: str | None = None) -> str:
    """The scene as a complete MJCF file (module docstring); raises SettingsError like ``build``.

    ``command``: the command that writes the file, kept as ``<custom><text name="chatterbench.command"
    data="..."/>`` (an attribute the XML writer escapes; a comment cannot hold ``--``), exactly but for
    characters XML cannot hold (``printable``)."""
    s = settings or MujocoSettings()
    spec = exported_spec(scene, s)
    root = ET.fromstring(spec.to_xml())
    _full_precision(root, spec)
    if command is not None:
        command = printable(command)
        spec.add_text(name=COMMAND_TEXT, data=command)  # the exported model plus the text, to compare with
        ET.SubElement(ET.SubElement(root, "custom"), "text", name=COMMAND_TEXT, data=command)
    own = compiled(spec, scene)
    root.insert(0, ET.Comment(_header(scene, s)))
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode") + "\n"
    if _model_bytes(mujoco.MjModel.from_xml_string(text)) != _model_bytes(own):  # pragma: no cover - the promise
        raise SettingsError(f"scene {scene.name!r}: the written MJCF does not compile to the exported model")
    return text


export_mjcf = model_xml  # the name the engine packages use (``MujocoEngine``, ``MujocoWarpEngine``)


def _force_reading(scene: Scene, s: MujocoSettings, indent: str) -> list[str]:
    """Each wall's normal force on body 2 at the sample the step started from, as the adapter reads its sensors
    (``mujoco_common.take``): the joint limit's force on the wall y is beyond the middle of, or each wall's contact."""
    walls = scene.gap.walls
    if s.gap_model == "geom":
        return [f'{indent}forces[{w!r}].append(max(data.sensor("contact_{w}").data[0], 0.0))' for w in walls]
    lines = [f'{indent}f = max(data.sensor("limit_y").data[0], 0.0)']
    if len(walls) == 1:
        return lines + [f'{indent}forces["lower"].append(f)']
    middle = num(0.5 * (scene.gap.lower + scene.gap.upper))
    return lines + [f"{indent}upper_side = y > {middle}  # only the wall y is beyond can push",
                    f'{indent}forces["lower"].append(0.0 if upper_side else f)',
                    f'{indent}forces["upper"].append(f if upper_side else 0.0)']


def _state_lines(scene: Scene, indent: str) -> list[str]:
    """x1, v1, y, vy, x2, v2 of the sample the loop is at (body 1 fixed, prescribed or on joint x1)."""
    ini, p = scene.initial, scene.prescribed
    if not scene.body1_infinite:
        body1 = [f'{indent}x1, v1 = data.qpos[X1_Q], data.qvel[X1_V]']
    elif p is not None:
        body1 = [f"{indent}x1 = {num(p.offset)} + {num(p.amplitude)} * math.sin({num(p.omega)} * t + {num(p.phase)})",
                 f"{indent}v1 = {num(p.amplitude * p.omega)} * math.cos({num(p.omega)} * t + {num(p.phase)})"]
    else:
        body1 = [f"{indent}x1, v1 = {num(ini.x1)}, 0.0  # body 1 is fixed"]
    return [*body1, f"{indent}y, vy = data.qpos[Y_Q], data.qvel[Y_V]", f"{indent}x2, v2 = x1 + y, v1 + vy"]


def runner_script(scene: Scene, settings: MujocoSettings | None = None, model_file: str = "model.xml",
                  command: str | None = None) -> str:
    """A Python program that runs ``model_file`` (beside it) with plain MuJoCo and prints each impact as the judge
    finds it (``impact_lines``); its docstring names ``command``, the command that wrote it, exactly."""
    s = settings or MujocoSettings()
    made = [] if command is None else ["", f"Written by: {command}"]
    ini = scene.initial
    finite = [] if scene.body1_infinite else ['X1_Q, X1_V = model.joint("x1").qposadr[0], model.joint("x1").dofadr[0]']
    return "\n".join([
        *docstring([
            f"Scene {scene.name!r} in plain MuJoCo (written by chatterbench): runs {model_file} beside this file for",
            f"{num(scene.duration)} s and prints each impact as chatterbench's judge finds it: t [s], v_in and v_out (the",
            "relative velocity y' = x2' - x1' where body 2 crosses the wall's surface on its way in and out [m/s]) and",
            "e = -v_out / v_in. It needs only the mujoco package: python THIS_FILE.", *made]),
        "import math",
        "from pathlib import Path",
        "",
        "import mujoco",
        "",
        *setup_lines({w: scene.gap.position(w) for w in scene.gap.walls}, scene.restitution, flight_band(), ini.t,
                     s.dt, n_steps(scene.duration, s.dt)),
        "",
        f"model = mujoco.MjModel.from_xml_path(str(Path(__file__).with_name({model_file!r})))",
        "data = mujoco.MjData(model)  # at the scene's initial position: the model's qpos0",
        "mujoco.mj_resetDataKeyframe(model, data, 0)  # and its initial time, velocity and controls",
        'Y_Q, Y_V = model.joint("y").qposadr[0], model.joint("y").dofadr[0]  # y = x2 - x1, the gap coordinate',
        *finite,
        "for k in range(STEPS + 1):",
        "    t = T0 + k * DT",
        *_state_lines(scene, "    "),
        *force_lines(scene, "    "),
        acceleration_line(scene, "    "),
        *record_lines("    "),
        *_control_lines(scene, s, "    ", time="t"),
        "    if k < STEPS:",
        "        mujoco.mj_step(model, data)",
        "    else:",
        "        mujoco.mj_forward(model, data)  # the last sample's forces",
        "    # the walls' forces at the sample the step started from (the sensors of its first stage)",
        *_force_reading(scene, s, "    "),
        *report_lines(),
        "",
    ])
