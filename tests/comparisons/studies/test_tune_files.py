"""The files `tune --out` writes beside the guide, and the guide's snippets, used as a user uses them: run as written
or pasted into models and scripts written from scratch, in fresh processes that do not import chatterbench."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from chatterbench.comparisons.outputs.engine_files import write_engine_files
from chatterbench.comparisons.pipeline.extract import extract
from chatterbench.comparisons.outputs.guide import guide_markdown
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.tune import tune
from chatterbench.comparisons.studies.tune.evidence import chosen_settings, evidence
from chatterbench.engines.registry import run_engine
from chatterbench.reference import load_scene

# one candidate per engine, each passing every check of TOL (restitution and persistence included): measured.
# MuJoCo at impedance 0.95 (its 0.99 flickers after the stick: buzz); PyBullet with a bounce threshold that ends
# its g dt bounces after the stick (threshold 0: buzz) and still resolves feigin-pair's slow impacts (0.01 m/s)
SPACES = {"mujoco": {"dt": (3e-4,), "mujoco.w0_dt": (0.1,), "mujoco.impedance": (0.95,)},
          "pybullet": {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.02,)}}
SPACE_OF = {("feigin-pair", "pybullet"): {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.01,)}}
SCENES = {"bouncing-ball": load_scene("bouncing-ball"),
          "feigin-pair": load_scene("feigin-pair", [f"duration={2 * math.pi}"])}  # one period: two visits with chatter
# MuJoCo's compliant contact under the scene's forces loses up to 11% of R at the slowest resolved impacts
# (measured: -0.112 at 0.0162 m/s on feigin-pair, -0.091 at 0.277 m/s on the ball, dt = 3e-4, w0 dt = 0.1)
TOL = Tolerances(stick=0.1, exit=0.1, first_impact=0.1, restitution=0.2)
LINE = re.compile(r"^impact t=(\S+) v_in=(\S+) v_out=(\S+) e=(\S+)$")


@pytest.fixture(scope="module")
def tuned(tmp_path_factory):
    """tuned(scene, engine): one tune per scene and engine (a one-candidate space), made once for the module, with
    its engine files written as `tune --out` writes them; returns (result, out dir, written files)."""
    done = {}

    def get(scene_name: str, engine: str):
        if (scene_name, engine) not in done:
            result = tune(SCENES[scene_name], engine, TOL, space=SPACE_OF.get((scene_name, engine), SPACES[engine]), workers=1, refine_steps=0,
                          check_robust=False, ladder=None)  # the asked tolerances alone: the files are at its answer
            out = tmp_path_factory.mktemp(f"{scene_name}-{engine}")
            done[scene_name, engine] = result, out, write_engine_files(result, out)
        return done[scene_name, engine]
    return get


def run_python(path: Path, cwd: Path | None = None) -> str:
    """Run a file with a fresh interpreter (no chatterbench import in it); its stdout."""
    done = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, cwd=cwd or path.parent, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


REST = re.compile(r"^rest wall=(\w+) t0=(\S+) t1=(\S+) onsets=(\d+) onsets_per_s=(\S+) open=(\S+) gap_max=(\S+)$")


def printed_rests(stdout: str) -> list[tuple[str, float, float, int, float, float, float]]:
    """The script's rest lines (after the impacts): wall, t0, t1, onsets, onsets per second, open share, largest gap."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("# rest: "))
    rows = [REST.match(line) for line in lines[start + 1:]]
    assert all(rows), lines[start + 1:][:3]
    return [(m.group(1), *(float(v) for v in m.groups()[1:3]), int(m.group(4)), *(float(v) for v in m.groups()[4:]))
            for m in rows]


def printed_impacts(stdout: str) -> list[tuple[float, float, float, float]]:
    header, *lines = stdout.splitlines()
    assert header.startswith("# impact: ")  # which contacts count (engines/impact_lines.py)
    lines = lines[:next(i for i, line in enumerate(lines) if line.startswith("# rest: "))]
    rows = [LINE.match(line) for line in lines]
    assert all(rows), [line for line, m in zip(stdout.splitlines(), rows) if not m][:3]
    return [tuple(float(v) for v in m.groups()) for m in rows]


@pytest.mark.parametrize("scene_name", SCENES)
@pytest.mark.parametrize("engine", SPACES)
def test_tune_files_print_the_runs_impacts_with_the_guides_restitution(tuned, scene_name, engine):
    result, out, written = tuned(scene_name, engine)
    engine, scene = result.engine, result.scene
    expected = {"mujoco": ["mujoco/model.xml", "mujoco/run.py"], "pybullet": ["pybullet/scene.py"]}[engine]
    assert written == expected  # at the chosen settings
    stdout = run_python(out / expected[-1])
    printed = printed_impacts(stdout)
    # after each of the reference's sticks the contact stays closed, as the judge found it (these settings pass)
    rests = printed_rests(stdout)
    assert len(rests) == len(result.extra["solution"].episodes)
    assert all(onsets == 0 and share == 0.0 for _, _, _, onsets, _, share, _ in rests), rests
    # the run's impacts, as the judge counts them at the tune's tolerances (the issue: `run ... --export-model
    # scene.py` counted 9 impacts of the ball, the script printed 11)
    settings = chosen_settings(result)
    ref = result.extra["solution"]
    found = extract(run_engine(engine, scene, settings), scene, ref.stick_tolerance(result.tolerance.stick))
    assert len(printed) == int((found.log["kind"] == "impact").sum()) >= 5
    # at every impact the guide lists (the run's resolved impacts as the judge measures them), the printed e is the
    # guide's number within 1% (measured: to the 4 digits the guide prints; the script's run repeats the adapter's)
    text = guide_markdown(result, ev=evidence(result, speeds=[1.0]))
    claim = next(line for line in text.splitlines() if line.startswith("**The run's impacts:**"))
    listed = [tuple(map(float, m)) for m in re.findall(r"#\d+ at t = (\S+) s, (\S+) m/s: e = (\d\.\d{4})", claim)]
    assert len(listed) >= 3 and f"`{expected[-1]}` prints each of them" in claim
    times = [t for t, *_ in printed]
    for t_guide, v_guide, e_guide in listed:
        t, v_in, v_out, e = printed[min(range(len(times)), key=lambda i: abs(times[i] - t_guide))]
        assert t == pytest.approx(t_guide, abs=1e-4) and abs(v_in) == pytest.approx(v_guide, rel=5e-3)
        assert e == pytest.approx(e_guide, rel=0.01) and e == pytest.approx(e_guide, abs=6e-5)  # 4 printed digits


def test_tunes_mujoco_model_starts_where_the_scene_starts_and_reproduces_the_run(tuned):
    # loaded as MuJoCo's viewer loads it, no keyframe reset (issue 33: the ball sat at qpos 0 with no gravity)
    result, out, _ = tuned("bouncing-ball", "mujoco")
    settings = chosen_settings(result)
    traj = run_engine("mujoco", result.scene, settings)
    code = ("import mujoco, sys, numpy as np\n"
            "m = mujoco.MjModel.from_xml_path(sys.argv[1]); d = mujoco.MjData(m)\n"
            "y = [d.qpos[-1]]\n"
            "for _ in range(int(sys.argv[2])):\n"
            "    mujoco.mj_step(m, d); y.append(d.qpos[-1])\n"
            "print(m.opt.timestep, *m.opt.gravity, 'chatterbench' in sys.modules)\n"
            "np.save(sys.argv[3], np.array(y))\n")
    done = subprocess.run([sys.executable, "-c", code, str(out / "mujoco" / "model.xml"), str(len(traj.t) - 1),
                           str(out / "y.npy")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [repr(settings.dt), "-9.81", "0.0", "0.0", "False"]
    assert np.array_equal(np.load(out / "y.npy"), traj.y)  # the run, bit for bit (the joint-limit gap)


def _guide_block(text: str, lang: str, after: str) -> str:
    """The first ```lang block of the guide's Markdown after the heading ``after``."""
    section = text.split(after, 1)[1]
    return section.split(f"```{lang}\n", 1)[1].split("```", 1)[0]


def test_pybullet_guide_snippet_pasted_into_a_script_from_scratch(tuned, tmp_path):
    result, _, _ = tuned("bouncing-ball", "pybullet")
    text = guide_markdown(result)
    snippet, check = _guide_block(text, "python", "## Paste"), _guide_block(text, "python", "## Check it in your own model")
    # the placeholders as the guide says: body unique ids, link index -1 for base bodies (no joints)
    for name in ("BALL_ID", "BALL_LINK", "WALL_ID", "WALL_LINK"):
        assert name in snippet and f"#   {name}:" in snippet
    fill = {"BALL_ID": "ball", "BALL_LINK": "-1", "WALL_ID": "floor", "WALL_LINK": "-1"}
    pasted = snippet
    for k, v in fill.items():
        pasted = pasted.replace(k, v)
    check = check.replace("BALL_ID", "ball").replace("WALL_ID", "floor")
    script = tmp_path / "mine.py"
    script.write_text("\n".join([
        "import pybullet as p",
        "p.connect(p.DIRECT)",
        "p.setGravity(0, 0, -9.81)",
        "floor = p.createMultiBody(0, p.createCollisionShape(p.GEOM_BOX, halfExtents=[1, 1, 0.05]), basePosition=[0, 0, -0.05])",
        "ball = p.createMultiBody(1.0, p.createCollisionShape(p.GEOM_SPHERE, radius=0.05), basePosition=[0, 0, 1.05])",
        pasted,
        "print('restitution', p.getDynamicsInfo(ball, -1)[5])",
        "SPEED = lambda: p.getBaseVelocity(ball)[0][2]",
        check,
    ]))
    lines = run_python(script).splitlines()
    assert lines[0] == f"restitution {result.scene.restitution}"
    e = float(lines[-1].split("=")[1])
    print(f"pybullet: e = {e}")
    # the guide's R at the ball's 4.43 m/s: a rigid contact, Newton's law (measured 0.5011)
    assert e == pytest.approx(result.scene.restitution, rel=result.tolerance.restitution)


@pytest.mark.parametrize("form", ["joint", "pair"])
def test_mujoco_guide_snippet_pasted_into_a_model_from_scratch(tuned, tmp_path, form):
    result, _, _ = tuned("bouncing-ball", "mujoco")
    text = guide_markdown(result)
    snippet, check = _guide_block(text, "xml", "## Paste"), _guide_block(text, "python", "## Check it in your own model")
    for name in ("GAP_JOINT", "WALL_GEOM", "BALL_GEOM"):
        assert f"{name}:" in snippet  # each placeholder is explained
    option = re.search(r"<option[^>]*/>", snippet).group(0)
    if form == "joint":  # the user's ball drops along z on a slide joint "drop" whose range starts at the floor
        joint = re.search(r"<joint[^>]*/>", snippet).group(0).replace("GAP_JOINT", "drop").replace('axis="1 0 0"', 'axis="0 0 1"')
        body, contact = joint, ""
    else:  # a sphere on a box floor, the pair pasted with the geoms' names
        pair = re.search(r"<pair[^>]*/>", snippet).group(0).replace("WALL_GEOM", "floor").replace("BALL_GEOM", "ball")
        body, contact = ('<joint name="drop" type="slide" axis="0 0 1"/><geom name="ball" type="sphere" size="0.01"'
                          ' contype="0" conaffinity="0" pos="0 0 0.01"/>', f"<contact>{pair}</contact>")
    floor = '<geom name="floor" type="box" size="1 1 0.005" pos="0 0 -0.005" contype="0" conaffinity="0"/>' if form == "pair" else ""
    model = tmp_path / "mine.xml"
    model.write_text(f"""<mujoco>
  {option.replace('<option ', '<option gravity="0 0 -9.81" ')}
  <worldbody>{floor}
    <body name="ball"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>{body}</body>
  </worldbody>
  {contact}
</mujoco>""")
    script = tmp_path / "check.py"
    script.write_text("\n".join(["import mujoco", f"model = mujoco.MjModel.from_xml_path({str(model)!r})",
                                 "data = mujoco.MjData(model)", 'data.qpos[0] = 1.0  # 1 m above the floor',
                                 check.replace("GAP_JOINT", "drop")]))
    e = float(run_python(script).splitlines()[-1].split("=")[1])
    print(f"{form}: e = {e}")
    # the guide's number at the ball's 4.43 m/s under gravity: R within the restitution tolerance (measured 0.49)
    assert e == pytest.approx(result.scene.restitution, rel=result.tolerance.restitution)
