"""The scene as files that run with plain MuJoCo: the full MJCF model and a runner that prints every impact.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.mujoco_engine.export import model_xml, runner_script, MujocoSettings
    >>> import mujoco
    >>> xml = model_xml(load_scene("bouncing-ball"), MujocoSettings(dt=3e-4, w0_dt=0.1))
    >>> model = mujoco.MjModel.from_xml_string(xml)
    >>> model.nkey, model.opt.timestep          # keyframe 0: the scene's initial state and constant forces
    (1, 0.0003)

``model_xml`` is ``build_spec``'s model, written by ``MjSpec.to_xml`` with every number put
back at full precision (``to_xml`` keeps 6 digits; a contact law that chatters amplifies the
7th into another bounce) and a keyframe ``initial`` (time, qpos, qvel, the constant part of
the motors' controls, the mocap position). Names are escaped by the XML writer; the comment
at the top never holds ``--``; the command that wrote the file is kept whole in a custom text
``chatterbench.command``. Promise, checked on every call: the file compiles to the same
``MjModel`` as the run's own (``mj_saveModel`` bytes identical), so ``mj_resetDataKeyframe(m, d, 0)``
and ``mj_step`` at ``model.opt.timestep`` give the run's trajectory bit for bit when the scene
has no time-dependent force (a harmonic force or a prescribed body 1). For those, the comment
and ``runner_script`` give the few lines that set ``data.ctrl`` (and ``data.mocap_pos``)
before each step, as the run does (``model.controls``).

``runner_script`` is a Python program (``mujoco`` only) that loads the model file beside it,
steps it for the scene's duration and prints one line per impact:
``impact t=... v_in=... v_out=... e=...`` (t the contact's start [s], v_in and v_out the relative
velocity y' at contact entry and exit [m/s], e = -v_out / v_in): a contact that has not
ended by the end of the run (resting) prints nothing.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from chatterbench.reference.forces import ForceModel
from chatterbench.reference.scene import Scene

from ..impact_lines import detection_lines, docstring, state_lines
from ..restitution import contact_duration
from .model import _actuated, build_spec, compiled, controls
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


def _spec_with_keyframe(scene: Scene, s: MujocoSettings) -> mujoco.MjSpec:
    spec = build_spec(scene, s)
    ini = scene.initial
    qpos, qvel = ([ini.y], [ini.vy]) if scene.body1_infinite else ([ini.x1, ini.y], [ini.v1, ini.vy])
    key = spec.add_key(name=KEYFRAME, time=ini.t, qpos=qpos, qvel=qvel)
    ctrl = controls(scene, s, np.array([ini.t]))[0]
    if len(ctrl):
        key.ctrl = ctrl.tolist()
    if scene.prescribed is not None:
        key.mpos = [float(scene.prescribed.position(ini.t)), 0.0, 0.0]
    return spec


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


def _control_lines(scene: Scene, s: MujocoSettings, indent: str = "") -> list[str]:
    """The Python lines that set the motors (and the mocap) before each step, from ``data.time``."""
    if not time_dependent(scene):
        return []
    half = f" + {num(0.5 * s.dt)}" if s.integrator == "rk4" else ""
    lines = [f"{indent}t = data.time{half}" + ("  # rk4 holds ctrl over the step: its midpoint" if half else "")]
    for i, (const, harm) in enumerate(harmonic_controls(scene, s)):
        terms = "".join(f" + {num(a)} * math.sin({num(w)} * t + {num(ph)})" for a, w, ph in harm)
        lines.append(f"{indent}data.ctrl[{i}] = {num(const)}{terms}")
    p = scene.prescribed
    if p is not None:
        lines.append(f"{indent}data.mocap_pos[0, 0] = {num(p.offset)} + {num(p.amplitude)} * math.sin({num(p.omega)} * "
                     f"data.time + {num(p.phase)})")
    return lines


def _header(scene: Scene, s: MujocoSettings) -> str:
    forced = _control_lines(scene, s, "       ")
    lines = [
        f" chatterbench: scene {scene.name} (Newton's R = {scene.restitution:g}) for MuJoCo {mujoco.__version__},",
        f" timestep {num(s.dt)} s, contact stiffness w0 dt = {num(s.w0_dt)}, integrator {s.integrator}, gap as a "
        f"{'joint limit on y' if s.gap_model == 'limit' else 'geom pair (walls on body1, ball on body2)'}.",
        " y = x2 - x1 is joint y (body2 inside body1); no gravity: every force is a joint or tendon spring",
        " or a motor (actuators force_*). To start from the scene's initial state:",
        "     mujoco.mj_resetDataKeyframe(model, data, 0)   # time, qpos, qvel and the constant controls",
    ]
    if forced:
        lines += [" The scene's forces change with time: before every mujoco.mj_step(model, data), set (import math)",
                  *forced, " as run.py beside a guide's model.xml does (written by chatterbench tune with an output folder)."]
    else:
        lines += [" then mujoco.mj_step(model, data) repeatedly reproduces chatterbench's run bit for bit."]
    lines.append(f" The scene lasts {num(scene.duration)} s.")
    return comment_text("\n".join(lines)) + "\n"


def model_xml(scene: Scene, settings: MujocoSettings | None = None, command: str | None = None) -> str:
    """The scene as a complete MJCF file (module docstring); raises SettingsError like ``build``.

    ``command``: the command that writes the file, kept exactly as ``<custom><text name="chatterbench.command"
    data="..."/>`` (an attribute the XML writer escapes; a comment cannot hold ``--``)."""
    s = settings or MujocoSettings()
    spec = _spec_with_keyframe(scene, s)
    root = ET.fromstring(spec.to_xml())
    _full_precision(root, spec)
    if command is not None:
        spec.add_text(name=COMMAND_TEXT, data=command)  # the run's model plus the text, to compare with
        ET.SubElement(ET.SubElement(root, "custom"), "text", name=COMMAND_TEXT, data=command)
    own = compiled(spec, scene)
    root.insert(0, ET.Comment(_header(scene, s)))
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode") + "\n"
    if _model_bytes(mujoco.MjModel.from_xml_string(text)) != _model_bytes(own):  # pragma: no cover - the promise
        raise SettingsError(f"scene {scene.name!r}: the written MJCF does not compile to the run's model")
    return text


export_mjcf = model_xml  # the name the engine packages use (``MujocoEngine``, ``MujocoWarpEngine``)


def _longest_contact(scene: Scene, s: MujocoSettings) -> int:
    """Three contact times in steps (``impact_lines``: a longer contact is a rest)."""
    duration = contact_duration(s.zeta(scene.restitution), s.w0)
    duration = duration if math.isfinite(duration) else 10.0 * math.pi / s.w0
    return max(3, math.ceil(3.0 * duration / s.dt))


def runner_script(scene: Scene, settings: MujocoSettings | None = None, model_file: str = "model.xml",
                  command: str | None = None) -> str:
    """A Python program that runs ``model_file`` (beside it) with plain MuJoCo and prints each impact; its docstring
    names ``command``, the command that wrote it, exactly."""
    s = settings or MujocoSettings()
    body = _control_lines(scene, s, "    ")
    made = [] if command is None else ["", f"Written by: {command}"]
    return "\n".join([
        *docstring([
            f"Scene {scene.name!r} in plain MuJoCo (written by chatterbench): runs {model_file} beside this file for",
            f"{num(scene.duration)} s and prints one line per impact: t (contact start [s]), v_in and v_out (the relative",
            "velocity y' = x2' - x1' at contact entry and exit [m/s]) and e = -v_out / v_in.",
            "It needs only the mujoco package: python THIS_FILE.", *made]),
        "import math",
        "from pathlib import Path",
        "",
        "import mujoco",
        "",
        f"model = mujoco.MjModel.from_xml_path(str(Path(__file__).with_name({model_file!r})))",
        "data = mujoco.MjData(model)",
        "mujoco.mj_resetDataKeyframe(model, data, 0)  # the scene's initial state and constant forces",
        'dof = model.joint("y").dofadr[0]  # y = x2 - x1, the gap coordinate',
        f"steps = round({num(scene.duration)} / model.opt.timestep)",
        *state_lines(_longest_contact(scene, s)),
        "for k in range(steps):",
        *body,
        "    t0, v0 = data.time, data.qvel[dof]",
        "    mujoco.mj_step(model, data)",
        "    # a wall pushed in this step (the constraint force from the state the step started in)",
        "    pushing = data.nefc > 0 and data.efc_force[:data.nefc].max() > 0",
        *detection_lines("    "),
        "",
    ])
