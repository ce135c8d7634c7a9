"""`compare` takes settings objects; text is parsed once, at the command line; each failure is caught in one place."""

import pandas as pd
import pytest
from helpers import cli, solution

import chatterbench.engines.settings as engine_settings_module
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.engines.registry import settings_for
from chatterbench.engines.mujoco_engine import MujocoSettings
from chatterbench.engines.mujoco_warp_engine.settings import MujocoWarpSettings
from chatterbench.engines.pybullet_engine import PybulletSettings
from chatterbench.engines.settings import SettingsError
from chatterbench.reference import load_scene

BALL = load_scene("bouncing-ball")  # R = 0.5 onto a fixed floor: one chatter to rest, its Zeno point at 1.35 s


def test_a_settings_object_is_the_run_and_the_verdict_follows_it():
    ref = solution("bouncing-ball")
    given = PybulletSettings(dt=1e-3, restitution_velocity_threshold=0.5)
    c = compare(BALL, engines=("pybullet",), settings={"pybullet": given}, solution=ref)
    # the settings record says what ran
    record = c.runs["pybullet"].trajectory.settings
    assert record["restitution_velocity_threshold"] == 0.5 and record["dt"] == 1e-3
    assert c.runs["pybullet"].settings["restitution_velocity_threshold"] == 0.5
    # known answer three ways: PyBullet makes every impact slower than its threshold plastic, so at 0.5 m/s the
    # ball's chatter stops with impacts the reference still makes (it sticks early); at 0.02 m/s, twice the bounce
    # of its resting contact (g dt), it sticks on time and rests: match; at the default 0 it sticks on time but
    # keeps bouncing at g dt after the stick, its contact open a third of the rest: buzz
    assert c.table["verdict"].tolist() == ["early"]
    rests = PybulletSettings(dt=1e-3, restitution_velocity_threshold=0.02)
    assert compare(BALL, engines=("pybullet",), settings={"pybullet": rests}, solution=ref).table["verdict"].tolist() == [
        "match"]
    default = compare(BALL, engines=("pybullet",), settings={"pybullet": PybulletSettings(dt=1e-3)}, solution=ref)
    assert default.table["verdict"].tolist() == ["buzz"] and 0.3 < default.table["open_fraction"].iloc[0] < 0.4
    # the object and the text it stands for are one run, bit for bit (for callers who hold strings)
    text = compare(BALL, settings=settings_for(("pybullet",), 1e-3, ["pybullet.restitution_velocity_threshold=0.5"]),
                   solution=ref)
    pd.testing.assert_frame_equal(c.table.drop(columns="cost_per_sim_s"), text.table.drop(columns="cost_per_sim_s"))


@pytest.mark.parametrize("engines, settings, words", [
    (("pybullet",), {"mujoco": MujocoSettings()}, ("settings['mujoco']", "not among the engines run (pybullet)")),
    (("pybullet",), {"pybullet": MujocoSettings()}, ("settings['pybullet']", "MujocoSettings", "PybulletSettings")),
    # MuJoCo Warp's settings are MuJoCo's plus its own: still another engine's
    (("mujoco",), {"mujoco": MujocoWarpSettings()}, ("settings['mujoco']", "MujocoWarpSettings")),
    (("pybullet", "mujco"), {"pybullet": PybulletSettings()}, ("'mujco'", "did you mean 'mujoco'")),
])
def test_settings_that_do_not_fit_are_refused_before_any_run(engines, settings, words):
    started = []
    with pytest.raises(SettingsError) as err:
        compare(BALL, engines=engines, settings=settings, progress=started.append)
    assert all(w in str(err.value) for w in words), str(err.value)
    assert started == []  # not even the reference


@pytest.mark.parametrize("text", [{"dt": 1e-3}, {"overrides": ["pybullet.restitution_velocity_threshold=0.5"]}])
def test_compare_takes_settings_objects_only(text):
    # one way in: a timestep or text is made into settings at the edge (registry.settings_for), not inside compare
    with pytest.raises(TypeError, match="unexpected keyword"):
        compare(BALL, engines=("pybullet",), **text)


def test_settings_given_for_some_engines_and_the_defaults_for_the_others():
    scene = load_scene("bouncing-ball", ["duration=0.3"])  # before the first impact: no episode, two cheap runs
    c = compare(scene, engines=("mujoco", "pybullet"), settings={"pybullet": PybulletSettings(dt=1e-3)})
    assert c.runs["mujoco"].settings["dt"] == MujocoSettings().dt and c.runs["mujoco"].settings["w0_dt"] == 0.03
    assert c.runs["pybullet"].settings["dt"] == 1e-3
    assert list(c.runs) == ["mujoco", "pybullet"]  # in the order of engines
    # engines left out: those of the settings, in their order
    assert list(compare(scene, settings={"pybullet": PybulletSettings(dt=1e-3)}).runs) == ["pybullet"]


def test_an_engine_fault_is_caught_by_its_adapter_and_the_other_engine_kept(monkeypatch):
    monkeypatch.setenv("CHATTERBENCH_FAULT", "raise:mujoco")  # the test-only fault hook, engines/faults.py
    scene = load_scene("bouncing-ball", ["duration=1.6"])
    # PyBullet with the threshold that lets the ball rest (its default 0 keeps bouncing after the stick: buzz)
    c = compare(scene, settings=settings_for(("mujoco", "pybullet"), 1e-3, ["pybullet.restitution_velocity_threshold=0.02"]))
    mj = c.runs["mujoco"]
    # the adapter's classification (its message names the engine; its record is the run's, with MuJoCo's own
    # w0 and solref), not a catch-all's further up
    assert mj.status == "error" and mj.trajectory.message.startswith("mujoco: InjectedFault")
    assert {"w0", "solref"} <= set(mj.settings)
    assert c.table.loc[c.table["engine"] == "mujoco", "verdict"].tolist() == ["error"]
    assert c.runs["pybullet"].status == "ok" and c.table.loc[c.table["engine"] == "pybullet", "verdict"].tolist() == ["match"]


def test_settings_the_scene_cannot_run_are_the_callers_mistake_not_an_engine_error():
    # w0 dt = 1.8 passes every damping's limit (2.0) but not the ball's: R = 0.5 damps at zeta = 0.26, where
    # Euler is stable to w0 dt = 1.55
    scene = load_scene("bouncing-ball", ["duration=0.3"])
    with pytest.raises(SettingsError, match="stability limit"):
        compare(scene, settings=settings_for(("mujoco",), 1e-3, ["mujoco.w0_dt=1.8"]))
    # isolated (the command line's way), whatever the child raises is its run's error: the others go on
    c = compare(scene, settings=settings_for(("mujoco", "pybullet"), 1e-3, ["mujoco.w0_dt=1.8"]), timeout=60)
    assert c.runs["mujoco"].status == "error" and "stability limit" in c.runs["mujoco"].trajectory.message
    assert c.runs["pybullet"].status == "ok"


def _no_text_past_the_edge(monkeypatch):
    """Make the library's parser of ``KEY=VALUE`` text fail: past the command line, settings are objects."""
    def refuse(item):
        raise AssertionError(f"{item!r} parsed inside the library")
    monkeypatch.setattr(engine_settings_module, "split_assignment", refuse)


def test_the_command_line_parses_set_once_and_hands_on_objects(monkeypatch):
    _no_text_past_the_edge(monkeypatch)
    run = cli(["compare", "bouncing-ball", "--engines", "pybullet", "--dt", "1e-3", "--set", "duration=1.6",
               "--set", "pybullet.restitution_velocity_threshold=0.5"])
    assert run.code == 0, run.err
    assert "early" in run.out  # the setting reached the engine (see the first test)
    run = cli(["run", "bouncing-ball", "--engines", "pybullet", "--dt", "1e-3", "--set", "duration=0.3",
               "--set", "pybullet.restitution_velocity_threshold=0.5"])
    assert run.code == 0, run.err
