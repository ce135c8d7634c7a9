"""The engine contract as tests, shipped with the package: ``pytest --chatterbench-engine NAME`` runs them on any engine.

    pip install chatterbench[test] ./my-engine          # a plugin, or nothing more for a built-in engine
    cd "$(mktemp -d)" && python -m pytest --chatterbench-engine myengine

Every test takes the engine's name as the fixture ``contract_engine`` (the pytest plugin
``contract_suite.py`` gives it the names of ``--chatterbench-engine``; this package's own
``tests/engines/test_contract.py`` imports these tests and gives them every installed engine),
reaches the engine through the registry as a command does (a plugin loaded through its entry
point, checked in a forked child, run isolated), and branches on no name: what differs between
engines is read from the facts each adapter declares. What they check, in order:

1. registration: the adapter keeps the contract (``contract.problem``), its settings are its
   ``settings_type`` with ``dt`` set, its facts and its optional capabilities
   (``capabilities.implemented``) have their shapes, and the fields it says a run does not read
   (``unread_fields``) leave the run bit for bit as it is;
2. the run's grid: ``run`` samples ``base.sample_times`` (sample 0 the initial state, sample k
   after k steps), with body 1 of infinite mass filled in by the base and the contact scales
   the adapter declares;
3. a known answer: the bouncing ball's first impact measured the judge's way
   (``sampled_impacts.judged_impacts``) sends the ball back with e within ``BOUNCE_TOLERANCE`` of
   the scene's R;
4. settings refusals: a bad ``dt`` (-1, 0, NaN) is a ``SettingsError`` naming ``NAME.dt`` and its
   range, an unknown key is refused with the nearest name, another engine's settings object is
   refused, each before the engine starts (a fault planned for the run is never reached);
5. failures are results: an exception in the engine is ``error`` with the samples before it, a
   NaN sample ``diverged`` there, a run too big for memory ``error``, a test fault
   (``faults.py``) is read from the environment only;
6. crash isolation: an isolated run whose engine segfaults is ``crashed`` and the process that
   asked goes on (the next run is ``ok``);
7. the benchmark has one signature and one result.

The runs are short (a second of the bouncing ball at most, at dt = 1 ms): the suite costs a
few seconds per engine, a slow engine's steps (MuJoCo Warp on the CPU) included.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from .base import STATUS_MESSAGE, BenchmarkResult, EngineAdapter, Status, sample_times
from .capabilities import implemented
from .contract import problem
from .faults import ENV as FAULT_ENV
from .registry import (adapter, available_engines, make_settings, run_engine, run_engine_isolated,
                       unavailable_reason)
from .sampled_impacts import judged_impacts
from .settings import SettingsError

DT = 1e-3  # [s] every run's step: short runs, a second of the ball at most, for every engine
# [1] |e - R| of the bouncing ball's first impact at DT (4.43 m/s onto the floor), measured the judge's way: at R = 0.5
# the rigid engines give 0.497 to 0.501 (PyBullet, PhysX, DART, Siconos), Drake's calibrated Hunt-Crossley 0.498,
# MuJoCo's soft contact 0.470 (its default w0 dt at a 1 ms step: its contact lasts a few samples); at R = 0.8, 0.795
# to 0.801. A contact that loses a fifth of the speed more (R x 0.8 at R = 0.5: e = 0.4) is off by 0.1 and fails, and
# an engine deaf to R fails one of the two
BOUNCE_TOLERANCE = 0.05
ISOLATED_LIMIT = 120.0  # [s] the crash-isolation run's limit: a fork and a one-step run, far from it


def _scene(name: str, *overrides: str):
    from chatterbench.reference.scene import load_scene

    return load_scene(name, list(overrides))


# -- 1. registration --------------------------------------------------------------------------------
def test_the_adapter_keeps_the_registration_contract(contract_engine):
    name = contract_engine
    reason = unavailable_reason(name)  # a plugin: imported, found and checked (contract.problem) in a fork first
    assert not reason, reason
    a = adapter(name)
    assert problem(type(a), name) == "", problem(type(a), name)
    assert isinstance(a, EngineAdapter) and a.name == name and a.version()
    settings = make_settings(name, DT)
    assert isinstance(settings, a.settings_type) and settings.dt == DT
    fields = {f.name for f in dataclasses.fields(settings)}
    assert a.cost_lever(settings) in fields  # the field charts label their points with
    assert a.steps() or a.whole_runs()  # build and step, or samples


def test_the_optional_capabilities_answer_in_their_shapes(contract_engine):
    name = contract_engine
    a = adapter(name)
    scene, settings = _scene("bouncing-ball"), make_settings(name, DT)
    fields = {f.name for f in dataclasses.fields(settings)}
    has = implemented(type(a))
    space = a.tuning_space(scene)
    assert space is None or "TuningSpace" in has  # the base declares none
    if space is not None:  # dt [s] from coarse to fine; every other key a settings field of this engine
        assert "dt" in space and all(d > 0 for d in space["dt"]) and list(space["dt"]) == sorted(space["dt"], reverse=True)
        assert all(k == "dt" or (k.startswith(f"{name}.") and k.split(".", 1)[1] in fields) for k in space), space
        for key, values in space.items():  # every candidate makes valid settings
            if key != "dt":
                make_settings(name, DT, overrides={key: values[-1]})
    snippet = a.snippet(scene, settings)
    assert isinstance(snippet, str) and snippet.strip()  # something a user pastes
    if "ExportedModel" in has:
        files = a.export(scene, settings)
        assert a.exports and a.export_kind and set(files) == set(a.exports) and all(files.values())


def test_the_fields_a_run_does_not_read_leave_it_bit_for_bit(contract_engine):
    # ``unread_fields``: at each searched value of each setting, the fields the adapter says a run does not read
    # (tune makes one run of candidates that differ only there), set to each of their searched values, give the same
    # run, bit for bit; an engine that declares none is checked for the shape of its answer only
    name = contract_engine
    a = adapter(name)
    scene = _scene("bouncing-ball", "duration=0.6")  # the first impact at 0.452 s: the contact is in the run
    knobs = {k: v for k, v in (a.tuning_space(scene) or {}).items() if k != "dt"}
    fields = {f.name for f in dataclasses.fields(make_settings(name, DT))}
    for key, values in knobs.items():
        for value in values:
            unread = a.unread_fields(make_settings(name, DT, overrides={key: value}))
            assert isinstance(unread, frozenset) and unread <= fields, unread
            others = [k for k in knobs if k != key and k.split(".", 1)[1] in unread]
            if not others:
                continue
            first = run_engine(name, scene, make_settings(name, DT, overrides={key: value}))
            assert first.status == "ok", first.message
            for other in others:
                for v in knobs[other]:
                    traj = run_engine(name, scene, make_settings(name, DT, overrides={key: value, other: v}))
                    same = [np.array_equal(x, y) for x, y in zip(_state(first), _state(traj))]
                    assert all(same), f"{key}={value}: {other}={v} changed the run"


def _state(traj) -> list[np.ndarray]:
    """A trajectory's samples: times, both bodies' states, each wall's contact."""
    return [traj.t, traj.x1, traj.v1, traj.y, traj.vy, *(traj.contact[w] for w in sorted(traj.contact))]


# -- 2. the run's grid ---------------------------------------------------------------------------------
def test_a_run_samples_the_grid_with_body1_filled_in(contract_engine):
    name = contract_engine
    a, settings = adapter(name), make_settings(name, DT)
    scene = _scene("bouncing-ball", "duration=0.3")  # body 1 of infinite mass, at rest: the base fills it in
    traj = run_engine(name, scene, settings)
    assert traj.status == "ok" and isinstance(traj.status, Status), traj.message
    np.testing.assert_array_equal(traj.t, sample_times(scene, DT))
    assert len(traj.t) == 301 and traj.y[0] == scene.initial.y and traj.vy[0] == scene.initial.vy
    np.testing.assert_array_equal(traj.x1, scene.initial.x1)
    np.testing.assert_array_equal(traj.v1, 0.0)
    if a.compliant:  # the contact law's own scales are typed fields, as the adapter declares its contact
        assert math.isfinite(traj.contact_frequency) and 0 < traj.contact_time < 0.2
    else:
        assert math.isinf(traj.contact_frequency) and traj.contact_time == 0.0
    fields = {f.name for f in dataclasses.fields(settings)}
    assert "contact_time" not in traj.settings and fields <= set(traj.settings)  # the settings record
    pair = _scene("feigin-pair", "duration=0.5")  # a finite body 1: the engine's own
    traj = run_engine(name, pair, settings)
    assert traj.status == "ok", traj.message
    np.testing.assert_array_equal(traj.t, sample_times(pair, DT))
    assert traj.x1[0] == pair.initial.x1 and np.ptp(traj.x1) > 0


# -- 3. a known answer ---------------------------------------------------------------------------------
@pytest.mark.parametrize("restitution", [0.5, 0.8])
def test_the_ball_bounces_with_the_scenes_restitution(contract_engine, restitution):
    name = contract_engine
    scene = _scene("bouncing-ball", "duration=0.8", f"restitution={restitution}")  # from 1 m: one impact at 0.4515 s
    traj = run_engine(name, scene, make_settings(name, DT))
    assert traj.status == "ok", traj.message
    t, y, vy = traj.t.tolist(), traj.y.tolist(), traj.vy.tolist()
    forces = {w: f.tolist() for w, f in traj.normal_force.items()}
    found = judged_impacts(t, y, vy, [scene.gravity] * len(t), forces, {"lower": scene.gap.lower},
                           scene.restitution, 0.0)
    assert found, f"{name}: no impact of the ball on the floor"
    t_impact, wall, v_in, v_out = found[0]
    e = -v_out / v_in
    assert wall == "lower" and abs(t_impact - math.sqrt(2.0 / -scene.gravity)) < 0.01  # sqrt(2 h / g), to 10 steps
    assert abs(e - scene.restitution) <= BOUNCE_TOLERANCE, f"{name}: e = {e:.4f}, R = {scene.restitution}"


# -- 4. settings refusals --------------------------------------------------------------------------------
@pytest.mark.parametrize("dt, words", [(-1.0, "dt = -1.0: must be > 0"), (0.0, "dt = 0.0: must be > 0"),
                                       (math.nan, "dt = nan: must be a finite number > 0")])
def test_a_bad_dt_is_refused_naming_the_field_and_range(contract_engine, dt, words):
    from chatterbench.reference.errors import InputError

    with pytest.raises(SettingsError) as info:
        make_settings(contract_engine, dt)
    assert f"{contract_engine}.{words}" in str(info.value) and isinstance(info.value, InputError), str(info.value)


@pytest.mark.parametrize("override, words", [
    ("dt=0", "dt = 0: must be > 0"),
    ("dt=-1e-4", "dt = -0.0001: must be > 0"),
    ("dtt=1e-3", "unknown NAME setting; allowed: dt"),  # a misspelt key: every key listed, the nearest suggested
])
def test_a_bad_override_is_refused_the_same_way(contract_engine, override, words):
    name = contract_engine
    with pytest.raises(SettingsError) as info:
        make_settings(name, overrides=[f"{name}.{override}"])
    assert words.replace("NAME", name) in str(info.value) and name in str(info.value), str(info.value)
    if override.startswith("dtt"):
        assert str(info.value).endswith("(did you mean 'dt'?)")


def test_settings_are_refused_before_the_engine_starts(contract_engine, monkeypatch):
    name = contract_engine
    a = adapter(name)
    monkeypatch.setenv(FAULT_ENV, f"raise:{name}")  # the engine's start would raise InjectedFault (an error status)
    with pytest.raises(SettingsError, match=name):  # another engine's settings object: refused, nothing started
        a.run(_scene("bouncing-ball", "duration=0.1"), object())
    if a.steps() and type(a).drive is EngineAdapter.drive:  # no drive: a prescribed body 1 is refused up front
        moving = _scene("bouncing-ball", "duration=0.1", "prescribed.amplitude=0.01", "prescribed.omega=10.0",
                        "initial.v1=0.1")
        with pytest.raises(SettingsError, match="cannot move a prescribed body 1"):
            a.run(moving, make_settings(name, DT))


# -- 5. failures are results ------------------------------------------------------------------------------
class _Disturbed:
    """A real engine's run whose recording is disturbed after its first chunk: an exception, or a NaN sample."""

    def __init__(self, name: str, how: str) -> None:
        self.name, self.how = name, how

    def run(self, scene, settings):
        how = self.how

        class Disturbed(type(adapter(self.name))):
            def open(self, *args, **kwargs):
                run = super().open(*args, **kwargs)
                add = run.add

                def disturbed(t, force, **cols):
                    if how == "nan":  # the state at sample 5 of the first chunk
                        cols = {k: np.where(np.arange(len(t)) == 5, np.nan, v) if k in ("y", "x2") and v is not None
                                else v for k, v in cols.items()}
                    go_on = add(t, force, **cols)
                    if how == "raise":
                        raise RuntimeError("the engine gave up")
                    return go_on

                run.add = disturbed
                return run

        return Disturbed().run(scene, settings)


def test_failures_are_classified_the_same_way(contract_engine):
    name = contract_engine
    scene = _scene("feigin-pair", "duration=0.5")
    s = make_settings(name, DT)
    raised = _Disturbed(name, "raise").run(scene, s)
    assert raised.status == Status.ERROR and len(raised.t) > 1  # the samples before it are kept
    assert raised.message == f"{name}: RuntimeError: the engine gave up"
    diverged = _Disturbed(name, "nan").run(scene, s)
    assert diverged.status == Status.DIVERGED and len(diverged.t) == 5 and np.isfinite(diverged.y).all()
    assert diverged.message.startswith(f"non-finite or huge state at t = {scene.initial.t + 5 * DT:.6g} s (sample 5)")
    assert set(STATUS_MESSAGE) == set(Status)


def test_a_run_too_big_for_memory_is_an_error_result(contract_engine):
    name = contract_engine
    traj = run_engine(name, _scene("feigin-pair", "duration=1e9"), make_settings(name))  # tens of TiB of samples
    assert traj.status == "error" and "MemoryError" in traj.message and len(traj.t) == 1, traj.message


def test_a_long_run_comes_back_compact(contract_engine):
    name = contract_engine
    scene, s = _scene("bouncing-ball", "duration=0.5"), make_settings(name, DT)
    a = adapter(name)
    full, small = a.run(scene, s, compact_above=math.inf), a.run(scene, s, compact_above=0)
    assert not full.compact and small.compact and small.step == pytest.approx(DT)
    np.testing.assert_array_equal(small.t, full.t[small.index])  # the samples kept are the run's own
    np.testing.assert_array_equal(small.y, full.y[small.index])


def test_the_fault_hook_is_read_from_the_environment_only(contract_engine, monkeypatch):
    name = contract_engine
    scene = _scene("bouncing-ball", "duration=0.1")
    assert "fault" not in [f.name for f in dataclasses.fields(make_settings(name))]
    monkeypatch.setenv(FAULT_ENV, f"raise:{name}:restitution=0.5")
    # the fault is raised inside the adapter's run, where every engine failure is caught: a result, never a raise
    failed = run_engine(name, scene, make_settings(name, DT))
    assert failed.status == "error" and f"{name}: InjectedFault" in failed.message, failed.message
    another = _scene("bouncing-ball", "duration=0.1", "restitution=0.4")
    assert run_engine(name, another, make_settings(name, DT)).status == "ok"  # another scene
    other = next((e for e in available_engines() if e != name), None)
    if other is not None:  # another engine
        assert run_engine(other, scene, make_settings(other, DT)).status == "ok"


# -- 6. crash isolation -----------------------------------------------------------------------------------
def test_an_isolated_run_that_crashes_is_crashed_and_the_caller_goes_on(contract_engine, monkeypatch):
    name = contract_engine
    scene, s = _scene("bouncing-ball", "duration=0.1"), make_settings(name, DT)
    if not adapter(name).forks(s):
        pytest.skip(f"{name} cannot run in a fork at these settings (a CUDA device)")
    monkeypatch.setenv(FAULT_ENV, f"segfault:{name}")  # SIGSEGV in the process running the engine
    crashed = run_engine_isolated(name, scene, s, timeout=ISOLATED_LIMIT)
    assert crashed.status == "crashed" and "SIGSEGV" in crashed.message and len(crashed.t) == 1, crashed.message
    if adapter(name).isolated:  # a plugin: every run of it is isolated, as a command runs it
        assert run_engine(name, scene, s).status == "crashed"
    monkeypatch.delenv(FAULT_ENV)
    assert run_engine_isolated(name, scene, s, timeout=ISOLATED_LIMIT).status == "ok"  # and this process goes on
    assert run_engine(name, scene, s).status == "ok"


# -- 7. the benchmark ----------------------------------------------------------------------------------------
def test_the_benchmark_has_one_signature_and_one_result(contract_engine):
    name = contract_engine
    result = adapter(name).benchmark(_scene("feigin-pair"), make_settings(name, DT), n_steps=300, repeats=1)
    assert isinstance(result, BenchmarkResult) and result.engine == name and result.status == "ok"
    assert result.n_steps == 300 and result.adapter_steps_per_s > 0 and result.raw_steps_per_s > 0
