"""The engine contract (``engines/base.py``): every adapter, through the registry, keeps the same promises."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from chatterbench.engines import ENGINE_NAMES, EngineAdapter, adapter, make_settings, run_engine, sample_times
from chatterbench.engines.base import failed_trajectory, n_steps
from chatterbench.engines.faults import ENV, InjectedFault
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import load_scene


@pytest.mark.parametrize("duration, dt, want", [(1.0, 3e-4, 3333), (2.0, 1e-4, 20000), (2.0, 3.0, 1), (1e-3, 1e-3, 1)])
def test_one_step_count_rule(duration, dt, want):
    # the last sample at or before the end of the run; 2.0 / 1e-4 is 20000 to rounding
    assert n_steps(duration, dt) == want


@pytest.mark.parametrize("name", ENGINE_NAMES)
def test_every_engine_samples_the_same_grid(name):
    from chatterbench.comparisons.pipeline.sampling import sample_grid

    scene = load_scene("feigin-pair", ["duration=1.0"])
    traj = run_engine(name, scene, make_settings(name, 3e-4))
    assert traj.status == "ok"
    np.testing.assert_array_equal(traj.t, sample_times(scene, 3e-4))
    np.testing.assert_array_equal(traj.t, sample_grid(scene, 3e-4))  # and so does the sampled reference
    assert len(traj.t) == 3334


@pytest.mark.parametrize("name", ENGINE_NAMES)
def test_adapters_go_through_the_contract(name):
    a = adapter(name)
    assert isinstance(a, EngineAdapter) and a.name == name and a.version()
    settings = make_settings(name, 1e-3)
    assert isinstance(settings, a.settings_type) and settings.dt == 1e-3
    scene = load_scene("bouncing-ball")
    assert a.snippet(scene, settings)  # something a user pastes
    traj = a.run(scene, settings)
    # the contact law's own scales are typed fields: MuJoCo's soft contact (MuJoCo Warp runs its model), PyBullet's rigid one
    if name in ("mujoco", "mujoco_warp"):
        assert traj.contact_frequency == pytest.approx(settings.w0) and 0 < traj.contact_time < 0.2
    elif name == "drake":  # compliant too, its w0 from the scene's scales (drake_engine/contact.py)
        assert traj.contact_frequency == pytest.approx(traj.settings["w0_used"]) and 0 < traj.contact_time < 0.2
    else:
        assert math.isinf(traj.contact_frequency) and traj.contact_time == 0.0
    assert "contact_time" not in traj.settings and "contact_duration" not in traj.settings


@pytest.mark.parametrize("name", ENGINE_NAMES)
def test_a_bad_setting_is_an_input_error_naming_it(name):
    with pytest.raises(SettingsError, match=rf"{name}\.dt = -1.0: must be > 0") as info:
        make_settings(name, -1.0)
    assert isinstance(info.value, InputError)


def test_a_failed_run_keeps_the_initial_state():
    scene = load_scene("spring-pair")
    traj = failed_trajectory("mujoco", scene, "error", "boom")
    assert traj.status == "error" and len(traj.t) == 1 and traj.y[0] == scene.initial.y


def test_the_fault_hook_is_read_from_the_environment_only(monkeypatch):
    scene = load_scene("bouncing-ball", ["duration=0.1"])
    for name in ENGINE_NAMES:
        assert "fault" not in [f for f in make_settings(name).__dataclass_fields__]
    monkeypatch.setenv(ENV, "raise:pybullet:restitution=0.5")
    with pytest.raises(InjectedFault):
        run_engine("pybullet", scene, make_settings("pybullet", 1e-3))
    assert run_engine("mujoco", scene, make_settings("mujoco", 1e-3)).status == "ok"  # another engine
    other = load_scene("bouncing-ball", ["duration=0.1", "restitution=0.4"])
    assert run_engine("pybullet", other, make_settings("pybullet", 1e-3)).status == "ok"  # another scene


def test_a_segfault_fault_kills_the_process_running_the_engine():
    code = ("from chatterbench.engines import run_engine, make_settings\n"
            "from chatterbench.reference.scene import load_scene\n"
            "run_engine('mujoco', load_scene('bouncing-ball'), make_settings('mujoco'))\n")
    proc = subprocess.run([sys.executable, "-c", code], env={**__import__("os").environ, ENV: "segfault:mujoco"},
                          capture_output=True, timeout=120)
    assert proc.returncode == -11  # SIGSEGV


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_a_run_too_big_for_memory_is_an_error_result_in_every_engine(engine):
    # before: PyBullet died with ArrayMemoryError where MuJoCo gave status "error"
    scene = load_scene("feigin-pair", ["duration=1e9"])  # 1e13 steps: tens of TiB of samples
    traj = run_engine(engine, scene, make_settings(engine))
    assert traj.status == "error" and "MemoryError" in traj.message
    assert len(traj.t) == 1
