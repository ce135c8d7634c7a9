"""The scene as a complete Newton script: the adapter's world, its settings and forces, printing every impact.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.newton_engine.export import scene_script
    >>> from chatterbench.engines.newton_engine.settings import SemiSettings
    >>> text = scene_script(load_scene("bouncing-ball"), SemiSettings(dt=1e-3), "semi")
    >>> compile(text, "scene.py", "exec") is not None, "newton.solvers.SolverSemiImplicit(" in text
    (True, True)

The script needs only ``newton`` (with warp and numpy, which it brings). It builds the world of
``world.World`` (x the up axis, body 2 a sphere and body 1's walls as boxes, each moving body on a
prismatic joint along x, a fixed body 1 as static shapes), with the snippet's shape settings
(``snippet``: restitution for XPBD, ke and kd for the penalty contact), captures one step as a warp
graph and replays it, applying every scene force each step as the adapter does (``impact_lines.force_lines``, the
weights the model adds taken off), records each sample as the adapter does (each wall's push: from
body 2's momentum for XPBD, the penalty force at the step's start for the semi-implicit solver), and
then prints every impact as chatterbench's judge finds it (``impact_lines``).
"""

from __future__ import annotations

from typing import Any

from chatterbench.reference.scene import Scene

from ..base import n_steps
from ..impact_lines import (acceleration_line, docstring, flight_band, force_lines, loop_start_lines, record_lines,
                            report_lines, setup_lines)
from .penalty import ke_kd, relative_mass
from .world import (BODY2_HALF, DETECT_GAP, IMPULSE_ABSOLUTE_TOLERANCE, IMPULSE_RELATIVE_TOLERANCE, INERTIA, WALL_HALF,
                    WALL_SIDE)


def _num(v: float) -> str:
    return repr(float(v))


def snippet(scene: Scene, settings: Any, solver: str) -> str:
    """The settings as Newton code a user pastes: every shape's ``ShapeConfig`` and the solver with its arguments."""
    if solver == "xpbd":
        s = settings
        solver_line = (f"solver = newton.solvers.SolverXPBD(model, enable_restitution=True, iterations={s.iterations}, "
                       f"rigid_contact_relaxation={_num(s.rigid_contact_relaxation)}, "
                       f"rigid_contact_restitution_iterations={s.restitution_iterations}, angular_damping=0.0)")
        cfg = (f"cfg = newton.ModelBuilder.ShapeConfig(restitution={_num(scene.restitution)}, mu=0.0, kf=0.0, "
               f"density=0.0, gap={_num(DETECT_GAP * s.length_unit)})  # every shape: XPBD averages the two shapes' "
               "restitution")
        note = (f"# XPBD's restitution acts on approach speeds above 2 |g| dt = {_num(s.threshold(scene.gravity))} m/s "
                f"(g in the model); slower impacts are plastic; lengths in units of 1 / {_num(s.length_unit)} m (XPBD "
                "sets speeds below 1e-4 units/s to 0)")
    else:
        ke, kd = ke_kd(settings.w0, settings.zeta(scene.restitution), relative_mass(scene.mass1, scene.mass2))
        solver_line = "solver = newton.solvers.SolverSemiImplicit(model, angular_damping=0.0)"
        cfg = (f"cfg = newton.ModelBuilder.ShapeConfig(ke={_num(ke)}, kd={_num(kd)}, restitution={_num(scene.restitution)}, "
               f"mu=0.0, kf=0.0, ka=0.0, density=0.0, gap={_num(DETECT_GAP)})  # every shape: ke, kd are averaged")
        note = (f"# penalty contact: w0 = {_num(settings.w0)} rad/s, zeta = {_num(settings.zeta(scene.restitution))} "
                "(damped while compressing only): e = R for the relative mass m1 m2 / (m1 + m2)")
    return "\n".join(["import newton", "", f"DT = {_num(settings.dt)}  # [s] the step", note, cfg,
                      "# ... build the model with cfg on every shape, then model = builder.finalize()", solver_line, ""])


def scene_script(scene: Scene, settings: Any, solver: str) -> str:
    """The complete script (module docstring)."""
    s = settings
    ini, gap = scene.initial, scene.gap
    finite1 = not scene.body1_infinite
    g = scene.gravity if s.gravity_in_model else 0.0
    L = getattr(s, "length_unit", 1.0)  # model length units per metre (XPBD's ``length_unit``)
    faces = [gap.lower - BODY2_HALF - WALL_HALF] + ([gap.upper + BODY2_HALF + WALL_HALF] if gap.upper is not None else [])
    pr = scene.prescribed
    i1, i2 = (0, 1) if finite1 or pr is not None else (None, 0)
    pasted = snippet(scene, s, solver).replace("import newton\n", "").rstrip().splitlines()
    solver_line, pasted = pasted[-1], "\n".join(line for line in pasted[:-1] if not line.startswith("# ..."))
    walls_box = (f"    builder.add_shape_box({{body}}, xform=wp.transform(wp.vec3({{x}}, 0.0, 0.0), wp.quat_identity()), "
                 f"hx={_num(L * WALL_HALF)}, hy={_num(L * WALL_SIDE)}, hz={_num(L * WALL_SIDE)}, cfg=cfg)")
    if i1 is not None:
        mass1 = "1.0, is_kinematic=True" if pr is not None else _num(scene.mass1)  # prescribed: moved each step
        body1 = [f"body1 = builder.add_link(xform=wp.transform(wp.vec3({_num(L * ini.x1)}, 0.0, 0.0), wp.quat_identity()), "
                 f"mass={mass1}, inertia=inertia)",
                 f"for x in {[L * f for f in faces]!r}:", walls_box.format(body="body1", x="x"),
                 "joints.append(builder.add_joint_prismatic(-1, body1, axis=newton.Axis.X))"]
    else:
        body1 = [f"for x in {[L * (ini.x1 + f) for f in faces]!r}:  # a fixed body 1: static shapes",
                 walls_box.format(body="-1", x="x")]
    if solver == "xpbd":
        push = ["    v_free = v2 + f2 * DT / M2",
                "    step()",
                *_read(finite1, i1, i2),
                "    dv = v2 - v_free  # body 2's momentum beyond its forces: the walls' push",
                f"    if abs(dv) > {_num(IMPULSE_RELATIVE_TOLERANCE)} * (abs(v_free) + abs(f2 * DT / M2)) + "
                f"{_num(IMPULSE_ABSOLUTE_TOLERANCE)}:",
                "        push = M2 * dv / DT",
                "        pushed['lower' if push > 0.0 else 'upper'] = abs(push)"]
    else:
        ke, kd = ke_kd(s.w0, s.zeta(scene.restitution), relative_mass(scene.mass1, scene.mass2))
        push = [f"    d = y - WALLS['lower']  # the penalty force Newton evaluates at the step's start: ke {_num(ke)}, kd {_num(kd)}",
                "    if d < 0.0:",
                f"        pushed['lower'] = {_num(ke)} * -d + {_num(kd)} * max(-vy, 0.0)",
                "    if 'upper' in WALLS and WALLS['upper'] - y < 0.0:",
                f"        pushed['upper'] = {_num(ke)} * (y - WALLS['upper']) + {_num(kd)} * max(vy, 0.0)",
                "    step()",
                *_read(finite1, i1, i2)]
    return "\n".join([
        *docstring([
            f"Scene {scene.name!r} in plain Newton (written by chatterbench): the bodies on prismatic joints along x, the",
            f"walls on body 1 and a sphere on body 2, {solver} solver, stepped at dt = {_num(s.dt)} s for {_num(scene.duration)} s",
            "(one step captured as a warp graph and replayed). Prints each impact as chatterbench's judge finds it: t [s],",
            "v_in and v_out (y' = x2' - x1' where body 2 crosses the wall's surface on its way in and out [m/s]),",
            "e = -v_out / v_in. It needs only the newton package: python THIS_FILE."]),
        "import math",
        "",
        "import numpy as np",
        "import warp as wp",
        "",
        "wp.config.quiet = True",
        "wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)",
        "wp.config.enable_backward = False  # forward kernels only, as chatterbench builds them: half the compile",
        "import newton  # noqa: E402",
        "",
        *setup_lines({w: scene.gap.position(w) for w in scene.gap.walls}, scene.restitution, flight_band(), ini.t,
                     s.dt, n_steps(scene.duration, s.dt)),
        "",
        "# the guide's settings: the snippet",
        pasted.rstrip(),
        "",
        f"M2, G = {_num(scene.mass2)}, {_num(g)}  # body 2's mass [kg]; the gravity in Newton's model [m/s^2] along x",
        f"L = {_num(L)}  # Newton's length units per metre: lengths, speeds and forces to the model x L, back / L",
        "builder = newton.ModelBuilder(up_axis=newton.Axis.X, gravity=(G * L, 0.0, 0.0))",
        f"inertia = wp.mat33(np.eye(3) * {_num(INERTIA)})  # never used along x, only inverted",
        "joints = []",
        *body1,
        f"ball = builder.add_link(xform=wp.transform(wp.vec3({_num(L * (ini.x1 + ini.y))}, 0.0, 0.0), wp.quat_identity()), "
        f"mass=M2, inertia=inertia)",
        f"builder.add_shape_sphere(ball, radius={_num(L * BODY2_HALF)}, cfg=cfg)",
        "joints.append(builder.add_joint_prismatic(-1, ball, axis=newton.Axis.X))",
        "for j in joints:",
        "    builder.add_articulation([j])",
        "model = builder.finalize()",
        solver_line,
        "s0, s1, control = model.state(), model.state(), model.control()  # the step goes s0 -> s1, copied back",
        "qd0 = s0.body_qd.numpy().copy()",
        *([f"qd0[{i1}, 0] = L * {_num(ini.v1)}"] if i1 is not None else []),
        f"qd0[{i2}, 0] = L * {_num(ini.v1 + ini.vy)}",
        "s0.body_qd.assign(qd0)",
        "pipeline = newton.CollisionPipeline(model)",
        "contacts = pipeline.contacts()",
        "s0.clear_forces()",
        "",
        "",
        "def one():",
        "    pipeline.collide(s0, contacts)",
        "    solver.step(s0, s1, control, contacts, DT)",
        "    wp.copy(s0.body_q, s1.body_q)",
        "    wp.copy(s0.body_qd, s1.body_qd)",
        "",
        "",
        "one()  # loads the kernels (a capture cannot), then back to the start",
        "s0.body_q.assign(model.body_q)",
        "s0.body_qd.assign(qd0)",
        "with wp.ScopedCapture() as captured:",
        "    one()",
        "",
        "",
        "def step():",
        "    s0.body_f.assign(body_f)",
        "    wp.capture_launch(captured.graph)",
        "",
        "",
        "body_f = np.zeros((model.body_count, 6), np.float32)  # the forces of the next step [N]",
        *loop_start_lines(scene),
        *([] if pr is None else [
            f"    x1 = {_num(pr.offset)} + {_num(pr.amplitude)} * math.sin({_num(pr.omega)} * t + {_num(pr.phase)})",
            f"    v1 = {_num(pr.amplitude * pr.omega)} * math.cos({_num(pr.omega)} * t + {_num(pr.phase)})",
            "    y, vy = x2 - x1, v2 - v1  # body 1's prescribed motion",
            "    q, qd = s0.body_q.numpy(), s0.body_qd.numpy()",
            f"    q[{i1}, 0], qd[{i1}, 0] = L * x1, L * v1  # the kinematic body 1 put on its path",
            "    s0.body_q.assign(q)",
            "    s0.body_qd.assign(qd)"]),
        *force_lines(scene, "    "),
        acceleration_line(scene, "    "),
        *record_lines("    "),
        "    if k == STEPS:",
        "        break",
        *([f"    body_f[{i1}, 0] = (f1 - {_num(scene.mass1)} * G) * L  # Newton adds the weight itself"] if finite1
          else []),
        "    body_f[%d, 0] = (f2 - M2 * G) * L" % i2,
        "    pushed = {wall: 0.0 for wall in WALLS}",
        *push,
        "    for wall in WALLS:",
        "        forces[wall].append(pushed[wall])",
        *report_lines(),
        "",
    ])


def _read(finite1: bool, i1: int | None, i2: int) -> list[str]:
    """Lines reading the state after a step (body 1 stays where it is when fixed)."""
    lines = ["    q, qd = s0.body_q.numpy(), s0.body_qd.numpy()"]
    if finite1:
        lines.append(f"    x1, v1 = float(q[{i1}, 0]) / L, float(qd[{i1}, 0]) / L")
    return lines + [f"    x2, v2 = float(q[{i2}, 0]) / L, float(qd[{i2}, 0]) / L"]
