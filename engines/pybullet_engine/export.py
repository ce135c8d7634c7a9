"""The scene as a complete PyBullet script: the adapter's world, its settings and forces, printing every impact.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.pybullet_engine.export import scene_script, PybulletSettings
    >>> text = scene_script(load_scene("bouncing-ball"), PybulletSettings(dt=1e-3))
    >>> compile(text, "scene.py", "exec") is not None, "p.changeDynamics(body1, BODY1_LINK," in text
    (True, True)

The script needs only ``pybullet``. It builds the world of ``world.build`` (body 1 carries the
walls, body 2 is a sphere, each on a prismatic joint along x; a fixed body 1 is a static base,
link -1), sets the engine with the guide's snippet (``settings.settings_snippet``, its
placeholders filled with the script's own bodies), applies every scene force each step as
the adapter does (an affine map of the state plus constant and harmonic terms, ``ForceModel.body_forces``:
``impact_lines.force_lines``), steps for the scene's duration, recording each sample as the adapter
does (each wall's normal force from the contact points of the step that ends there), and then
prints every impact as chatterbench's judge finds it, ``impact t=... v_in=... v_out=... e=...``
(``impact_lines``: the speeds where the ball crosses the wall's surface), as many as ``chatterbench
run`` counts.
"""

from __future__ import annotations

import math

from chatterbench.reference.scene import Scene

from ..base import n_steps
from ..impact_lines import (acceleration_line, docstring, flight_band, force_lines, loop_start_lines, record_lines,
                            report_lines, setup_lines)
from .settings import PybulletSettings, settings_snippet
from .world import BODY2_HALF, WALL_HALF, WALL_SIDE


def _num(v: float) -> str:
    return repr(float(v))


def scene_script(scene: Scene, settings: PybulletSettings | None = None) -> str:
    """The complete script (module docstring)."""
    s = settings or PybulletSettings()
    ini, gap, pr = scene.initial, scene.gap, scene.prescribed
    centres = [[gap.lower - BODY2_HALF - WALL_HALF, 0.0, 0.0]]
    if gap.upper is not None:
        centres.append([gap.upper + BODY2_HALF + WALL_HALF, 0.0, 0.0])
    fixed = scene.body1_infinite and pr is None
    mass1 = scene.mass1 if math.isfinite(scene.mass1) else s.mass1_inf
    pasted = settings_snippet(s, scene.restitution, {"BALL_ID": "ball", "BALL_LINK": "0", "WALL_ID": "body1",
                                                     "WALL_LINK": "BODY1_LINK"})
    pasted = pasted.replace("import pybullet as p\n", "")
    if fixed:
        body1 = [f"body1 = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=wall_shape, basePosition=[{_num(ini.x1)}, 0.0, 0.0])",
                 "BODY1_LINK = -1  # a static base: exactly infinite mass"]
    else:
        body1 = [f"body1 = slider(wall_shape, {_num(mass1)})", "BODY1_LINK = 0",
                 f"p.resetJointState(body1, 0, {_num(ini.x1)}, {_num(ini.v1)})"]
    moving1 = [] if fixed else ["    x1, v1 = p.getJointState(body1, 0)[:2]"]
    prescribe = [] if pr is None else [
        f"    x1 = {_num(pr.offset)} + {_num(pr.amplitude)} * math.sin({_num(pr.omega)} * t + {_num(pr.phase)})",
        f"    v1 = {_num(pr.amplitude * pr.omega)} * math.cos({_num(pr.omega)} * t + {_num(pr.phase)})",
        "    p.resetJointState(body1, 0, x1, v1)  # body 1's prescribed motion"]
    push1 = [] if scene.body1_infinite else [
        "    p.applyExternalForce(body1, BODY1_LINK, (f1, 0.0, 0.0), (0.0, 0.0, 0.0), p.LINK_FRAME)"]
    return "\n".join([
        *docstring([
            f"Scene {scene.name!r} in plain PyBullet (written by chatterbench): the bodies on prismatic joints along x,",
            f"the walls on body1 and a sphere on ball, stepped at dt = {_num(s.dt)} s for {_num(scene.duration)} s. Prints",
            "each impact as chatterbench's judge finds it: t [s], v_in and v_out (y' = x2' - x1' where the ball crosses",
            "the wall's surface on its way in and out [m/s]), e = -v_out / v_in. It needs only the pybullet package:",
            "python THIS_FILE."]),
        "import math",
        "",
        "import pybullet as p",
        "",
        *setup_lines({w: scene.gap.position(w) for w in scene.gap.walls}, scene.restitution, flight_band(), ini.t,
                     s.dt, n_steps(scene.duration, s.dt)),
        "",
        "p.connect(p.DIRECT)",
        "p.setGravity(0.0, 0.0, 0.0)  # every scene force, gravity included, is applied below, each step",
        f"wall_shape = p.createCollisionShapeArray(shapeTypes=[p.GEOM_BOX] * {len(centres)}, "
        f"halfExtents=[[{_num(WALL_HALF)}, {_num(WALL_SIDE)}, {_num(WALL_SIDE)}]] * {len(centres)}, "
        f"collisionFramePositions={centres!r})",
        f"ball_shape = p.createCollisionShape(p.GEOM_SPHERE, radius={_num(BODY2_HALF)})",
        "",
        "",
        "def slider(shape, mass):",
        '    """A shapeless fixed base and one link on a prismatic joint along x: the joint position is the body\'s x."""',
        "    return p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=-1, linkMasses=[mass],",
        "                             linkCollisionShapeIndices=[shape], linkVisualShapeIndices=[-1],",
        "                             linkPositions=[[0.0, 0.0, 0.0]], linkOrientations=[[0.0, 0.0, 0.0, 1.0]],",
        "                             linkInertialFramePositions=[[0.0, 0.0, 0.0]],",
        "                             linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]], linkParentIndices=[0],",
        "                             linkJointTypes=[p.JOINT_PRISMATIC], linkJointAxis=[[1.0, 0.0, 0.0]])",
        "",
        "",
        *body1,
        f"ball = slider(ball_shape, {_num(scene.mass2)})",
        f"p.resetJointState(ball, 0, {_num(ini.x1 + ini.y)}, {_num(ini.v1 + ini.vy)})",
        "for body, link in ((body1, BODY1_LINK), (ball, 0)):",
        "    if link == 0:  # PyBullet's default velocity motor would hold the joint: off",
        "        p.setJointMotorControl2(body, 0, p.VELOCITY_CONTROL, targetVelocity=0.0, force=0.0)",
        "",
        "# the guide's settings: its snippet, the placeholders filled with this script's bodies",
        pasted.rstrip(),
        "",
        *loop_start_lines(scene),
        *prescribe,
        *force_lines(scene, "    "),
        acceleration_line(scene, "    "),
        *record_lines("    "),
        "    if k == STEPS:",
        "        break",
        *push1,
        "    p.applyExternalForce(ball, 0, (f2, 0.0, 0.0), (0.0, 0.0, 0.0), p.LINK_FRAME)",
        "    p.stepSimulation()",
        *moving1,
        "    x2, v2 = p.getJointState(ball, 0)[:2]",
        "    # each wall's normal force in this step: the contact normal points from the ball to body 1, so its",
        "    # x sign names the wall (lower: -x); the force belongs to the sample the step ends at",
        "    pushed = {wall: 0.0 for wall in WALLS}",
        "    for pt in p.getContactPoints(body1, ball):",
        '        wall = "lower" if pt[7][0] < 0.0 else "upper"',
        "        if wall in pushed and pt[9] > 0.0:",
        "            pushed[wall] += pt[9]",
        "    for wall in WALLS:",
        "        forces[wall].append(pushed[wall])",
        *report_lines(),
        "",
    ])
