"""The engine contract (``engines/base.py``): every installed engine, through the registry, keeps the same promises.

The per-engine tests are the package's shipped suite (``engines/contract_tests.py``, what
``pytest --chatterbench-engine NAME`` runs for a plugin's author), imported here and given
``available_engines()`` (built in, optional extras installed, and plugins found through the
``chatterbench.engines`` entry points) as ``CONTRACT_ENGINES``: one copy of the tests, with no
branch on names. Here beside them: what holds for no engine in particular (the step count, the
engine table, the benchmark's arithmetic, the registration check's messages).
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import time

import numpy as np
import pytest

from chatterbench.engines import EngineAdapter, Status, adapter, make_settings, sample_times
from chatterbench.engines.base import STATUS_MESSAGE, failed_trajectory, n_steps
from chatterbench.engines.contract_tests import *  # noqa: F401,F403  the shipped suite, on every installed engine
from chatterbench.engines.faults import ENV
from chatterbench.engines.registry import DEFAULT_ENGINES, ENGINE_NAMES, ENGINES, EXTRAS, available_engines
from chatterbench.reference.scene import load_scene

INSTALLED = available_engines()
CONTRACT_ENGINES = INSTALLED  # the engines the shipped suite's tests take (``contract_suite.pytest_generate_tests``)


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


def test_the_engines_grid_is_the_sampled_references():
    # every engine samples base.sample_times (the shipped suite's test_a_run_samples_the_grid_with_body1_filled_in);
    # so does the sampled reference the judge compares them with
    from chatterbench.comparisons.pipeline.sampling import sample_grid

    scene = load_scene("feigin-pair", ["duration=1.0"])
    np.testing.assert_array_equal(sample_grid(scene, 3e-4), sample_times(scene, 3e-4))
    assert len(sample_times(scene, 3e-4)) == 3334


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


def test_a_segfault_fault_kills_the_process_running_the_engine():
    code = ("from chatterbench.engines import run_engine, make_settings\n"
            "from chatterbench.reference.scene import load_scene\n"
            "run_engine('mujoco', load_scene('bouncing-ball'), make_settings('mujoco'))\n")
    proc = subprocess.run([sys.executable, "-c", code], env={**__import__("os").environ, ENV: "segfault:mujoco"},
                          capture_output=True, timeout=120)
    assert proc.returncode == -11  # SIGSEGV


# -- the contract checked when an adapter is registered (engines/contract.py), known answers both ways ----------
def _howto_engine():
    """The plugin how-to's engine (``EulerEngine``, ``EulerSettings``), loaded from its code block."""
    import types

    from plugin_cases import readme_block

    module = types.ModuleType("chatterbench_euler")
    sys.modules[module.__name__] = module
    exec(compile(readme_block("# chatterbench_euler.py"), "docs/how-to/plugin.md", "exec"), module.__dict__)
    return module


def _broken(kind: str):
    """The plugin how-to's engine with one thing of the contract broken (``kind``)."""
    euler = _howto_engine()
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
    if kind == "writes simulate":  # the run is the base's: a whole-run engine yields its samples
        return type("E", (base,), {"simulate": lambda self, run: None})
    return int  # not an adapter at all


@pytest.mark.parametrize("kind, words", [
    ("not frozen", "S) is not a frozen dataclass"),
    ("no dt", "has no field 'dt'"),
    ("dt unchecked", "(dt=-1.0) was accepted: dt is not checked"),
    ("no default", "field 'k' has no default"),
    ("no step", "writes build but not step"),
    ("nothing", "writes neither build and step nor samples"),
    ("wrong name", "E.name is 'eulr', not the name it is registered under ('euler')"),
    ("bad precision", "E.precision = 'float16': must be one of float32, float64"),
    ("exports without kind", "E.export_kind: what its model file is"),
    ("writes simulate", "E writes simulate, the base's run: a whole-run engine writes samples(run)"),
    ("not an adapter", "int is not an EngineAdapter subclass"),
])
def test_the_contract_names_what_an_adapter_is_missing(kind, words):
    from chatterbench.engines.contract import problem

    assert problem(_howto_engine().EulerEngine, "euler") == ""  # the plugin how-to's engine keeps it
    found = problem(_broken(kind), "euler")
    assert words in found and "\n" not in found, found


def test_the_engine_rows_list_every_built_in_engine():
    from chatterbench.engines.registry import BUILT_IN, engine_rows

    rows = {r.name: r for r in engine_rows() if r.source == "built in"}
    assert set(rows) == {e.name for e in BUILT_IN}
    for name, row in rows.items():
        assert (row.status == "ok") == (name in INSTALLED) and (row.status == "ok") == (row.reason == "")
        assert row.status in ("ok", "not installed") and (row.version != "-") == (row.status == "ok")


def test_a_field_called_unread_that_the_run_reads_fails_the_contract(monkeypatch):
    # the other way of the shipped suite's unread-fields test: MuJoCo's adapter made to say that at the implicitfast
    # integrator its runs do not read w0 dt (they do: the contact's stiffness) fails it, naming the setting
    from chatterbench.engines.contract_tests import test_the_fields_a_run_does_not_read_leave_it_bit_for_bit as check

    mujoco = adapter("mujoco")
    check("mujoco")  # as declared (nothing unread): passes
    monkeypatch.setattr(type(mujoco), "unread_fields",
                        lambda self, s: frozenset({"w0_dt"}) if s.integrator == "implicitfast" else frozenset())
    with pytest.raises(AssertionError, match=r"mujoco.integrator=implicitfast: mujoco.w0_dt=.* changed the run"):
        check("mujoco")
