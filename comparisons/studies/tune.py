"""Engine tuning: for a scene and tolerances, the cheapest settings that pass, and every cheaper one with the check it failed.

    >>> space = {"dt": (1e-3, 3e-4), "mujoco.w0_dt": (0.1,)}
    >>> result = tune(load_scene("feigin-pair", ["duration=12.6"]), "mujoco", Tolerances(), space=space, workers=1,
    ...               refine_steps=0)
    >>> result.best["settings"]            # the recommended settings (None if nothing passes)
    'dt=0.0003, mujoco.w0_dt=0.1'
    >>> result.table.loc[0, "failed"]      # the cheaper candidate, and why it fails
    'sticking error +0.124 of the chatter > 0.05'

``outputs/guide.py`` turns the result into the tuning guide.

The search (``tune_search.py``) walks each engine's own space (``EngineAdapter.tuning_space``:
a dt ladder and, per setting, its values, the default first) one setting at a time, each
combination down the dt ladder from coarse to fine until a level passes, then bisects dt
between the cheapest pass and the failure above it. Every candidate is judged by the one
judge (``pipeline.compare.judge_run``) against one reference solution, condensed to the
summary row (``pipeline.summary.metrics``) plus each check's error over its tolerance
(``tune_checks``): ``failed`` names the checks that failed with their measures.

Cost and choice. The cost of a candidate is its steps per simulated second (1 / dt: every
searched setting makes one force evaluation per step, so this is the work, and it is free
of timing noise), with the wall-clock stepping time per simulated second beside it
(``cost_per_sim_s``: the minimum over ``repeats`` runs for the candidates the choice is
between, interleaved, one run for the others; ``cost_repeats`` says which): reported, never
deciding, since on a shared machine it follows the load (``TIE_BAND``'s comment). The
recommendation is the passing candidate (verdicts ``match`` or ``none`` in every episode) of
fewest steps; those within ``tie_band`` (10%) of it in steps are tied, and the tie goes to the
simplest: fewest settings away from the engine's defaults, then the larger dt, then the
smaller wall time. When nothing
passes, ``best_reachable`` is the candidate with the most matching episodes, then the
smallest ``worst_ratio`` (its worst error over its tolerance), then the fewest steps.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Sequence

import pandas as pd

from chatterbench.engines.registry import adapter, check_engine, make_settings, run_engine
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene, SceneError

from ..pipeline.compare import judge_run
from ..pipeline.solution import ReferenceSolution, solve
from ..pipeline.summary import METRIC_COLUMNS, metrics
from ..pipeline.tolerances import Tolerances
from .tune_checks import RATIO_COLUMNS, check_ratios, describe_failures
from .tune_search import agrees, search

TUNE_COLUMNS = ["stage", "dt", "settings", "verdict", "n_episodes", "n_match", "failed", *RATIO_COLUMNS,
                *METRIC_COLUMNS, "steps_per_sim_s", "cost_per_sim_s", "cost_repeats", "n_non_default", "status", "message"]
TIE_BAND = 0.1  # [-] steps per simulated second within 10% of each other are a tie
# Wall time decides nothing: on this shared 2-core machine the least of 3 interleaved timings of PyBullet at
# dt = 4.05e-4 with 10 and 50 solver iterations (identical trajectories) came out 1.10x apart in one measurement
# and 2.2x in another (tune feigin-pair --engine pybullet --tolerance 0.01): a choice by it follows the load.


class TuneError(SceneError):
    """A search space tune cannot use (no dt ladder, an empty list, an engine that declares none)."""


@dataclass(frozen=True)
class TuneResult:
    """Every candidate tried (``table``, cheapest first), the recommendation and the best reachable candidate."""

    scene: Scene
    engine: str
    tolerance: Tolerances
    table: pd.DataFrame  # TUNE_COLUMNS plus one column per searched setting
    best: dict[str, Any] | None  # the recommended candidate (module docstring), None if nothing passes
    best_reachable: dict[str, Any] | None  # most matches, then smallest worst_ratio, whatever the verdict
    extra: dict[str, Any] = field(default_factory=dict)  # space, defaults, tie band, repeats, wall time, solution

    @property
    def chosen(self) -> dict[str, Any] | None:
        """The recommendation, or when nothing passes the best reachable candidate."""
        return self.best if self.best is not None else self.best_reachable

    def cheaper(self) -> pd.DataFrame:
        """The failing candidates no more expensive than the chosen one (steps within the tie band), cheapest first."""
        c = self.chosen
        if c is None:
            return self.table.iloc[0:0]
        t = self.table
        key = cost_key(t[t["verdict"] != "refused"])
        limit = c[key] * (1.0 + self.extra.get("tie_band", TIE_BAND))
        return t[(t[key] <= limit) & ~passing(t["verdict"]) & (t["settings"] != c["settings"])]


def passing(verdicts: pd.Series) -> pd.Series:
    """Whether each candidate's verdict agrees with the reference (``match``, or ``none`` when nothing sticks)."""
    return verdicts.map(agrees).astype(bool)


def overrides_of(params: dict[str, Any]) -> list[str]:
    """``engine.field=value`` items for ``registry.make_settings`` from a candidate's dotted settings."""
    return [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in params.items() if "." in k]


def settings_label(params: dict[str, Any]) -> str:
    """A candidate as one string, ``dt=...`` first: the ``settings`` column."""
    return ", ".join(f"{k}={v}" for k, v in params.items())


def short_label(row: dict[str, Any], defaults: dict[str, Any]) -> str:
    """A candidate as dt and the settings it changes from the engine's defaults, without the engine prefix."""
    changed = [f"{k.split('.', 1)[-1]}={row[k]}" for k, v in defaults.items() if k in row and row[k] != v]
    return ", ".join([f"dt={row['dt']:g}", *changed])


def _evaluate(ref: ReferenceSolution, engine: str, params: dict, tol: Tolerances) -> dict[str, Any]:
    """Run one candidate and judge it (runs in a worker process)."""
    settings = make_settings(engine, params["dt"], overrides_of(params))
    run, table, impacts = judge_run(ref, engine, settings, tol)
    ratios = check_ratios(table, impacts, tol, tol.penetration * ref.length_scale)
    return {**params, "settings": settings_label(params), **metrics(table), **ratios,
            "failed": describe_failures(table, ratios, tol), "steps_per_sim_s": steps_per_sim_s(engine, settings, run),
            "cost_per_sim_s": run.cost_per_sim_s, "cost_repeats": 1, "status": run.status, "message": run.trajectory.message}


def steps_per_sim_s(engine: str, settings: Any, run) -> float:
    """Engine steps per simulated second: the steps the engine says it took (``settings["steps_taken"]`` of
    its trajectory), else 1 / dt for a fixed-step engine (``cost_lever`` "dt"); NaN when unknown (an
    error-controlled integrator that does not report its steps: then wall time ranks)."""
    traj = run.trajectory
    sim = float(traj.t[-1] - traj.t[0]) if len(traj.t) > 1 else 0.0
    taken = traj.settings.get("steps_taken")
    if taken is not None and sim > 0:
        return float(taken) / sim
    return 1.0 / settings.dt if adapter(engine).cost_lever(settings) == "dt" else math.nan


def _refused(params: dict, exc: Exception) -> dict[str, Any]:
    """The row of a candidate whose settings the scene cannot run (e.g. past the stability limit)."""
    return {**params, "settings": settings_label(params), "verdict": "refused", "n_episodes": 0, "n_match": 0,
            "failed": f"refused: {exc}", **{c: math.nan for c in [*RATIO_COLUMNS, *METRIC_COLUMNS]},
            "worst_ratio": math.inf, "cost_per_sim_s": math.nan, "cost_repeats": 0, "status": "refused", "message": str(exc)}


def _evaluator(executor: Executor, ref: ReferenceSolution, engine: str, tol: Tolerances):
    """A function running a batch of candidates in parallel, one row each, in order."""
    def run_batch(batch: list[dict], stage: str) -> list[dict]:
        futures = [executor.submit(_evaluate, ref, engine, p, tol) for p in batch]
        rows = []
        for fut, params in zip(futures, batch):
            try:
                row = fut.result()
            except InputError as exc:
                row = _refused(params, exc)
            rows.append({**row, "stage": stage})
        return rows
    return run_batch


def _time(scene: Scene, engine: str, candidates: list[dict], repeats: int) -> list[list[float]]:
    """Wall-clock stepping seconds per simulated second of ``repeats`` more runs of each candidate, interleaved
    (A B A B ...: a change in the machine's load falls on all of them alike), one after another in this process."""
    settings = [make_settings(engine, p["dt"], overrides_of(p)) for p in candidates]
    out: list[list[float]] = [[] for _ in candidates]
    for _ in range(repeats):
        for times, s in zip(out, settings):
            traj = run_engine(engine, scene, s)
            sim = float(traj.t[-1] - traj.t[0]) if len(traj.t) > 1 else 0.0
            if traj.status == "ok" and sim > 0:
                times.append(traj.wall_time / sim)
    return out


def cost_key(frame: pd.DataFrame) -> str:
    """The column that ranks cost in ``frame``: steps when every candidate has them, else wall time."""
    return "steps_per_sim_s" if frame["steps_per_sim_s"].notna().all() else "cost_per_sim_s"


def _tied(frame: pd.DataFrame, column: str, band: float) -> pd.DataFrame:
    low = frame[column].min()
    return frame[frame[column] <= low * (1.0 + band)] if pd.notna(low) else frame


def choose(table: pd.DataFrame, band: float = TIE_BAND) -> dict[str, Any] | None:
    """The recommendation among ``table``'s passing candidates (module docstring); None if none passes."""
    ok = table[passing(table["verdict"])]
    if ok.empty:
        return None
    tied = _tied(ok, cost_key(ok), band)
    return tied.sort_values(["n_non_default", "dt", "cost_per_sim_s"], ascending=[True, False, True]).iloc[0].to_dict()


def reachable(table: pd.DataFrame) -> dict[str, Any] | None:
    """The best reachable candidate: most matching episodes, then the smallest worst ratio, then the fewest steps."""
    ran = table[table["verdict"] != "refused"]
    if ran.empty:
        return None
    return ran.sort_values(["n_match", "worst_ratio", "steps_per_sim_s"], ascending=[False, True, True]).iloc[0].to_dict()


def engine_space(engine: str, scene: Scene, space: dict[str, Sequence] | None = None) -> dict[str, tuple]:
    """The search space: ``space`` or what the engine declares (``EngineAdapter.tuning_space``), checked."""
    space = space if space is not None else adapter(engine).tuning_space(scene)
    if space is None:
        raise TuneError(f"engine {engine!r}: declares no tuning space (its adapter's tuning_space), so tune cannot search it; "
                        "tune(..., space={...}) names one")
    space = {k: tuple(v) for k, v in space.items()}
    if "dt" not in space or not all(len(v) for v in space.values()):
        raise TuneError("tune search space: needs a non-empty 'dt' list and non-empty lists for every setting")
    for key in space:
        if key != "dt" and not key.startswith(f"{engine}."):
            raise TuneError(f"tune search space: {key!r} is not a setting of {engine} (expected {engine}.FIELD)")
    for key, values in space.items():  # validate every value before running anything
        for v in values:
            make_settings(engine, v if key == "dt" else space["dt"][0], overrides_of({key: v}) if key != "dt" else [])
    return space


def tune(
    scene: Scene,
    engine: str,
    tolerance: Tolerances | float,
    space: dict[str, Sequence] | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
    refine_steps: int = 2,
    repeats: int = 1,
    tie_band: float = TIE_BAND,
) -> TuneResult:
    """The cheapest settings of ``engine`` whose every episode passes within ``tolerance`` (module docstring).

    Parameters
    ----------
    tolerance : Tolerances or float
        The verdict tolerances; a number sets the sticking, exit and first-impact
        tolerances at once (fractions of each episode's chatter or sliding duration).
    space : dict, optional
        ``"dt"`` -> timesteps [s] and ``"engine.field"`` -> values, defaults first (default: the
        engine's ``tuning_space(scene)``).
    refine_steps : int
        Geometric bisections of dt between the cheapest pass and the failure above it.
    repeats : int
        Timed runs, the minimum taken, of the candidates the choice is between (>= 1).
    tie_band : float
        Relative cost difference under which candidates are tied [-].
    """
    check_engine(engine)
    tol = tolerance if isinstance(tolerance, Tolerances) else Tolerances(stick=tolerance, exit=tolerance, first_impact=tolerance)
    if not (isinstance(repeats, int) and repeats >= 1):
        raise TuneError(f"tune repeats = {repeats!r}: must be an integer >= 1")
    space = engine_space(engine, scene, space)
    started = time.perf_counter()
    ref = solve(scene)
    own = executor is None
    executor = executor or ProcessPoolExecutor(max_workers=workers)
    try:
        rows = search(_evaluator(executor, ref, engine, tol), space, refine_steps, tie_band,
                      lambda found: _current(found, space, tie_band))
    finally:
        if own:
            executor.shutdown()
    table = _frame(rows, space)
    best = choose(table, tie_band)
    if best is not None and repeats > 1:  # time the candidates the choice is between again, and choose again
        ok = table[passing(table["verdict"])]
        tied = _tied(ok, cost_key(ok), tie_band).index
        more = _time(scene, engine, [{k: table.at[i, k] for k in space} for i in tied], repeats - 1)
        for i, times in zip(tied, more):
            times = [table.at[i, "cost_per_sim_s"], *times]
            table.at[i, "cost_per_sim_s"] = min(times)
            table.at[i, "cost_repeats"] = len(times)
        best = choose(table, tie_band)
    return TuneResult(scene=scene, engine=engine, tolerance=tol, table=table, best=best, best_reachable=reachable(table),
                      extra={"space": space, "defaults": {k: v[0] for k, v in space.items() if k != "dt"},
                             "tie_band": tie_band, "repeats": repeats, "wall_time_s": time.perf_counter() - started,
                             "solution": ref})


def _current(rows: list[dict], space: dict[str, tuple], band: float) -> dict[str, Any] | None:
    """The search's current choice: the recommendation if any, else the best reachable (``tune_search``)."""
    frame = _frame(rows, space)
    return choose(frame, band) or reachable(frame)


def _frame(rows: list[dict], space: dict[str, tuple]) -> pd.DataFrame:
    """The candidates as a table, cheapest (fewest steps) first."""
    table = pd.DataFrame(rows)
    table["dt"] = table["dt"].astype(float)
    if "steps_per_sim_s" not in table:  # every candidate refused
        table["steps_per_sim_s"] = math.nan
    table["steps_per_sim_s"] = table["steps_per_sim_s"].astype(float).fillna(1.0 / table["dt"].where(
        table["verdict"] == "refused"))
    defaults = {k: v[0] for k, v in space.items() if k != "dt"}
    table["n_non_default"] = (table[list(defaults)] != pd.Series(defaults)).sum(axis=1) if defaults else 0
    cols = TUNE_COLUMNS + list(defaults)
    return (table[[c for c in cols if c in table.columns]]
            .sort_values(["steps_per_sim_s", "n_non_default", "cost_per_sim_s"], na_position="last")
            .reset_index(drop=True))
