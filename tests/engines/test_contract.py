"""The engine contract (``engines/base.py``): every installed engine, through the registry, keeps the same promises.

One suite, parametrised over ``available_engines()`` (built in, optional extras installed, and
plugins found through the ``chatterbench.engines`` entry points), with no branch on names: what
differs between engines is read from the facts each adapter declares.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
import time

import numpy as np
import pytest

from chatterbench.engines import BenchmarkResult, EngineAdapter, Status, adapter, make_settings, run_engine, sample_times
from chatterbench.engines.base import STATUS_MESSAGE, failed_trajectory, n_steps
from chatterbench.engines.faults import ENV
from chatterbench.engines.registry import DEFAULT_ENGINES, ENGINE_NAMES, ENGINES, EXTRAS, available_engines
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import load_scene

INSTALLED = available_engines()


@pytest.mark.parametrize("duration, dt, want", [(1.0, 3e-4, 3333), (2.0, 1e-4, 20000), (2.0, 3.0, 1), (1e-3, 1e-3, 1)])
def test_one_step_count_rule(duration, dt, want):
    # the last sample at or before the end of the run; 2.0 / 1e-4 is 20000 to rounding
    assert n_steps(duration, dt) == want


def test_the_engine_lists_are_read_from_one_table():
    assert ENGINE_NAMES == tuple(e.name for e in ENGINES)
    assert DEFAULT_ENGINES == tuple(e.name for e in ENGINES if e.default) and DEFAULT_ENGINES
    assert EXTRAS == {e.name: (e.module, e.extra) for e in ENGINES if e.extra}
    assert set(INSTALLED) <= set(ENGINE_NAMES)


def test_status_is_an_enum_equal_to_its_string_with_one_message_each():
    assert Status.DIVERGED == "diverged" and f"{Status.CRASHED}" == "crashed" and Status("timeout") is Status.TIMEOUT
    assert set(STATUS_MESSAGE) == set(Status) and all(STATUS_MESSAGE.values())


@pytest.mark.parametrize("name", INSTALLED)
def test_every_engine_samples_the_same_grid(name):
    from chatterbench.comparisons.pipeline.sampling import sample_grid

    scene = load_scene("feigin-pair", ["duration=1.0"])
    traj = run_engine(name, scene, make_settings(name, 3e-4))
    assert traj.status == "ok"
    np.testing.assert_array_equal(traj.t, sample_times(scene, 3e-4))
    np.testing.assert_array_equal(traj.t, sample_grid(scene, 3e-4))  # and so does the sampled reference
    assert len(traj.t) == 3334


@pytest.mark.parametrize("name", INSTALLED)
def test_adapters_go_through_the_contract_and_declare_their_facts(name):
    a = adapter(name)
    assert isinstance(a, EngineAdapter) and a.name == name and a.version()
    settings = make_settings(name, 1e-3)
    assert isinstance(settings, a.settings_type) and settings.dt == 1e-3
    fields = {f.name for f in dataclasses.fields(settings)}
    assert a.precision in ("float32", "float64") and a.cost_lever(settings) in fields
    space = a.tuning_space(load_scene("bouncing-ball"))
    assert space is None or all(k == "dt" or (k.startswith(f"{name}.") and k.split(".", 1)[1] in fields) for k in space)
    scene = load_scene("bouncing-ball")  # body 1 of infinite mass, at rest: the base fills it in
    assert a.snippet(scene, settings)  # something a user pastes
    traj = a.run(scene, settings)
    assert traj.status == "ok" and isinstance(traj.status, Status)
    np.testing.assert_array_equal(traj.x1, scene.initial.x1)
    np.testing.assert_array_equal(traj.v1, 0.0)
    # the contact law's own scales are typed fields, as the adapter declares its contact: compliant or rigid
    if a.compliant:
        assert math.isfinite(traj.contact_frequency) and 0 < traj.contact_time < 0.2
    else:
        assert math.isinf(traj.contact_frequency) and traj.contact_time == 0.0
    assert "contact_time" not in traj.settings and fields <= set(traj.settings)  # the settings record


@pytest.mark.parametrize("name", INSTALLED)
def test_a_bad_setting_is_an_input_error_naming_it(name):
    with pytest.raises(SettingsError, match=rf"{name}\.dt = -1.0: must be > 0") as info:
        make_settings(name, -1.0)
    assert isinstance(info.value, InputError)
    with pytest.raises(SettingsError, match=name):  # another engine's settings object
        adapter(name).run(load_scene("bouncing-ball"), object())


@pytest.mark.parametrize("name", INSTALLED)
@pytest.mark.parametrize("override, words", [
    ("dt=0", "dt = 0: must be > 0"),
    ("dt=-1e-4", "dt = -0.0001: must be > 0"),
    ("dtt=1e-3", "unknown NAME setting; allowed: dt"),  # a misspelt key: every key listed, the nearest suggested
])
def test_every_engine_refuses_the_same_bad_settings_the_same_way(name, override, words):
    # one copy for every engine (was one per engine test file); each file keeps only its engine's own keys
    with pytest.raises(SettingsError) as info:
        make_settings(name, overrides=[f"{name}.{override}"])
    assert words.replace("NAME", name) in str(info.value) and (name in str(info.value))
    if override.startswith("dtt"):
        assert str(info.value).endswith("(did you mean 'dt'?)")


@pytest.mark.parametrize("name", INSTALLED)
def test_a_long_run_comes_back_compact_in_every_engine(name):
    # before: Drake never used window.Recorder, so its long runs were always full
    # (what compaction keeps is tests/engines/test_window.py's; here, that every engine's run goes through it)
    scene = load_scene("bouncing-ball", ["duration=1.0"])
    s = make_settings(name, 1e-3)
    full = adapter(name).run(scene, s, compact_above=math.inf)
    small = adapter(name).run(scene, s, compact_above=0)
    assert not full.compact and small.compact and small.step == pytest.approx(1e-3)
    np.testing.assert_array_equal(small.t, full.t[small.index])  # the samples kept are the run's own
    np.testing.assert_array_equal(small.y, full.y[small.index])


class _Fails:
    """A real engine's run whose recording is disturbed after its first chunk: an exception, or a NaN sample."""

    def __init__(self, name: str, how: str) -> None:
        self.name, self.how = name, how

    def run(self, scene, settings):
        engine = adapter(self.name)
        how = self.how

        class Disturbed(type(engine)):
            def simulate(self, run):
                add = run.add

                def disturbed(t, force, **cols):
                    if how == "nan":  # the state at sample 5 of the first chunk
                        cols = {k: np.where(np.arange(len(t)) == 5, np.nan, v) if k in ("y", "x2") else v
                                for k, v in cols.items()}
                    go_on = add(t, force, **cols)
                    if how == "raise":
                        raise RuntimeError("the engine gave up")
                    return go_on

                run.add = disturbed
                super().simulate(run)

        return Disturbed().run(scene, settings)


@pytest.mark.parametrize("name", INSTALLED)
def test_failures_are_classified_once_the_same_way_in_every_engine(name):
    # before: each run.py caught its own exceptions (MuJoCo any Exception and dropped the samples, PyBullet
    # only p.error and MemoryError) and cut divergence its own way
    scene = load_scene("feigin-pair", ["duration=0.5"])
    s = make_settings(name, 1e-3)
    raised = _Fails(name, "raise").run(scene, s)
    assert raised.status == Status.ERROR and len(raised.t) > 1  # the samples before it are kept
    assert raised.message == f"{name}: RuntimeError: the engine gave up"
    diverged = _Fails(name, "nan").run(scene, s)
    assert diverged.status == Status.DIVERGED and len(diverged.t) == 5 and np.isfinite(diverged.y).all()
    assert diverged.message.startswith(f"non-finite or huge state at t = {scene.initial.t + 0.005:.6g} s (sample 5)")


@pytest.mark.parametrize("name", INSTALLED)
def test_benchmark_has_one_signature_and_one_result(name):
    # before: four benchmarks (steps/repeats, steps/repeat), four dicts with different keys;
    # the speed goals are `chatterbench bench engines`, not timed assertions here
    result = adapter(name).benchmark(load_scene("feigin-pair"), make_settings(name, 1e-3), n_steps=300, repeats=1)
    assert isinstance(result, BenchmarkResult) and result.engine == name and result.status == "ok"
    assert result.n_steps == 300 and result.adapter_steps_per_s > 0 and result.raw_steps_per_s > 0


def test_benchmark_divides_the_steps_by_their_seconds(monkeypatch):
    # a known answer without a stopwatch: the clock the benchmark reads advances 1 us per engine step and stands
    # still otherwise, so every figure is exactly 1e6 steps/s (the adapter's with its one-step fixed cost taken off:
    # n / (n - 1) of it), whatever the machine's load. A figure off by the repeats, by a run of another length, or
    # by a unit (ms for s) is off by that factor. Before: a factor-3 band around a stopwatch, which load could break.
    from chatterbench.engines.pybullet_engine.run import PybulletEngine

    steps = [0]
    real_step = PybulletEngine.step

    def counted(self, world, forces):
        steps[0] += 1
        return real_step(self, world, forces)

    monkeypatch.setattr(PybulletEngine, "step", counted)
    monkeypatch.setattr(time, "perf_counter", lambda: steps[0] * 1e-6)
    n = 3000
    result = adapter("pybullet").benchmark(load_scene("feigin-pair"), make_settings("pybullet", 1e-4), n_steps=n,
                                           repeats=3)
    assert result.n_steps == n and result.repeats == 3
    assert result.raw_steps_per_s == pytest.approx(1e6, rel=1e-9)
    assert result.adapter_steps_per_s == pytest.approx(1e6 * n / (n - 1), rel=1e-9)
    assert result.details["fixed_s"] == pytest.approx(1e-6, rel=1e-9)  # the one-step run: one step


def test_a_failed_run_keeps_the_initial_state():
    scene = load_scene("spring-pair")
    traj = failed_trajectory("mujoco", scene, "error", "boom")
    assert traj.status == "error" and len(traj.t) == 1 and traj.y[0] == scene.initial.y


@pytest.mark.parametrize("name", INSTALLED)
def test_the_fault_hook_is_read_from_the_environment_only(name, monkeypatch):
    scene = load_scene("bouncing-ball", ["duration=0.1"])
    assert "fault" not in [f.name for f in dataclasses.fields(make_settings(name))]
    monkeypatch.setenv(ENV, f"raise:{name}:restitution=0.5")
    # the fault is raised inside the adapter's run, where every engine failure is caught: a result, never a raise
    failed = run_engine(name, scene, make_settings(name, 1e-3))
    assert failed.status == "error" and f"{name}: InjectedFault" in failed.message
    other = next(e for e in INSTALLED if e != name)
    assert run_engine(other, scene, make_settings(other, 1e-3)).status == "ok"  # another engine
    another = load_scene("bouncing-ball", ["duration=0.1", "restitution=0.4"])
    assert run_engine(name, another, make_settings(name, 1e-3)).status == "ok"  # another scene


def test_a_segfault_fault_kills_the_process_running_the_engine():
    code = ("from chatterbench.engines import run_engine, make_settings\n"
            "from chatterbench.reference.scene import load_scene\n"
            "run_engine('mujoco', load_scene('bouncing-ball'), make_settings('mujoco'))\n")
    proc = subprocess.run([sys.executable, "-c", code], env={**__import__("os").environ, ENV: "segfault:mujoco"},
                          capture_output=True, timeout=120)
    assert proc.returncode == -11  # SIGSEGV


@pytest.mark.parametrize("name", INSTALLED)
def test_a_run_too_big_for_memory_is_an_error_result_in_every_engine(name):
    # before: PyBullet died with ArrayMemoryError where MuJoCo gave status "error"
    scene = load_scene("feigin-pair", ["duration=1e9"])  # 1e13 steps: tens of TiB of samples
    traj = run_engine(name, scene, make_settings(name))
    assert traj.status == "error" and "MemoryError" in traj.message
    assert len(traj.t) == 1


# -- the contract checked when an adapter is registered (engines/contract.py), known answers both ways ----------
def _readme_engine():
    """The README's plugin engine (``EulerEngine``, ``EulerSettings``), loaded from its code block."""
    import types

    from plugin_cases import readme_block

    module = types.ModuleType("chatterbench_euler")
    sys.modules[module.__name__] = module
    exec(compile(readme_block("# chatterbench_euler.py"), "README.md", "exec"), module.__dict__)
    return module


def _broken(kind: str):
    """The README's engine with one thing of the contract broken (``kind``)."""
    euler = _readme_engine()
    base = euler.EulerEngine
    settings = {
        "not frozen": dataclasses.dataclass(type("S", (), {"__annotations__": {"dt": float}, "dt": 1e-3})),
        "no dt": dataclasses.dataclass(frozen=True)(type("S", (), {"__annotations__": {"h": float}, "h": 1e-3})),
        "dt unchecked": dataclasses.dataclass(frozen=True)(type("S", (), {"__annotations__": {"dt": float}, "dt": 1e-3})),
        "no default": dataclasses.dataclass(frozen=True)(type("S", (), {"__annotations__": {"k": int, "dt": float},
                                                                         "dt": 1e-3, "__post_init__": euler.EulerSettings.__post_init__})),
    }
    if kind in settings:
        return type("E", (base,), {"settings_type": settings[kind]})
    if kind == "no step":
        return type("E", (EngineAdapter,), {"name": "euler", "package": "p", "settings_type": euler.EulerSettings,
                                            "build": base.build})
    if kind == "nothing":
        return type("E", (EngineAdapter,), {"name": "euler", "package": "p", "settings_type": euler.EulerSettings})
    if kind == "wrong name":
        return type("E", (base,), {"name": "eulr"})
    if kind == "bad precision":
        return type("E", (base,), {"precision": "float16"})
    if kind == "exports without kind":
        return type("E", (base,), {"exports": ("model.txt",)})
    return int  # not an adapter at all


@pytest.mark.parametrize("kind, words", [
    ("not frozen", "S) is not a frozen dataclass"),
    ("no dt", "has no field 'dt'"),
    ("dt unchecked", "(dt=-1.0) was accepted: dt is not checked"),
    ("no default", "field 'k' has no default"),
    ("no step", "writes build but not step"),
    ("nothing", "writes neither build and step nor simulate"),
    ("wrong name", "E.name is 'eulr', not the name it is registered under ('euler')"),
    ("bad precision", "E.precision = 'float16': must be one of float32, float64"),
    ("exports without kind", "E.export_kind: what its model file is"),
    ("not an adapter", "int is not an EngineAdapter subclass"),
])
def test_the_contract_names_what_an_adapter_is_missing(kind, words):
    from chatterbench.engines.contract import problem

    assert problem(_readme_engine().EulerEngine, "euler") == ""  # the README's engine keeps it
    found = problem(_broken(kind), "euler")
    assert words in found and "\n" not in found, found


@pytest.mark.parametrize("name", INSTALLED)
def test_every_installed_adapter_keeps_the_contract(name):
    from chatterbench.engines.contract import problem

    assert problem(type(adapter(name)), name) == ""


def test_the_engine_rows_list_every_built_in_engine():
    from chatterbench.engines.registry import BUILT_IN, engine_rows

    rows = {r.name: r for r in engine_rows() if r.source == "built in"}
    assert set(rows) == {e.name for e in BUILT_IN}
    for name, row in rows.items():
        assert (row.status == "ok") == (name in INSTALLED) and (row.status == "ok") == (row.reason == "")
        assert row.status in ("ok", "not installed") and (row.version != "-") == (row.status == "ok")
