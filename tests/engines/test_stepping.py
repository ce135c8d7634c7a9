"""The base's step loop (``engines/stepping.py``) and an isolated adapter's runs, on the plugin how-to's engine.

The engine is the code block of ``docs/how-to/plugin.md`` (a real one: semi-implicit Euler, Newton's law
at each impact), loaded as its own module: what a plugin author writes, run by the base.
"""

from __future__ import annotations

import math
import sys
import types

import numpy as np
import pytest

from chatterbench.engines.base import sample_times
from chatterbench.engines.isolate import run_limit, set_run_limit
from chatterbench.engines.settings import SettingsError
from chatterbench.engines.stepping import force_plan
from chatterbench.reference.forces import evaluate_forces
from chatterbench.reference.scene import load_scene
from plugin_cases import readme_block


def _readme_engine() -> types.ModuleType:
    module = types.ModuleType("chatterbench_euler")
    sys.modules[module.__name__] = module  # the dataclass decorator looks its module up
    exec(compile(readme_block("# chatterbench_euler.py"), "docs/how-to/plugin.md", "exec"), module.__dict__)
    return module


EULER = _readme_engine()


class Listening(EULER.EulerEngine):
    """The plugin how-to's engine, keeping the forces the base handed over and what it did with its world."""

    def __init__(self, fail_at: int | None = None, nan_at: int | None = None) -> None:
        self.forces, self.states, self.closed, self.fail_at, self.nan_at = [], [], 0, fail_at, nan_at

    def build(self, scene, settings):
        world = super().build(scene, settings)
        world.close = lambda: setattr(self, "closed", self.closed + 1)
        return world

    def step(self, w, forces):
        if len(self.forces) == self.fail_at:
            raise RuntimeError("the engine gave up")
        self.forces.append(forces)
        self.states.append((w.x1, w.v1, w.x2, w.v2))  # the state the step starts from
        state, pushes = super().step(w, forces)
        if len(self.forces) == self.nan_at:
            state = (*state[:2], math.nan, state[3])
        return state, pushes


def test_force_plan_is_the_scenes_force_model():
    # the affine split (time part + gain . state) of every affine term: only rounding differs (forces are O(10 N))
    scene = load_scene("impact-damper")
    t = np.linspace(0.0, 1.0, 11)
    time1, time2, gain = force_plan(scene, t)
    rng = np.random.default_rng(1)
    for k in range(len(t)):
        x1, v1, x2, v2 = rng.normal(size=4) * 0.01
        f1, f2, f12 = evaluate_forces(scene, t[k], x1, v1, x2 - x1, v2 - v1)
        got = gain @ np.array([x1, v1, x2, v2]) + [time1[k], time2[k]]
        np.testing.assert_allclose(got, [f1 + f12, f2 - f12], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["spring-pair", "impact-damper", "feigin-pair"])
def test_each_step_gets_the_scenes_forces_at_its_start(name):
    scene = load_scene(name, ["duration=0.5"])
    engine = Listening()
    traj = engine.run(scene, EULER.EulerSettings(dt=1e-3))
    assert traj.status == "ok" and len(traj.t) == 501 and engine.closed == 1
    np.testing.assert_array_equal(traj.t, sample_times(scene, 1e-3))
    for k in (0, 1, 250, 499):  # step k starts at sample k: the forces of the state there, at t_k
        x1, v1, x2, v2 = engine.states[k]
        assert (x1, x2) == (traj.x1[k], traj.x2[k])  # the samples are the states the steps start from
        f1, f2, f12 = evaluate_forces(scene, traj.t[k], x1, v1, x2 - x1, v2 - v1)
        np.testing.assert_allclose(engine.forces[k], (f1 + f12, f2 - f12), rtol=1e-12, atol=1e-12)
    # and a force of another time is caught: the next step's time is off by the forcing's change over dt
    x1, v1, x2, v2 = engine.states[250]
    f1, f2, f12 = evaluate_forces(scene, traj.t[251], x1, v1, x2 - x1, v2 - v1)
    assert not np.allclose(engine.forces[250], (f1 + f12, f2 - f12), rtol=1e-12, atol=1e-12)


def test_a_failing_step_keeps_the_samples_before_it_and_closes_the_world():
    engine = Listening(fail_at=10)
    traj = engine.run(load_scene("feigin-pair", ["duration=0.5"]), EULER.EulerSettings(dt=1e-3))
    assert traj.status == "error" and traj.message == "euler: RuntimeError: the engine gave up"
    assert len(traj.t) == 11 and engine.closed == 1  # the initial state and the 10 steps taken


def test_a_non_finite_state_is_diverged_there():
    engine = Listening(nan_at=7)
    traj = engine.run(load_scene("feigin-pair", ["duration=0.5"]), EULER.EulerSettings(dt=1e-3))
    assert traj.status == "diverged" and len(traj.t) == 7 and np.isfinite(traj.x2).all()


def test_runs_longer_than_a_chunk_are_one_run():
    # 20,000 steps: two chunks of the loop; the samples are those of one loop over the engine, bit for bit
    scene = load_scene("bouncing-ball")
    engine = Listening()
    traj = engine.run(scene, EULER.EulerSettings(dt=1e-4), compact_above=math.inf)
    assert traj.status == "ok" and len(traj.t) == 20_001
    np.testing.assert_array_equal(traj.x2[:-1], [s[2] for s in engine.states])
    np.testing.assert_array_equal(traj.t, sample_times(scene, 1e-4))


def test_a_prescribed_body_1_is_refused_by_an_engine_without_drive():
    scene = load_scene("feigin-pair", ["mass1=inf", "prescribed.amplitude=0.05", "initial.v1=0.05", "forces.0.on=coupling"])
    with pytest.raises(SettingsError, match="engine 'euler' cannot move a prescribed body 1"):
        EULER.EulerEngine().run(scene, EULER.EulerSettings())


@pytest.mark.parametrize("force_sum", ["grouped", "in order"])
def test_the_bare_loop_replays_the_runs_forces_bit_for_bit(force_sum):
    scene = load_scene("impact-damper", ["duration=0.3"])
    engine = Listening()
    engine.force_sum = force_sum
    traj = engine.run(scene, EULER.EulerSettings(dt=1e-3), compact_above=math.inf)
    ran = engine.forces
    engine.forces, engine.states = [], []
    assert engine.bare_seconds(scene, EULER.EulerSettings(dt=1e-3), traj) > 0
    assert engine.forces == ran  # the same floats: the bare loop steps the same trajectory


# -- an isolated adapter (every plugin): each run in a forked child under the run limit ----------------------
class Faulty(EULER.EulerEngine):
    isolated = True

    def __init__(self, fault: str = "") -> None:
        self.fault = fault

    def step(self, w, forces):
        if self.fault == "segfault":
            import ctypes

            ctypes.string_at(0)
        elif self.fault == "exit":
            import os

            os._exit(0)
        elif self.fault == "hang":
            import time

            while True:
                time.sleep(1.0)
        return super().step(w, forces)


@pytest.fixture
def short_limit():
    before = run_limit()
    set_run_limit(3.0)
    yield
    set_run_limit(before)


def test_an_isolated_run_is_the_run_itself():
    scene, settings = load_scene("bouncing-ball"), EULER.EulerSettings(dt=1e-3)
    there, here = Faulty().run(scene, settings), EULER.EulerEngine().run(scene, settings)
    assert there.status == here.status == "ok"
    for column in ("t", "x1", "x2", "v1", "v2"):
        np.testing.assert_array_equal(getattr(there, column), getattr(here, column))
    np.testing.assert_array_equal(there.normal_force["lower"], here.normal_force["lower"])


@pytest.mark.parametrize("fault, status, words", [
    ("segfault", "crashed", "euler: killed by SIGSEGV"),
    ("exit", "crashed", "euler: exited with code 0 without a result"),
    ("hang", "timeout", "euler: no result after 1 s; killed"),
])
def test_a_fault_in_an_isolated_run_is_that_runs_status(fault, status, words, short_limit):
    if fault == "hang":  # the run built to hang waits out its limit: 1 s (the run after it has the 3 s of the others)
        set_run_limit(1.0)
    traj = Faulty(fault).run(load_scene("bouncing-ball"), EULER.EulerSettings(dt=1e-3))
    set_run_limit(3.0)
    assert traj.status == status and traj.message == words and len(traj.t) == 1
    assert Faulty().run(load_scene("bouncing-ball"), EULER.EulerSettings(dt=1e-3)).status == "ok"  # this process goes on


def test_a_settings_refusal_in_an_isolated_run_is_raised_here():
    scene = load_scene("feigin-pair", ["mass1=inf", "prescribed.amplitude=0.05", "initial.v1=0.05", "forces.0.on=coupling"])
    with pytest.raises(SettingsError, match="cannot move a prescribed body 1"):
        Faulty().run(scene, EULER.EulerSettings())
