"""The tuning guide's MuJoCo snippet, pasted into a fresh MJCF with the scene's bodies, gives the adapter's verdicts."""

import math
import re

import mujoco
import numpy as np
import pytest

from chatterbench.comparisons.outputs.guide import guide_markdown, snippet
from chatterbench.comparisons.pipeline.compare import judge_run
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.studies.tune import tune
from chatterbench.comparisons.studies.tune.evidence import chosen_settings
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.mujoco_engine import MujocoSettings
from chatterbench.engines.mujoco_engine.snippet import contact_law, mjcf_snippet
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference import load_scene

SCENE = load_scene("feigin-pair", [f"duration={4 * math.pi}"])  # two forcing periods: four visits with chatter


def _user_model(scene, pasted: str) -> str:
    """A user's own MJCF of the scene's two bodies (written here, not by the adapter), the snippet's lines pasted in:
    body 1 on a slide joint, body 2 on a slide joint y = x2 - x1 inside it, a motor for the forcing on body 1."""
    option = re.search(r"<option[^>]*/>", pasted).group(0).replace("<option ", '<option gravity="0 0 0" ')
    joint = re.search(r"<joint[^>]*/>", pasted).group(0).replace("GAP_JOINT", "y")  # the placeholder, as the snippet says
    return f"""<mujoco model="users-own-pair">
  {option}
  <worldbody>
    <body name="carrier">
      <inertial pos="0 0 0" mass="{scene.mass1}" diaginertia="1 1 1"/>
      <joint name="x1" type="slide" axis="1 0 0"/>
      <body name="striker">
        <inertial pos="0 0 0" mass="{scene.mass2}" diaginertia="1 1 1"/>
        {joint}
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="x1" gear="1" ctrllimited="false"/></actuator>
  <sensor><jointlimitfrc joint="y"/></sensor>
</mujoco>"""


def _user_geom_model(scene, pasted: str) -> str:
    """The same two bodies with the gap as geoms, the snippet's <pair> pasted once per wall: box walls on the
    carrier, a 1 cm ball on the striker; contype/conaffinity 0, so only the explicit pairs collide."""
    option = re.search(r"<option[^>]*/>", pasted).group(0).replace("<option ", '<option gravity="0 0 0" ')
    pair = re.search(r"<pair[^>]*/>", pasted).group(0).replace("WALL_GEOM", "lower").replace("BALL_GEOM", "ball")
    r, h = 0.01, 0.005  # ball radius, half the wall thickness [m]
    lo, up = scene.gap.lower - r - h, scene.gap.upper + r + h
    return f"""<mujoco model="users-own-walls">
  {option}
  <default><geom contype="0" conaffinity="0" density="0"/></default>
  <worldbody>
    <body name="carrier">
      <inertial pos="0 0 0" mass="{scene.mass1}" diaginertia="1 1 1"/>
      <joint name="x1" type="slide" axis="1 0 0"/>
      <geom name="lower" type="box" size="{h} {2 * r} {2 * r}" pos="{lo} 0 0"/>
      <geom name="upper" type="box" size="{h} {2 * r} {2 * r}" pos="{up} 0 0"/>
      <body name="striker">
        <inertial pos="0 0 0" mass="{scene.mass2}" diaginertia="1 1 1"/>
        <joint name="y" type="slide" axis="1 0 0"/>
        <geom name="ball" type="sphere" size="{r}"/>
      </body>
    </body>
  </worldbody>
  <contact>{pair}{pair.replace('geom1="lower"', 'geom1="upper"')}</contact>
  <actuator><motor joint="x1" gear="1" ctrllimited="false"/></actuator>
</mujoco>"""


def _force_on_body1(scene, t: float) -> float:
    """The scene's forcing [N]: feigin-pair has one harmonic force on body 1 (asserted by the test)."""
    return sum(f.amplitude * math.sin(f.omega * t + f.phase) for f in scene.forces)


def _limit_forces(model, data) -> dict[str, float]:
    """The joint limit's force [N] on the wall y is nearer to (the limit pushes from that side only)."""
    f = max(float(data.sensordata[0]), 0.0)
    return {"lower": 0.0, "upper": f} if data.qpos[1] > 0 else {"lower": f, "upper": 0.0}


def _pair_forces(model, data) -> dict[str, float]:
    """Each wall's normal contact force [N], from MuJoCo's contacts (mj_contactForce)."""
    out, frame = {"lower": 0.0, "upper": 0.0}, np.zeros(6)
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, frame)
        c = data.contact[i]
        wall = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, c.geom1 if c.geom1 != model.geom("ball").id else c.geom2)
        out[wall] += max(frame[0], 0.0)
    return out


def _run_by_hand(scene, xml: str, forces=_limit_forces) -> Trajectory:
    """Step the model with mujoco.mj_step and turn its samples into the suite's Trajectory."""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    ini = scene.initial
    data.qpos[:] = [ini.x1, ini.y]
    data.qvel[:] = [ini.v1, ini.vy]
    data.time = ini.t
    dt = model.opt.timestep
    n = int(math.floor(scene.duration / dt * (1 + 1e-12)))
    t = ini.t + dt * np.arange(n + 1)
    q, v = np.empty((n + 1, 2)), np.empty((n + 1, 2))
    normal = {"lower": np.zeros(n + 1), "upper": np.zeros(n + 1)}
    q[0], v[0] = data.qpos, data.qvel
    for k in range(n + 1):
        data.ctrl[0] = _force_on_body1(scene, t[k])  # held over the step, as a user's control loop does
        if k == n:
            mujoco.mj_forward(model, data)  # the last sample's forces
        else:
            mujoco.mj_step(model, data)  # forces computed at the start of step k: those of sample k
        for wall, f in forces(model, data).items():
            normal[wall][k] = f
        if k < n:
            q[k + 1], v[k + 1] = data.qpos, data.qvel
    x1, y, v1, vy = q[:, 0], q[:, 1], v[:, 0], v[:, 1]
    return Trajectory(engine="mujoco", t=t, x1=x1, x2=x1 + y, v1=v1, v2=v1 + vy,
                      contact={w: normal[w] > 0 for w in normal}, normal_force=normal, wall_time=0.0)


@pytest.mark.slow
def test_pasted_snippet_gives_the_tuned_verdicts():
    assert [(f.kind, f.on) for f in SCENE.forces] == [("harmonic", "body1")]  # what _force_on_body1 assumes
    # the brief's case, on a short scene: tolerance 0.01, stiffer contacts than the default and solimp in the space
    space = {"dt": (1e-3, 3e-4), "mujoco.w0_dt": (0.03, 0.3), "mujoco.impedance": (0.99, 0.9999)}
    result = tune(SCENE, "mujoco", 0.01, space=space, workers=2, refine_steps=1, ladder=None)  # the asked answer only
    chosen = result.chosen
    assert chosen is not None
    # every cheaper failing candidate is in the guide with the check it failed and its measure
    text = guide_markdown(result)
    cheaper = result.cheaper()
    assert len(cheaper) > 0
    for row in cheaper.itertuples():
        assert row.failed and (" > " in row.failed or "episode" in row.failed), row.settings
        assert row.failed.replace("|", "\\|") in text or row.failed in text
    # the snippet, pasted into the user's own model, gives the same verdicts as the adapter's run
    pasted = snippet(result)
    assert 'solreflimit="-' in pasted and "<option" in pasted and "<pair" in pasted
    ref = solve(SCENE)
    settings = chosen_settings(result)
    _, adapter_table, _ = judge_run(ref, "mujoco", settings, result.tolerance)
    _, pasted_table, _ = judge_run(ref, "mujoco", settings, result.tolerance, trajectory=_run_by_hand(SCENE, _user_model(SCENE, pasted)))
    assert pasted_table["verdict"].tolist() == adapter_table["verdict"].tolist()
    assert len(adapter_table) >= 4
    # the same law, not just the same verdicts: sticking starts within one timestep of the adapter's
    # (the snippet writes every number so that it reads back to the same double: measured identical)
    np.testing.assert_allclose(pasted_table["t_stick"], adapter_table["t_stick"], atol=settings.dt)


def test_the_pasted_geom_pair_gives_the_geom_models_verdicts():
    # the snippet's other form: the same law as a <pair> of a wall box and a ball, in the user's own model
    s = MujocoSettings(dt=3e-4, w0_dt=0.1, gap_model="geom")
    ref, tol = solve(SCENE), Tolerances()
    _, adapter_table, _ = judge_run(ref, "mujoco", s, tol)
    pasted = _run_by_hand(SCENE, _user_geom_model(SCENE, mjcf_snippet(SCENE, s)), _pair_forces)
    _, table, _ = judge_run(ref, "mujoco", s, tol, trajectory=pasted)
    assert table["verdict"].tolist() == adapter_table["verdict"].tolist()
    # the same contact law: sticking starts within one timestep of the adapter's geom model
    np.testing.assert_allclose(table["t_stick"], adapter_table["t_stick"], atol=s.dt)


def test_the_paste_check_catches_a_wrong_snippet():
    # known answers both ways, at one fixed setting: the snippet as written reproduces the adapter's verdicts;
    # the same paste with the contact's damping doubled (a different restitution) does not
    s = MujocoSettings(dt=3e-4, w0_dt=0.3)
    pasted, law = mjcf_snippet(SCENE, s), contact_law(SCENE, s)
    wrong = pasted.replace(f'solreflimit="{law.solref}"', f'solreflimit="-{law.stiffness:.10g} -{2 * law.damping:.10g}"')
    assert wrong != pasted
    ref, tol = solve(SCENE), Tolerances()
    _, adapter_table, _ = judge_run(ref, "mujoco", s, tol)
    _, good, _ = judge_run(ref, "mujoco", s, tol, trajectory=_run_by_hand(SCENE, _user_model(SCENE, pasted)))
    _, bad, _ = judge_run(ref, "mujoco", s, tol, trajectory=_run_by_hand(SCENE, _user_model(SCENE, wrong)))
    assert good["verdict"].tolist() == adapter_table["verdict"].tolist()
    assert bad["verdict"].tolist() != adapter_table["verdict"].tolist()
