"""`run --export-model`: the files load and run in the engine alone, in processes that do not import chatterbench."""

from __future__ import annotations

import ast
import json
import math
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pandas as pd
import pytest

from chatterbench.comparisons.pipeline.extract import extract
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.registry import run_engine
from chatterbench.engines.mujoco_engine import MujocoEngine, MujocoSettings
from chatterbench.engines.mujoco_engine.export import harmonic_controls
from chatterbench.engines.mujoco_engine.model import controls
from chatterbench.engines.pybullet_engine import PybulletSettings
from chatterbench.engines.pybullet_engine import PybulletEngine
from chatterbench.reference import load_scene
from chatterbench.reference.catalogue import CATALOGUE

from helpers import cli as cli_here
from helpers import cli_process as cli, needs_engine

HOSTILE = '</mujoco><!-- & "q" -- x """ \\ '  # XML markup, a comment closer, a docstring closer, a backslash
# names a user's scene may carry that XML cannot hold or reads back changed (issue 34): newline, tab, triple quotes,
# BEL, ESC, NUL, U+FFFE; written in TOML basic strings, as escapes
CONTROL_NAMES = {"newline": r"a\nb", "tab": r"a\tb", "quotes": 'a\\"\\"\\"b', "bel": r"a\u0007b", "esc": r"a\u001bb",
                 "nul": r"a\u0000b", "fffe": r"a\uFFFEb"}
# a user's loop over the exported model, as MuJoCo's viewer starts it: no keyframe, no reset; y after every step
STEP_MODEL = """
import sys
import mujoco
import numpy as np
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
if sys.argv[4] == "reset":
    mujoco.mj_resetDataKeyframe(model, data, 0)
y = [data.qpos[-1]]
for _ in range(int(sys.argv[2])):
    mujoco.mj_step(model, data)
    y.append(data.qpos[-1])
np.save(sys.argv[3], np.array(y))
print(*model.opt.gravity, model.nu, "chatterbench" in sys.modules)
"""


def _stepped(model_file, n: int, out, reset: bool = False) -> tuple[np.ndarray, str]:
    """y after each of ``n`` steps of ``model_file`` in a fresh process (no chatterbench), and what it printed."""
    done = subprocess.run([sys.executable, "-c", STEP_MODEL, str(model_file), str(n), str(out), "reset" if reset else "no"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return np.load(out), done.stdout


@pytest.mark.parametrize("gap_model", ["limit", "geom"])
def test_exported_mjcf_starts_where_the_scene_starts_and_reproduces_the_run(tmp_path, gap_model):
    # written by the command in this process (what this test asks is the file, loaded and stepped in a fresh one)
    done = cli_here(["run", "bouncing-ball", "--engines", "mujoco", "--dt", "3e-4", "--set", "mujoco.w0_dt=0.1",
                     "--set", f"mujoco.gap_model={gap_model}", "--export-model", str(tmp_path / "m.xml")])
    assert done.code == 0, done.err
    scene, settings = load_scene("bouncing-ball"), MujocoSettings(dt=3e-4, w0_dt=0.1, gap_model=gap_model)
    traj = MujocoEngine().run(scene, settings, compact_above=math.inf)
    y, printed = _stepped(tmp_path / "m.xml", len(traj.t) - 1, tmp_path / "y.npy")
    # loaded and stepped as MuJoCo's viewer does: the ball starts 1 m up under MuJoCo's gravity along the slide axis
    # (before: qpos 0 on the floor, gravity 0 and a motor whose control only the keyframe set: nothing moved)
    assert printed.split() == ["-9.81", "0.0", "0.0", "0", "False"] and y[0] == 1.0
    if gap_model == "limit":  # every position of the run, bit for bit: 6667 steps through 8 impacts and the rest
        assert np.array_equal(y, traj.x2 - traj.x1)
    else:  # the ball's world position is its body's (1 m) plus the joint's move from there: one rounding more
        np.testing.assert_allclose(y, traj.x2 - traj.x1, rtol=0, atol=1e-11)


@pytest.mark.parametrize("source,over,gravity,nu", [
    ("bouncing-ball", ["mass2=0.2"], "-9.81", "0"),  # the scene's gravity, whatever the mass (issue 41)
    ("old.toml", ["mass2=0.2"], "-9.81", "0"),  # a file's weight -1.962 N on the 0.2 kg ball, read as gravity
    ("pushed.toml", [], "0.0", "1"),  # -5 N on a 1 kg ball is no weight: a motor's bias, MuJoCo's gravity 0
])
def test_exported_mjcf_carries_the_scenes_gravity(tmp_path, source, over, gravity, nu):
    body = _ball_body().replace("gravity = -9.81\n", "").replace("duration = 0.5", "duration = 1.0")  # to 0.63 s
    force = {"old.toml": -1.962, "pushed.toml": -5.0}.get(source)
    if force is not None:
        (tmp_path / source).write_text(body.replace("mass2 = 1.0", f"mass2 = {0.2 if force == -1.962 else 1.0}")
                                       + f"[[forces]]\nkind = 'constant'\non = 'body2'\nvalue = {force}\n")
        source = str(tmp_path / source)
    done = cli_here(["run", source, "--engines", "mujoco", "--dt", "3e-4", "--set", "mujoco.w0_dt=0.1",
                     *[w for o in over for w in ("--set", o)], "--export-model", str(tmp_path / "m.xml")])
    assert done.code == 0, done.err
    scene = load_scene(source, over)
    traj = MujocoEngine().run(scene, MujocoSettings(dt=3e-4, w0_dt=0.1), compact_above=math.inf)
    y, printed = _stepped(tmp_path / "m.xml", len(traj.t) - 1, tmp_path / "y.npy")
    assert printed.split() == [gravity, "0.0", "0.0", nu, "False"]
    # the file run as MuJoCo's viewer runs it is the run: the ball under MuJoCo's gravity (or the motor's bias)
    # falls as the adapter's motors make it fall, bit for bit (measured: also at mass2 = 0.2)
    assert np.array_equal(y, traj.x2 - traj.x1)
    fall = float(gravity) if gravity != "0.0" else -5.0
    first = traj.t[np.argmax(traj.contact["lower"])]  # first contact: the step the ball reaches the floor
    assert abs(first - math.sqrt(2.0 / -fall)) <= 3e-4  # within a step of the free fall's time


def test_the_keyframe_adds_the_initial_velocity(tmp_path):
    # a ball thrown up at 1 m/s: the model's default state is the initial position only; keyframe 0 adds the speed
    scene = load_scene("bouncing-ball", ["initial.vy=1.0"])
    settings = MujocoSettings(dt=3e-4, w0_dt=0.1)
    from chatterbench.engines.export import model_file
    (tmp_path / "m.xml").write_text(model_file("mujoco", scene, settings))
    traj = MujocoEngine().run(scene, settings, compact_above=math.inf)
    y, _ = _stepped(tmp_path / "m.xml", len(traj.t) - 1, tmp_path / "y.npy", reset=True)
    assert np.array_equal(y, traj.x2 - traj.x1)
    y, _ = _stepped(tmp_path / "m.xml", len(traj.t) - 1, tmp_path / "y.npy", reset=False)
    assert y[0] == 1.0 and y[1000] < traj.y[1000] - 0.2  # without it the ball is dropped, not thrown: 0.3 s later, lower


def test_a_hostile_scene_name_still_gives_well_formed_xml(tmp_path):
    toml = tmp_path / "hostile.toml"
    toml.write_text(f"name = '{HOSTILE}'\n" + _ball_body())  # a TOML literal string: the name as typed
    done = cli_here(["run", str(toml), "--engines", "mujoco", "--export-model", str(tmp_path / "h.xml")])
    assert done.code == 0, done.err
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


# a user's process that loads MJCF files with MuJoCo alone: per file, one JSON line [nq, the model's name] (or the error)
LOAD_NAMES = """
import json, sys
import mujoco
for path in sys.argv[1:]:
    try:
        m = mujoco.MjModel.from_xml_path(path)
        print(json.dumps([m.nq, m.names.split(b"\\0")[0].decode()]))
    except Exception as exc:
        print(json.dumps(["error", repr(exc)]))
print("chatterbench" in sys.modules)
"""


@pytest.fixture(scope="module")
def control_named(tmp_path_factory):
    """Each kind of CONTROL_NAMES: its scene, both engines' ``run --export-model`` (in this process) and what one fresh
    process, without chatterbench, read from each MJCF ([nq, name]): the files of every kind loaded in that one."""
    made = {}
    for kind, typed in CONTROL_NAMES.items():
        folder = tmp_path_factory.mktemp(f"named-{kind}")
        toml = folder / "named.toml"
        toml.write_text(f'name = "{typed}"\n' + _ball_body())
        done = {engine: cli_here(["run", str(toml), "--engines", engine, "--dt", "1e-3", "--export-model", str(folder / name)])
                for engine, name in (("mujoco", "m.xml"), ("pybullet", "s.py"))}
        made[kind] = (load_scene(str(toml)), done, folder)
    loaded = subprocess.run([sys.executable, "-c", LOAD_NAMES, *(str(folder / "m.xml") for _, _, folder in made.values())],
                            capture_output=True, text=True)
    *lines, alone = loaded.stdout.splitlines() or [""]
    assert loaded.returncode == 0 and alone == "False" and len(lines) == len(made), loaded.stderr
    return {kind: (*made[kind], json.loads(line)) for kind, line in zip(made, lines)}


@pytest.mark.parametrize("kind", CONTROL_NAMES)
def test_control_characters_in_a_scene_name_are_exported_escaped(control_named, kind):
    # issue 34: a newline, a tab or triple quotes made --export-model refuse the scene ("the written MJCF does not
    # compile"), BEL, ESC, NUL or U+FFFE gave a traceback; the scene is valid and every file is written
    scene, done, folder, loaded = control_named[kind]
    for engine in ("mujoco", "pybullet"):
        assert done[engine].code == 0 and "Traceback" not in done[engine].err, done[engine].err
    escaped = "".join(c if c.isprintable() else c.encode("unicode_escape").decode() for c in scene.name)
    assert loaded == [1, f"chatterbench-{escaped}"]  # the model's name, as a process with MuJoCo alone reads it
    assert repr(scene.name) in ast.get_docstring(ast.parse((folder / "s.py").read_text()))


def test_tune_writes_its_engine_files_for_a_scene_named_with_control_characters(tmp_path):
    # the same names through tune's files and guide (one candidate per engine): every one of them at once
    toml = tmp_path / "named.toml"
    toml.write_text(f'name = "{"".join(CONTROL_NAMES.values())}"\n' + _ball_body())
    scene = load_scene(str(toml))
    from chatterbench.comparisons.outputs.engine_files import write_engine_files
    from chatterbench.comparisons.outputs.guide import guide_html, guide_markdown
    from chatterbench.comparisons.studies.tune import tune
    for engine in ("mujoco", "pybullet"):
        result = tune(scene, engine, 0.2, space={"dt": (1e-3,)}, workers=1, refine_steps=0, check_robust=False)
        written = write_engine_files(result, tmp_path / "tuned")
        assert len(written) == {"mujoco": 2, "pybullet": 1}[engine] and guide_markdown(result) and guide_html(result)
        for path in written:
            text = (tmp_path / "tuned" / path).read_text()
            compile(text, path, "exec") if path.endswith(".py") else ET.fromstring(text)


def _ball_body() -> str:
    ball = CATALOGUE["bouncing-ball"]
    return (f"mass1 = 'inf'\nmass2 = 1.0\nrestitution = 0.5\nduration = 0.5\ngravity = {ball['gravity']!r}\n"
            "[gap]\nlower = 0.0\n[initial]\nt = 0.0\nx1 = 0.0\nv1 = 0.0\ny = 1.0\nvy = 0.0\n")


def _printed(stdout: str) -> list[tuple[float, float, float, float]]:
    """(t, v_in, v_out, e) of each ``impact`` line a script printed, after its ``# impact:`` header."""
    header, *lines = stdout.splitlines()
    assert header.startswith("# impact: ")
    lines = [line for line in lines if line.startswith("impact ")]  # the rest lines after them: test_persistence.py
    return [tuple(float(w.split("=")[1]) for w in line.split()[1:]) for line in lines]


def _judged(engine: str, scene, settings) -> pd.DataFrame:
    """The impacts of the judge's event log on the adapter's own run: what ``chatterbench run`` counts."""
    ref = solve(scene)
    found = extract(run_engine(engine, scene, settings), scene, ref.stick_tolerance(Tolerances().stick))
    return found.log[found.log["kind"] == "impact"]


def test_exported_pybullet_script_prints_the_runs_impacts_as_the_judge_measures_them(tmp_path):
    # the issue's case: `run bouncing-ball --engines pybullet --export-model scene.py` reported 9 impacts, the script
    # printed 11 (two of the ball's last micro-bounces), with e from velocities one step either side of the contact
    done = cli_here(["run", "bouncing-ball", "--engines", "pybullet", "--export-model", str(tmp_path / "scene.py")])
    assert done.code == 0, done.err
    counted = int(re.search(r"(\d+) impacts", done.out).group(1))
    out = subprocess.run([sys.executable, str(tmp_path / "scene.py")], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    printed = _printed(out.stdout)
    judged = _judged("pybullet", load_scene("bouncing-ball"), PybulletSettings())
    assert len(printed) == counted == len(judged) == 9
    for (t, v_in, v_out, e), row in zip(printed, judged.itertuples()):
        # the judge's rule on the same run: the same impacts, speeds at the wall's surface; 6 printed digits
        assert t == pytest.approx(row.t, abs=1e-6) and v_in == pytest.approx(row.v_minus, rel=1e-5)
        assert e == pytest.approx(-row.v_plus / row.v_minus, rel=1e-5)


def test_an_adapter_that_exports_nothing_is_one_clear_error():
    from chatterbench.engines.export import ExportError, adapter_files
    from chatterbench.engines.pybullet_engine import PybulletEngine

    class Forgetful(PybulletEngine):  # a third party's adapter: declares scene.py, writes nothing
        def export(self, scene, settings, command=None):
            return None

    with pytest.raises(ExportError, match=r"export\(\) wrote no 'scene.py' \(it declares 'scene.py'; it returned 'NoneType'\)"):
        adapter_files(Forgetful(), load_scene("bouncing-ball"), PybulletSettings())
    files = adapter_files(PybulletEngine(), load_scene("bouncing-ball"), PybulletSettings())  # the real one: its file
    assert list(files) == ["scene.py"]


def test_export_refuses_the_scene_file_it_reads(tmp_path):
    # issue 34: `run s.py --engines pybullet --export-model s.py` replaced the scene file with the script
    from chatterbench.reference.scene_toml import scene_toml
    scene_file = tmp_path / "s.py"
    scene_file.write_text(scene_toml(load_scene("bouncing-ball")))
    before = scene_file.read_text()
    (tmp_path / "link.py").symlink_to(scene_file)
    done = cli_here(["run", str(scene_file), "--engines", "pybullet", "--export-model", str(scene_file)])
    assert done.code == 2 and "is the SCENE file" in done.err and "name another file" in done.err, done.err
    # a link to it: refused as a link (issue 45: a write never replaces a link), the scene untouched either way
    done = cli_here(["run", str(scene_file), "--engines", "pybullet", "--export-model", str(tmp_path / "link.py")])
    assert done.code == 2 and "a symbolic link" in done.err and "give the file itself" in done.err, done.err
    assert scene_file.read_text() == before
    done = cli_here(["run", str(scene_file), "--engines", "pybullet", "--dt", "1e-3", "--export-model", str(tmp_path / "t.py")])
    assert done.code == 0 and (tmp_path / "t.py").is_file(), done.err  # another name: written


def test_export_refuses_other_engines_and_wrong_suffixes(tmp_path):
    needs_engine("drake")  # without it, the refusal is Drake's install line
    done = cli_here(["run", "bouncing-ball", "--engines", "drake", "--export-model", str(tmp_path / "d.xml")])
    assert done.code == 2 and "engines that can: mujoco, pybullet" in done.err
    done = cli_here(["run", "bouncing-ball", "--engines", "pybullet", "--export-model", str(tmp_path / "d.xml")])
    assert done.code == 2 and "name a .py file" in done.err
    assert "pybullet writes a Python script" in done.err  # before: "an MJCF model" for any engine but MuJoCo
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
