"""Candidates of one run make one run (issue 42, the atlas's cost): settings that differ only in fields the run does not
read (``EngineAdapter.unread_fields``: Drake's integrator in discrete mode) give the same row, value for value, as
their own run would, and a whole tune gives the same table with fewer runs.

Found in the kept atlas's rows: Drake's spring pair ran every discrete candidate at each of the 3 to 5 searched
``accuracy`` values (discrete mode reads none): 60 of its 918 runs were repeats, 2,130 of its 3,214 s of runs
(dt 1.7e-5 and 1.1e-5: 100 to 200 s a run).
"""

from __future__ import annotations

import json
import math
from concurrent.futures import Executor, Future

import pytest

from helpers import needs_engine

from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.tune import runner
from chatterbench.comparisons.studies.tune.ladder import Ladder
from chatterbench.comparisons.studies.tune.passes import need
from chatterbench.comparisons.studies.tune.rows import evaluate, evaluator, shared_row
from chatterbench.comparisons.studies.tune.runs import run_key
from chatterbench.reference import load_scene

ASKED = Tolerances(stick=0.05, exit=0.02, first_impact=0.05, restitution=0.05)  # the atlas's
# Drake's continuous spring pair at the kept atlas's answer (robust at stick 20%, restitution 10%)
CONTINUOUS = {"dt": 0.00565, "drake.mode": "continuous", "drake.accuracy": 3.162e-05, "drake.contact_time_ratio": 0.01}
# Drake's discrete bouncing ball (TAMSI, 0.3 ms), which passes at two points of the ladder around a loose tolerance:
# dt is its cost lever, so a row's judged points can be cut down by the search's bounds (tune.passes.need)
DISCRETE = {"dt": 3e-4, "drake.mode": "discrete", "drake.solver": "tamsi", "drake.contact_time_ratio": 0.0035}
LOOSE = Tolerances(stick=0.3, exit=0.3, first_impact=0.3, restitution=0.3)

class InProcess(Executor):
    """An executor that runs each task here at once and counts them: the runs tune makes."""

    def __init__(self) -> None:
        self.tasks = 0

    def submit(self, fn, /, *args, **kwargs) -> Future:
        self.tasks += 1
        done: Future = Future()
        try:
            done.set_result(fn(*args, **kwargs))
        except Exception as exc:  # noqa: BLE001  (as a worker's: the future holds it)
            done.set_exception(exc)
        return done


def _same(a: dict, b: dict, but=("cost_per_sim_s",)) -> bool:
    """Two rows equal value for value (NaN equal to NaN), but the wall time of their runs."""
    text = lambda row: json.dumps({k: v for k, v in row.items() if k not in but}, sort_keys=True, default=str)  # noqa: E731
    return text(a) == text(b)


def test_a_run_key_leaves_out_the_fields_the_run_does_not_read():
    needs_engine("drake")
    discrete = {"dt": 1e-4, "drake.mode": "discrete", "drake.contact_time_ratio": 0.01}
    assert run_key("drake", {**discrete, "drake.accuracy": 1e-8}) == run_key("drake", {**discrete, "drake.accuracy": 1e-4})
    assert run_key("drake", {**discrete, "drake.accuracy": 1e-8, "phase": 0.5}) != run_key("drake", {**discrete, "phase": 0.5, "drake.accuracy": 1e-8, "dt": 2e-4})
    assert run_key("drake", {**CONTINUOUS, "drake.solver": "sap"}) == run_key("drake", {**CONTINUOUS, "drake.solver": "tamsi"})
    # the other way: what a mode reads keeps candidates apart
    assert run_key("drake", {**CONTINUOUS, "drake.accuracy": 1e-8}) != run_key("drake", CONTINUOUS)
    assert run_key("drake", {**discrete, "drake.solver": "tamsi"}) != run_key("drake", {**discrete, "drake.solver": "sap"})
    assert run_key("mujoco", {"dt": 1e-3, "mujoco.w0_dt": 0.1}) != run_key("mujoco", {"dt": 1e-3, "mujoco.w0_dt": 0.3})
    assert run_key("drake", {"dt": 1e-3, "drake.accuracy": 7.0}) is None  # refused settings run alone, refused by name


def test_a_shared_row_is_the_row_its_own_run_gives_where_it_can_still_matter():
    needs_engine("drake")
    ref = solve(load_scene("bouncing-ball"))
    points = Ladder().points(LOOSE)
    asked = points.index(LOOSE)
    made = evaluate(ref, "drake", {**DISCRETE, "drake.accuracy": 1e-6}, points, asked)
    assert len(made["passes"]) >= 2 and made["unjudged"] == ()  # passes somewhere, judged everywhere
    other = {**DISCRETE, "drake.accuracy": 1e-8}
    # all points judged (no bounds yet): the other's own run gives the same row
    assert _same(shared_row(made, other, "drake", len(points), asked, None), evaluate(ref, "drake", other, points, asked))
    # bounds that leave out a point it passes at (tune.passes.need): judged where they reach, as its own run would be
    left_out = set(made["passes"][::2]) - {asked}
    bounds = [0.0 if p in left_out else math.inf for p in range(len(points))]
    assert left_out and not left_out & set(need(made["steps_per_sim_s"], bounds, asked))
    shared = shared_row(made, other, "drake", len(points), asked, bounds)
    assert _same(shared, evaluate(ref, "drake", other, points, asked, bounds))
    assert set(shared["unjudged"]) == left_out and not left_out & set(shared["passes"]) and shared["passes"]
    assert len(shared["margins"]) == len(shared["passes"]) == len(shared["rests"]) == len(shared["limits"])
    # the other way: a row judged at fewer points than a later candidate needs is not shared (that one runs)
    assert shared_row(shared, {**DISCRETE, "drake.accuracy": 1e-4}, "drake", len(points), asked, None) is None


def test_a_tune_makes_one_run_of_candidates_of_one_run_and_the_same_table(monkeypatch):
    # Drake's bouncing ball, a budget of 40 runs: its discrete slice searches accuracy (unread there) at 3 values
    needs_engine("drake")
    scene = load_scene("bouncing-ball")
    tables, tasks = {}, {}
    for shared in (True, False):
        pool = InProcess()
        monkeypatch.setattr(runner, "evaluator", lambda *args, shared=shared, **kw: evaluator(*args, **kw, shared=shared))
        result = runner.tune(scene, "drake", ASKED, executor=pool, max_runs=40, transfer=False)
        tables[shared] = result.table.drop(columns=["cost_per_sim_s"]).sort_values(["settings", "stage"]).reset_index(drop=True)
        tasks[shared] = pool.tasks
        assert result.extra["searched"]["shared_runs"] == len(result.table) - pool.tasks  # said in recommended.json
    assert tables[True].equals(tables[False])  # row for row, value for value, but the runs' wall times
    discrete = tables[True][tables[True]["drake.mode"] == "discrete"]
    def params(r) -> dict:  # a discrete row's run: its dt, contact, and phase for a band run
        phase = r.get("phase", math.nan)
        return {"dt": r["dt"], "drake.mode": "discrete", "drake.contact_time_ratio": r["drake.contact_time_ratio"],
                **({} if math.isnan(phase) else {"phase": phase})}
    repeats = len(discrete) - len({run_key("drake", params(r)) for _, r in discrete.iterrows()})
    assert repeats > 0 and tasks[False] == len(tables[False]) and tasks[True] == tasks[False] - repeats


def test_a_batch_runs_a_refused_candidate_alone_and_names_it():
    # candidates the settings refuse make no run key: each runs alone, refused by name, the others unchanged
    needs_engine("drake")
    ref = solve(load_scene("bouncing-ball", ["duration=0.6"]))
    points = (ASKED,)
    pool = InProcess()
    run_batch = evaluator(pool, ref, "drake", points, 0)
    good = {"dt": 1e-3, "drake.mode": "discrete", "drake.accuracy": 1e-6, "drake.contact_time_ratio": 0.0035}
    rows = run_batch([good, {**good, "drake.accuracy": 2.0}, {**good, "drake.accuracy": 1e-8}], "grid")
    assert [r["verdict"] == "refused" for r in rows] == [False, True, False] and "drake.accuracy" in rows[1]["failed"]
    assert _same({**rows[0], "settings": ""}, {**rows[2], "settings": "", "drake.accuracy": 1e-6}) and pool.tasks == 2
    assert all(r["stage"] == "grid" for r in rows)
    with pytest.raises(AssertionError):  # a row of another run is not the same (the helper can fail)
        assert _same(rows[0], evaluate(ref, "drake", {**good, "dt": 5e-4}, points, 0))
