"""The resource budget: estimates that hold, refusals that name the input, no refusal of real work."""

from __future__ import annotations

import pytest

from chatterbench.comparisons.pipeline.budget import (GIB, LONG_PERIODS, Budget, BudgetError, check_comparison,
                                                      check_engine_run, check_plate_map, engine_estimate,
                                                      reference_estimate)
from chatterbench.engines import ENGINE_NAMES, make_settings, n_steps
from chatterbench.engines.registry import adapter, unavailable_reason
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import load_scene
from chatterbench.reference.simulate import simulate


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_the_default_budget_refuses_no_built_in_work(name):
    scene = load_scene(name)
    for engine in ENGINE_NAMES:  # the default settings, and the finest dt tune tries
        if unavailable_reason(engine):  # an engine not installed here (siconos needs a system package) has no settings
            continue
        check_comparison(scene, {engine: make_settings(engine)}, Budget())
        space = adapter(engine).tuning_space(scene)
        if space is not None:
            check_engine_run(scene, engine, min(space["dt"]), Budget())


def test_engine_steps_follow_the_engines_own_step_rule():
    scene = load_scene("feigin-pair")
    for dt in (1e-3, 3e-4, 1e-4):
        assert engine_estimate(scene, "mujoco", dt).steps == n_steps(scene.duration, dt)


def test_a_runaway_engine_run_is_refused_with_its_estimate_and_limit():
    scene = load_scene("feigin-pair")
    with pytest.raises(BudgetError) as err:
        check_engine_run(scene, "pybullet", 1e-7, Budget())
    text = str(err.value)
    assert "dt = 1e-07" in text and "4.02e+08 steps" in text and "--max-steps 5e+07" in text and "--max-memory" in text
    # raising the limits lets the same run through: the refusal is the budget's, not the input's
    est = check_engine_run(scene, "pybullet", 1e-7, Budget(max_steps=1e9, max_memory=1000 * GIB))
    assert est.steps == 402123859 and est.memory > 40 * GIB  # 125 B a step: 47 GiB
    # a timestep below the float spacing of the run's times is refused whatever the budget
    far = load_scene("feigin-pair", ["initial.t=1e6"])
    with pytest.raises(BudgetError, match="too small for times near"):
        check_engine_run(far, "mujoco", 1e-13, Budget(max_steps=1e30, max_memory=1e30))


def test_the_reference_estimate_comes_from_a_pilot_and_holds():
    scene = load_scene("feigin-pair")
    long = load_scene("feigin-pair", [f"duration={3 * LONG_PERIODS * scene.time_scale}"])
    est = reference_estimate(long)
    events = sum(len(simulate(long, mode).log) for mode in ("feigin", "exhaustive"))
    assert 0.8 * events <= est.steps <= 1.25 * events, (est.steps, events)
    assert reference_estimate(scene).steps == 0  # short runs are not piloted
    with pytest.raises(BudgetError, match="the reference on 'feigin-pair': duration = 1e\\+06 s"):
        check_comparison(load_scene("feigin-pair", ["duration=1e6"]), {}, Budget())


def test_a_plate_map_grid_is_bounded_by_memory():
    check_plate_map(96, 64, Budget())
    with pytest.raises(BudgetError, match="--phases 100000 x --speeds 100000"):
        check_plate_map(100000, 100000, Budget())


@pytest.mark.parametrize("field, value", [("max_steps", 0), ("max_memory", 1.0), ("max_steps", float("inf")),
                                          ("max_memory", True)])
def test_a_budget_out_of_range_is_refused_by_name(field, value):
    with pytest.raises(BudgetError, match=f"--{field.replace('_', '-')}"):
        Budget(**{field: value})
