"""`run --export-model`: the files load and run in the engine alone, in processes that do not import chatterbench."""

from __future__ import annotations

import ast
import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from chatterbench.engines.mujoco_engine import MujocoEngine, MujocoSettings
from chatterbench.engines.mujoco_engine.export import harmonic_controls
from chatterbench.engines.mujoco_engine.model import controls
from chatterbench.engines.pybullet_engine import PybulletSettings
from chatterbench.engines.pybullet_engine import PybulletEngine
from chatterbench.reference import load_scene
from chatterbench.reference.catalogue import CATALOGUE

from helpers import cli_process as cli, needs_engine

HOSTILE = '</mujoco><!-- & "q" -- x """ \\ '  # XML markup, a comment closer, a docstring closer, a backslash
# a user's loop over the exported model: reset to keyframe 0, mj_step at the model's timestep, y after every step
STEP_MODEL = """
import sys
import mujoco
import numpy as np
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
mujoco.mj_resetDataKeyframe(model, data, 0)
y = [data.qpos[-1]]
for _ in range(int(sys.argv[2])):
    mujoco.mj_step(model, data)
    y.append(data.qpos[-1])
np.save(sys.argv[3], np.array(y))
"""


@pytest.mark.parametrize("gap_model", ["limit", "geom"])
def test_exported_mjcf_loads_and_reproduces_the_run_bit_for_bit(tmp_path, gap_model):
    done = cli("run", "bouncing-ball", "--engines", "mujoco", "--dt", "3e-4", "--set", "mujoco.w0_dt=0.1",
               "--set", f"mujoco.gap_model={gap_model}", "--export-model", str(tmp_path / "m.xml"))
    assert done.returncode == 0, done.stderr
    scene, settings = load_scene("bouncing-ball"), MujocoSettings(dt=3e-4, w0_dt=0.1, gap_model=gap_model)
    traj = MujocoEngine().run(scene, settings, compact_above=math.inf)
    n = len(traj.t) - 1
    stepped = subprocess.run([sys.executable, "-c", STEP_MODEL, str(tmp_path / "m.xml"), str(n), str(tmp_path / "y.npy")],
                             capture_output=True, text=True)
    assert stepped.returncode == 0, stepped.stderr
    y = np.load(tmp_path / "y.npy")
    # bit for bit: every position of the run (x1 = 0: the floor is fixed), 6667 steps through 8 impacts and the rest
    assert np.array_equal(y, traj.x2 - traj.x1)


def test_a_hostile_scene_name_still_gives_well_formed_xml(tmp_path):
    toml = tmp_path / "hostile.toml"
    toml.write_text(f"name = '{HOSTILE}'\n" + _ball_body())  # a TOML literal string: the name as typed
    done = cli("run", str(toml), "--engines", "mujoco", "--export-model", str(tmp_path / "h.xml"))
    assert done.returncode == 0, done.stderr
    root = ET.parse(tmp_path / "h.xml").getroot()  # well formed
    assert root.tag == "mujoco" and root.get("model") == f"chatterbench-{HOSTILE}"
    loaded = subprocess.run([sys.executable, "-c", "import mujoco, sys; print(mujoco.MjModel.from_xml_path(sys.argv[1]).nq)",
                             str(tmp_path / "h.xml")], capture_output=True, text=True)
    assert loaded.stdout.strip() == "1", loaded.stderr
    # the same name in the scripts
    from chatterbench.engines.export import export_files
    from chatterbench.engines.pybullet_engine.export import scene_script
    scene = load_scene(str(toml))
    for name, text in [("run.py", export_files("mujoco", scene, MujocoSettings())["run.py"]),
                       ("scene.py", scene_script(scene, PybulletSettings()))]:
        assert repr(scene.name) in ast.get_docstring(ast.parse(text, name))  # parsed: the name is text, never code


def _ball_body() -> str:
    ball = CATALOGUE["bouncing-ball"]
    return ("mass1 = 'inf'\nmass2 = 1.0\nrestitution = 0.5\nduration = 0.5\n[gap]\nlower = 0.0\n"
            f"[[forces]]\nkind = 'constant'\non = 'body2'\nvalue = {ball['forces'][0]['value']}\n"
            "[initial]\nt = 0.0\nx1 = 0.0\nv1 = 0.0\ny = 1.0\nvy = 0.0\n")


def test_exported_pybullet_script_runs_the_adapters_bounces(tmp_path):
    done = cli("run", "bouncing-ball", "--engines", "pybullet", "--dt", "1e-3", "--export-model", str(tmp_path / "s.py"))
    assert done.returncode == 0, done.stderr
    out = subprocess.run([sys.executable, str(tmp_path / "s.py")], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    lines = [line.split() for line in out.stdout.splitlines() if not line.startswith("# ")]  # after the header
    t = np.array([float(w[1].split("=")[1]) for w in lines])
    e = np.array([float(w[4].split("=")[1]) for w in lines])
    # the adapter's run: its contacts start at the same steps (the same world, settings and forces)
    traj = PybulletEngine().run(load_scene("bouncing-ball"), PybulletSettings(dt=1e-3), compact_above=math.inf)
    on = traj.contact["lower"]
    starts = traj.t[1:][on[1:] & ~on[:-1]] - 1e-3  # the step a contact starts in begins one dt before its sample
    np.testing.assert_allclose(t[:5], starts[:5], atol=1e-9)
    assert e[0] == pytest.approx(0.5011, abs=5e-4)  # Newton's R at 4.43 m/s (the measurement: 0.5011)


def test_export_refuses_other_engines_and_wrong_suffixes(tmp_path):
    needs_engine("drake")  # without it, the refusal is Drake's install line
    done = cli("run", "bouncing-ball", "--engines", "drake", "--export-model", str(tmp_path / "d.xml"))
    assert done.returncode == 2 and "engines that can: mujoco, pybullet" in done.stderr
    done = cli("run", "bouncing-ball", "--engines", "pybullet", "--export-model", str(tmp_path / "d.xml"))
    assert done.returncode == 2 and "name a .py file" in done.stderr
    assert "pybullet writes a Python script" in done.stderr  # before: "an MJCF model" for any engine but MuJoCo
    assert not (tmp_path / "d.xml").exists()


def test_which_engines_export_is_what_their_adapters_declare():
    from chatterbench.engines.export import check_exportable, export_files_names, exporting_engines
    from chatterbench.engines.registry import adapter, available_engines
    from chatterbench.engines.settings import SettingsError

    # known answer: MuJoCo and PyBullet export, in table order, with their files; no other built-in engine does
    assert exporting_engines()[:2] == ("mujoco", "pybullet")
    assert export_files_names("mujoco") == ["model.xml", "run.py"] and export_files_names("pybullet") == ["scene.py"]
    silent = [n for n in available_engines() if not adapter(n).exports]
    assert silent and not set(silent) & set(exporting_engines())
    with pytest.raises(SettingsError, match="engines that can: " + ", ".join(exporting_engines()) + "$"):
        check_exportable(silent[0])


@pytest.mark.parametrize("name", sorted(CATALOGUE) + ["prescribed"])
def test_runner_controls_are_the_runs_controls(name):
    # the lines the model's comment and run.py give for time-dependent forces are model.controls, to rounding
    scene = load_scene("bouncing-ball" if name == "prescribed" else name)
    if name == "prescribed":
        scene = load_scene("feigin-pair", ["mass1=inf", "prescribed.amplitude=0.05", "prescribed.omega=2.0",
                                           "initial.v1=0.1", "forces.0.on=coupling"])  # x1(0) = 0, v1(0) = A w
    for s in (MujocoSettings(), MujocoSettings(integrator="rk4")):
        t = np.linspace(0.0, 7.0, 50)
        expected = controls(scene, s, t)
        ts = t + 0.5 * s.dt if s.integrator == "rk4" else t
        got = np.array([[k + sum(a * math.sin(w * x + ph) for a, w, ph in harm) for k, harm in harmonic_controls(scene, s)]
                        for x in ts]).reshape(expected.shape)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_exported_scripts_print_no_lift_off_from_sliding_as_an_impact(tmp_path):
    # feigin-pair slides along a wall twice a period and leaves it where sin t changes sign: the solver's last touches
    # there are entered at a speed under a step's worth of |y''| (the old printer showed e.g. v_in=-1.07e-07 e=1.98)
    scene = load_scene("feigin-pair", [f"duration={4 * math.pi}"])
    from chatterbench.engines.export import export_files
    files = {"mujoco": export_files("mujoco", scene, MujocoSettings(dt=3e-4, w0_dt=0.1)),
             "pybullet": export_files("pybullet", scene, PybulletSettings(dt=1e-3))}
    for engine, texts in files.items():
        for name, text in texts.items():
            (tmp_path / f"{engine}-{name}").write_text(text)
        runnable = tmp_path / f"{engine}-{'run.py' if engine == 'mujoco' else 'scene.py'}"
        if engine == "mujoco":
            runnable.write_text(runnable.read_text().replace("'model.xml'", "'mujoco-model.xml'"))
        out = subprocess.run([sys.executable, str(runnable)], capture_output=True, text=True, cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        lines = out.stdout.splitlines()
        assert lines[0].startswith("# ") and "v_in" in lines[0]  # the header says what counts as an impact
        dt = 3e-4 if engine == "mujoco" else 1e-3
        v_in = [abs(float(line.split()[2].split("=")[1])) for line in lines[1:] if line.startswith("impact ")]
        assert len(v_in) >= 8, out.stdout  # the chatter sequences of both walls, twice
        # |y''| = |sin t| <= 1 m/s^2 in flight: a contact entered slower than one step's worth is a lift-off
        assert min(v_in) >= 1.0 * dt, [line for line in lines if line.startswith("impact ")][:5]


@pytest.mark.parametrize("scene", ["bouncing-ball", "feigin-pair"])
def test_the_command_that_wrote_the_mjcf_reads_back_exactly(tmp_path, scene):
    # XML comments cannot hold "--": the old comment read "chatterbench tune - -out"; the command is a custom text
    args = ["run", scene, "--engines", "mujoco", "--dt", "1e-3", "--export-model", str(tmp_path / "a--b.xml")]
    done = cli(*args)
    assert done.returncode == 0, done.stderr
    root = ET.parse(tmp_path / "a--b.xml").getroot()
    texts = {t.get("name"): t.get("data") for t in root.iter("text")}
    assert texts["chatterbench.command"] == " ".join(["chatterbench", *args])  # no quoting needed for these words
    assert "- -" not in ET.tostring(root, encoding="unicode")  # nothing mangled to fit a comment
    loaded = subprocess.run([sys.executable, "-c", "import mujoco, sys; print(mujoco.MjModel.from_xml_path(sys.argv[1]).ntext)",
                             str(tmp_path / "a--b.xml")], capture_output=True, text=True)
    assert loaded.stdout.strip() == "1", loaded.stderr
