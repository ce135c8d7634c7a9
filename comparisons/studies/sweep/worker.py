"""One run of a sweep, inside a worker: the run isolated in a child process, its row, or its failure row.

    >>> from chatterbench.comparisons.studies.sweep.worker import run_task
    >>> from chatterbench.comparisons.studies.sweep.spec import load_sweep, sweep_runs
    >>> result = run_task(sweep_runs(load_sweep("examples/sweeps/bouncing-ball-dt.toml"))[0])
    >>> result.row["status"], result.row["engine"]
    ('ok', 'mujoco')

Every run goes through ``isolate.run_isolated`` inside the function submitted to the
executor, so under a local process pool and under Dask alike a run that segfaults is a
``crashed`` row, one past the timeout a ``timeout`` row, one that raises an ``error`` row.
Runs go in units of a few runs of one engine (``work_units``); MuJoCo's compatible runs of
a unit share one ``mujoco.rollout`` call, with the rows of runs made one by one, bit for bit.
A run's settings object is made once (``task_settings``) and handed to the engine and to
``compare`` alike.
"""

from __future__ import annotations

import math
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.summary import failure_row, mass_ratio, summarize
from chatterbench.comparisons.pipeline.tolerances import make_tolerances
from chatterbench.engines.isolate import Outcome, run_isolated
from chatterbench.engines.registry import (adapter, can_batch, engine_version, is_plugin, make_settings, run_engine_batch,
                                           settings_for)
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene, load_scene

from .spec import RunTask

_MESSAGE_CHARS = 4000  # a failure row keeps the end of a traceback, where the cause is

_WARM: set = set()  # engine names and ("scene", scene) keys already warmed in this process
_WARM_LOCK = threading.Lock()


def _warm_up(task: RunTask) -> None:
    """Once per worker process: load the task's engine and the reference's kernels for its scene.

    Every run is a fork of the worker, so what is loaded here is loaded for all of them;
    without it each run would pay the imports and numba's cache loading (~0.6 s). The
    reference is run once on the task's own scene too: numba loads a compiled kernel the
    first time a scene's code path calls it (~10 ms for feigin-pair after a ball warm-up),
    and a forked run would otherwise pay that again every time.
    """
    with _WARM_LOCK:
        todo = [key for key in (task.engine, ("scene", task.scene)) if key not in _WARM]
        if not todo:
            return
        try:
            if task.engine in todo and not is_plugin(task.engine):  # a plugin's runs are isolated: nothing to warm
                compare(load_scene("bouncing-ball", {"duration": 0.6}), settings=settings_for((task.engine,), 1e-3))
            if ("scene", task.scene) in todo:
                compare(load_scene(task.scene, task.scene_overrides()), engines=())
        except Exception:  # a warm-up failure is only slower runs; the runs report real errors
            pass
        _WARM.update(todo)


def task_settings(task: RunTask) -> Any:
    """The run's engine settings object, made once from its dt and its own settings (TOML values, already typed)."""
    return make_settings(task.engine, task.dt, task.engine_overrides())


def _row(task: RunTask, scene: Scene, settings: Any, trajectory: Trajectory | None = None) -> dict[str, Any]:
    """The row of one run: its comparison with ``settings`` (on ``trajectory`` when already run), summarized."""
    result = compare(scene, engines=(task.engine,), settings={task.engine: settings},
                     tol=make_tolerances(dict(task.tolerances)),
                     trajectories=None if trajectory is None else {task.engine: trajectory})
    return summarize(result, task.engine, dict(task.params))


def _compute_row(task: RunTask) -> dict[str, Any]:
    """The row of one run (runs in the isolated child)."""
    return _row(task, load_scene(task.scene, task.scene_overrides()), task_settings(task))


@dataclass(frozen=True)
class RunResult:
    """A worker's answer: the row and what the run cost."""

    index: int
    row: dict[str, Any]
    run_time: float  # [s] wall-clock of the isolated run, fork to result


def _forks(task: RunTask) -> bool:
    """Whether the task's run may be made in a forked child (``EngineAdapter.forks``: not MuJoCo Warp on cuda)."""
    try:
        return adapter(task.engine).forks(task_settings(task))
    except Exception:  # noqa: BLE001  the run itself reports what is wrong with it, isolated
        return True


def _here(fn: Callable[..., Any], *args: Any) -> Outcome:
    """``fn(*args)`` in this process, as ``run_isolated`` reports it (an exception is ``error``; no time limit: an
    engine that cannot be forked keeps its own failures in its results)."""
    start = time.perf_counter()
    try:
        value = fn(*args)
    except Exception as exc:  # noqa: BLE001  a failure row, as an isolated run's
        return Outcome("error", None, f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}",
                       time.perf_counter() - start)
    return Outcome("ok", value, "", time.perf_counter() - start)


def run_task(task: RunTask) -> RunResult:
    """The function submitted to the executor: one isolated run -> its row (never raises for the run); made in the
    worker itself for an engine that cannot be forked (``_forks``)."""
    _warm_up(task)
    outcome = run_isolated(_compute_row, task, timeout=task.timeout) if _forks(task) else _here(_compute_row, task)
    if outcome.status == "ok":
        row = outcome.value
    else:
        message = outcome.message if len(outcome.message) <= _MESSAGE_CHARS else "..." + outcome.message[-_MESSAGE_CHARS:]
        try:
            version = engine_version(task.engine)
        except Exception:
            version = ""
        try:  # the spec was validated: the scene loads; the guard keeps a failure row whatever happens
            mu = mass_ratio(load_scene(task.scene, task.scene_overrides()))
        except Exception:
            mu = math.nan
        row = failure_row(task.scene_name, task.engine, dict(task.params), outcome.status, message, version, mu)
        row["dt"] = task.dt
    return RunResult(index=task.index, row=row, run_time=outcome.wall_time)


def _compute_batch_rows(tasks: Sequence[RunTask]) -> list[dict[str, Any]]:
    """The rows of runs of one engine, in one isolated child (MuJoCo: compatible runs rolled out together, a chunk of each in turn)."""
    scenes = [load_scene(t.scene, t.scene_overrides()) for t in tasks]
    settings = [task_settings(t) for t in tasks]
    trajectories = run_engine_batch(tasks[0].engine, list(zip(scenes, settings)))
    return [_row(*job) for job in zip(tasks, scenes, settings, trajectories)]


def run_batch_task(tasks: Sequence[RunTask]) -> list[RunResult]:
    """The function submitted for a unit of work (``work_units``): one isolated call for all -> their rows.

    The batch's limit is the sum of its runs' limits. If the batch does not come back whole
    (a run crashed, hung or raised, or a run's settings refuse the batch), every run of it
    is run again alone through ``run_task``, so the faulty run is classified by itself and
    the others get their rows. Each row's ``run_time`` is its share of the batch's time. An engine
    that cannot be forked (``EngineAdapter.forks``: MuJoCo Warp on cuda) runs in the worker itself.
    """
    if len(tasks) == 1:
        return [run_task(tasks[0])]
    _warm_up(tasks[0])
    if _forks(tasks[0]):
        outcome = run_isolated(_compute_batch_rows, list(tasks), timeout=sum(t.timeout for t in tasks))
    else:
        outcome = _here(_compute_batch_rows, list(tasks))
    if outcome.status != "ok":
        return [run_task(t) for t in tasks]
    share = outcome.wall_time / len(tasks)
    return [RunResult(index=t.index, row=row, run_time=share) for t, row in zip(tasks, outcome.value)]


MAX_BATCH = 8  # runs per unit of work by default: long enough to amortize, short enough to balance


def work_units(runs: Sequence[RunTask], batch: int | None, slots: int,
               unit_runs: Callable[[RunTask], int | None] | None = None) -> list[tuple[RunTask, ...]]:
    """Group ``runs`` into units of work (one isolated child each), ordered by their first run.

    A unit holds runs of one engine; for an engine that batches (MuJoCo) also of one ``dt``
    and duration, and the worker rolls out together the ones whose compiled models are
    compatible. Other engines' runs in a unit run one after another in the same child,
    which saves a fork per run. Sizes: ``batch`` runs per unit; or the engine's own
    (``unit_runs(run)``, by default ``EngineAdapter.unit_runs``: MuJoCo Warp on a GPU takes
    thousands of worlds at once); or by default guided self-scheduling, ``remaining // (4
    slots)`` clipped to [1, MAX_BATCH], so units shrink towards the end of each group and no
    slot waits long for the last one. ``batch = 1``: every run alone.
    """
    unit_runs = unit_runs or _unit_runs
    groups: dict[tuple, list[RunTask]] = {}
    for r in runs:
        key = (r.engine, r.dt, dict(r.params).get("duration")) if can_batch(r.engine) else (r.engine,)
        groups.setdefault(key, []).append(r)
    first_of: dict[int, tuple[RunTask, ...]] = {}
    for g in groups.values():
        own = unit_runs(g[0]) if batch is None and can_batch(g[0].engine) else None
        i = 0
        while i < len(g):
            size = batch if batch is not None else own if own is not None else \
                max(1, min(MAX_BATCH, (len(g) - i) // (4 * max(1, slots))))
            chunk = tuple(g[i:i + size])
            first_of[chunk[0].index] = chunk
            i += size
    return [first_of[r.index] for r in runs if r.index in first_of]


def _unit_runs(task: RunTask) -> int | None:
    """The engine's own unit size for the task's settings (``EngineAdapter.unit_runs``); None when it names none."""
    try:
        return adapter(task.engine).unit_runs(task_settings(task))
    except Exception:  # noqa: BLE001  the runs report what is wrong with them
        return None
