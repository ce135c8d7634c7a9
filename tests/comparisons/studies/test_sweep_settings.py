"""A sweep's run and a tune candidate make their settings object once, from typed values, never through text."""

import pytest
from helpers import count_settings_made, measured

import chatterbench.engines.settings as engine_settings_module
from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.summary import summarize
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.sweep.spec import Sweep, sweep_runs
from chatterbench.comparisons.studies.sweep.worker import _compute_batch_rows, _compute_row
from chatterbench.comparisons.studies.tune import tune
from chatterbench.reference import load_scene

def test_a_sweep_run_makes_its_settings_once(monkeypatch):
    made = count_settings_made(monkeypatch)
    sweep = Sweep(scene="bouncing-ball", engines=("mujoco",), fixed={"duration": 1.6, "dt": 1e-3},
                  grid={"mujoco.w0_dt": (0.03, 0.1)})
    tasks = sweep_runs(sweep)
    made.clear()  # reading the spec validates every point's settings; the runs are counted from here
    batched = _compute_batch_rows(tasks)  # in this process (a worker runs it in an isolated child)
    assert made == ["mujoco", "mujoco"]  # one object per run, for the engine and for compare alike
    made.clear()
    alone = _compute_row(tasks[1])
    assert made == ["mujoco"]
    assert measured(alone) == measured(batched[1])
    # each row is its own settings' run: a spring-damper struck at speed v sinks v / w0 times a function of its
    # damping ratio alone (one R, one zeta), so the deepest penetrations are as w0 dt, 0.1 / 0.03 (2%: the steps
    # resolve the stiffer contact less finely)
    assert batched[0]["penetration_max"] / batched[1]["penetration_max"] == pytest.approx(0.1 / 0.03, rel=0.02)
    # and each is the run the text --set gives
    scene = load_scene("bouncing-ball", ["duration=1.6"])
    for task, row in zip(tasks, batched):
        text = f"mujoco.w0_dt={dict(task.params)['mujoco.w0_dt']}"
        assert measured(summarize(compare(scene, settings=settings_for(("mujoco",), 1e-3, [text])), "mujoco", {})) == \
            measured(row)


def test_tune_hands_its_candidates_on_as_values_not_text(monkeypatch):
    def refuse(item):
        raise AssertionError(f"{item!r} parsed inside the library")
    monkeypatch.setattr(engine_settings_module, "split_assignment", refuse)  # the worker processes fork with it
    space = {"dt": (1e-3,), "mujoco.w0_dt": (0.1,), "mujoco.integrator": ("euler", "implicitfast")}
    result = tune(load_scene("bouncing-ball", ["duration=1.6"]), "mujoco", Tolerances(), space=space, workers=1,
                  refine_steps=0, check_robust=False)
    assert set(result.table["mujoco.integrator"]) == {"euler", "implicitfast"}
    assert (result.table["status"] == "ok").all(), result.table[["settings", "status", "message"]]
