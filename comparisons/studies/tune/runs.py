"""A tune candidate's runs: its settings object and labels, its runs alone or with a search pass's others as one batch of
the engine, its cost in steps and of the budget, and its timed reruns.

    >>> from chatterbench.comparisons.studies.tune.runs import candidate_settings, settings_label
    >>> params = {"dt": 1e-3, "mujoco.w0_dt": 0.1}
    >>> settings_label(params), candidate_settings("mujoco", params).w0_dt
    ('dt=0.001, mujoco.w0_dt=0.1', 0.1)

A search pass's candidates go to the engine one by one in the workers (each run, struck and judged
there), or, where the engine takes thousands of runs at once and cannot be forked (``batches_on_device``:
MuJoCo Warp on cuda), as one batch here (``batch_runs``: the runs and their strikes under the scene's
forces), only the judging in the workers; a batch's run is the run alone, so the rows are the same.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from chatterbench.engines.registry import adapter, can_batch, make_settings, run_engine, run_engine_batch
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene

from ...pipeline.solution import ReferenceSolution
from ...pipeline.tolerances import Tolerances
from ..phases import phase_solution
from .checks import scene_strikes
from .passes import params_key

UNIT_STEPS = 100_000  # a run of more steps counts as steps / UNIT_STEPS runs of the budget (its work)


def candidate_settings(engine: str, params: dict[str, Any]) -> Any:
    """A candidate's settings object: ``engine``'s defaults with its ``dt`` [s] and dotted settings (``engine.field``),
    values handed on as they are (never through text); numpy scalars of a table row become Python's."""
    values = {k: v.item() if isinstance(v, np.generic) else v for k, v in params.items() if "." in k}
    return make_settings(engine, params["dt"], values)


def settings_label(params: dict[str, Any]) -> str:
    """A candidate as one string, ``dt=...`` first: the ``settings`` column."""
    return ", ".join(f"{k}={v}" for k, v in params.items())


def short_label(row: dict[str, Any], defaults: dict[str, Any]) -> str:
    """A candidate as dt and the settings it changes from the engine's defaults, without the engine prefix."""
    changed = [f"{k.split('.', 1)[-1]}={row[k]}" for k, v in defaults.items() if k in row and row[k] != v]
    return ", ".join([f"dt={row['dt']:g}", *changed])


def run_key(engine: str, params: dict[str, Any]) -> tuple | None:
    """What a candidate's run is, as a key: its params (and phase) less the settings fields a run at its settings does
    not read (``EngineAdapter.unread_fields``: Drake's integrator in discrete mode), so that candidates of one key
    make one run, bit for bit; None where its settings cannot be made (it runs alone, to be refused by name)."""
    try:
        unread = adapter(engine).unread_fields(candidate_settings(engine, params))
    except InputError:
        return None
    return params_key({k: v for k, v in params.items()
                       if not (k.startswith(f"{engine}.") and k.split(".", 1)[1] in unread)})


def steps_per_sim_s(engine: str, settings: Any, run) -> float:
    """Engine steps per simulated second: the steps the engine says it took (``settings["steps_taken"]`` of
    its trajectory), else 1 / dt for a fixed-step engine (``cost_lever`` "dt"); NaN when unknown (an
    error-controlled integrator that does not report its steps: then wall time ranks)."""
    traj = run.trajectory
    sim = _simulated(traj)
    taken = traj.settings.get("steps_taken")
    if taken is not None and sim > 0:
        return float(taken) / sim
    return 1.0 / settings.dt if adapter(engine).cost_lever(settings) == "dt" else math.nan


def run_weight(scene: Scene, dt: float) -> float:
    """What one run at ``dt`` [s] costs of the budget: its steps / ``UNIT_STEPS``, at least one run."""
    return max(1.0, scene.duration / dt / UNIT_STEPS)


def batch_runs(ref: ReferenceSolution, engine: str, batch: list[dict], tol: Tolerances) -> list[tuple | InputError]:
    """Each candidate's (trajectory, strikes under the scene's forces), the runs as one batch of the engine
    (``run_engine_batch``: MuJoCo Warp's worlds of one model), or the ``InputError`` that refuses its settings."""
    settings: list[Any] = []
    refs = [phase_solution(ref, p["dt"], p["phase"]) if "phase" in p else ref for p in batch]  # a band run's moved start
    for params, own in zip(batch, refs):
        try:
            s = candidate_settings(engine, params)
            adapter(engine).validate(own.scene, s)
            settings.append(s)
        except InputError as exc:
            settings.append(exc)
    jobs = [(own.scene, s) for own, s in zip(refs, settings) if not isinstance(s, InputError)]
    try:
        trajectories = iter(run_engine_batch(engine, jobs) if jobs else [])
    except InputError:  # one the adapter refuses only when it runs: each alone, the refused one refused
        return [s if isinstance(s, InputError) else _alone(own, engine, s, tol, "phase" not in p)
                for p, own, s in zip(batch, refs, settings)]
    out: list[tuple | InputError] = []
    for params, own, s in zip(batch, refs, settings):
        if isinstance(s, InputError):
            out.append(s)
            continue
        traj = next(trajectories)
        out.append((traj, strikes_of(own, engine, s, tol, traj) if "phase" not in params else None))
    return out


def run_and_strike(ref: ReferenceSolution, engine: str, settings: Any, tol: Tolerances, strike: bool = True) -> tuple:
    """One candidate run alone and its strikes (``strikes_of``; None where ``strike`` is False: a band run checks a
    candidate's timing, the candidate's own strikes its restitution); InputError for settings the scene cannot run
    with."""
    traj = run_engine(engine, ref.scene, settings)
    return traj, strikes_of(ref, engine, settings, tol, traj) if strike else None


def strikes_of(ref: ReferenceSolution, engine: str, settings: Any, tol: Tolerances, traj) -> Any:
    """The settings struck under the scene's forces (``tune.checks.scene_strikes``), meeting the contact the run
    ``traj`` had; None for a run that failed."""
    return scene_strikes(engine, settings, ref, tol, traj.settings) if traj.status == "ok" else None


def _alone(ref: ReferenceSolution, engine: str, settings: Any, tol: Tolerances, strike: bool = True) -> tuple | InputError:
    """``batch_runs`` of one candidate, run by itself."""
    try:
        return run_and_strike(ref, engine, settings, tol, strike)
    except InputError as exc:
        return exc


def batches_on_device(engine: str) -> bool:
    """Whether tune hands ``engine`` a search pass's candidates as one batch: an engine that takes thousands of runs
    at once (``EngineAdapter.unit_runs``: MuJoCo Warp on cuda), whose runs cannot be forked into the workers."""
    return can_batch(engine) and adapter(engine).unit_runs(make_settings(engine)) is not None


def batches_in_workers(engine: str) -> bool:
    """Whether tune hands each worker a part of a search pass as one batch of ``engine`` (``rows.evaluator``): an
    engine that runs compatible jobs together (``can_batch``) and not thousands at once on a device
    (``batches_on_device``). MuJoCo Warp on the CPU: a block of 8 worlds steps in about the time of 2 alone."""
    return can_batch(engine) and not batches_on_device(engine)


def time_runs(scene: Scene, engine: str, candidates: list[dict], repeats: int) -> list[list[float]]:
    """Wall-clock stepping seconds per simulated second of ``repeats`` more runs of each candidate, interleaved
    (A B A B ...: a change in the machine's load falls on all of them alike), one after another in this process."""
    settings = [candidate_settings(engine, p) for p in candidates]
    out: list[list[float]] = [[] for _ in candidates]
    for _ in range(repeats):
        for times, s in zip(out, settings):
            traj = run_engine(engine, scene, s)
            sim = _simulated(traj)
            if traj.status == "ok" and sim > 0:
                times.append(traj.wall_time / sim)
    return out


def _simulated(traj) -> float:
    """The simulated seconds a trajectory spans [s] (0 below two samples)."""
    return float(traj.t[-1] - traj.t[0]) if len(traj.t) > 1 else 0.0
