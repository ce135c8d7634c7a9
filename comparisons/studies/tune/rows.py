"""A tune candidate's row (run, judged at the asked tolerances and the ladder, or refused) and the rows as one table.

    >>> from chatterbench.comparisons.studies.tune.rows import table_of
    >>> rows = [{"dt": 1e-3, "verdict": "match", "steps_per_sim_s": 1000.0, "cost_per_sim_s": 0.1, "robust": True,
    ...          "e.w": 2.0}, {"dt": 2e-3, "verdict": "refused", "robust": None, "e.w": 1.0}]
    >>> table_of(rows, {"dt": (2e-3,), "e.w": (1.0, 2.0)})[["dt", "steps_per_sim_s", "n_non_default"]].values.tolist()
    [[0.002, 500.0, 0.0], [0.001, 1000.0, 1.0]]

Every candidate is judged by the one judge (``pipeline.compare.judge_run``) against one reference
solution, condensed to the summary row (``pipeline.summary.metrics``) plus each check's error over
its tolerance (``tune.checks``): ``failed`` names the checks that failed with their measures, and
the ladder points it passes at (``tune.ladder``) beside them. Settings the scene cannot run (past
the stability limit, say) give a row of verdict ``refused``. The rows run in worker processes
(``evaluator``), in order.
"""

from __future__ import annotations

import math
from concurrent.futures import Executor
from typing import Any

import pandas as pd

from chatterbench.engines.registry import adapter
from chatterbench.reference.errors import InputError

from ...pipeline.compare import judge_run
from ...pipeline.solution import ReferenceSolution
from ...pipeline.summary import METRIC_COLUMNS, metrics
from ...pipeline.tolerances import Tolerances
from .. import waits
from ..phases import phase_solution
from .checks import RATIO_COLUMNS, STRIKE_COLUMNS, check_ratios, describe_failures, misses_of, strike_summary
from .ladder import judge_levels, reference_levels
from .runs import (batch_runs, batches_in_workers, candidate_settings, run_and_strike, run_key, settings_label,
                   steps_per_sim_s)
from .passes import need
from .search import SEARCH_COLUMNS

PART_RUNS = 8  # candidates a worker runs as one batch of the engine at most (``evaluator``: MuJoCo Warp's worlds)
PART_DT_RATIO = 1.6  # [-] the largest dt over the smallest in a part (a band's dts span 1.25 / 0.8 = 1.5625)
PART_SAMPLES = 2_000_000  # samples of a part's runs at most (about 100 MB recorded; a longer run goes alone)
TUNE_COLUMNS = ["stage", "dt", "phase", "settings", "verdict", "n_episodes", "n_match", "failed", *SEARCH_COLUMNS, "passes",
                "robust_at", "margins", "limits", "rests", "unjudged", *RATIO_COLUMNS,
                *STRIKE_COLUMNS,
                *METRIC_COLUMNS, "steps_per_sim_s", "cost_per_sim_s", "cost_repeats", "n_non_default", "status", "message"]


def evaluate(ref: ReferenceSolution, engine: str, params: dict, points: tuple[Tolerances, ...], asked: int,
             bounds: list[float] | None = None, ran: tuple | None = None, per_point: bool = False) -> dict[str, Any]:
    """Run one candidate, judge it at the asked tolerances ``points[asked]`` and at every ladder point where it can
    still matter (``tune.passes.need`` of the search's ``bounds``; all of them for an engine whose steps are not
    1 / dt); in a worker process. ``ran``: its (trajectory, strikes) already made (``batch_runs``); ``per_point``: the
    ladder judged one point at a time (``tune.ladder.reference_levels``, the same values: ``bench atlas``'s baseline)."""
    tol = points[asked]
    settings = candidate_settings(engine, params)
    band = "phase" in params  # a band run (``tune.grid.Grid.neighbourhood``): the scene started phase x dt later
    ref = phase_solution(ref, params["dt"], params["phase"]) if band else ref
    trajectory, strikes = ran if ran is not None else run_and_strike(ref, engine, settings, tol, not band)
    run, table, impacts = judge_run(ref, engine, settings, tol, trajectory=trajectory)
    misses = misses_of(strikes, tol)  # once, for the check and the row's words
    ratios = check_ratios(table, impacts, tol, tol.penetration * ref.length_scale, misses)
    steps = steps_per_sim_s(engine, settings, run)
    judged = judged_points(engine, settings, steps, bounds, asked, len(points))
    levels = (reference_levels if per_point else judge_levels)(ref, engine, settings, run.trajectory, points,
                                                               known={asked: (run, table, impacts)}, only=judged)
    return {**params, "settings": settings_label(params), **metrics(table), **ratios, **strike_summary(misses), **levels,
            "failed": describe_failures(table, ratios, tol), "steps_per_sim_s": steps,
            "cost_per_sim_s": run.cost_per_sim_s, "cost_repeats": 1, "status": run.status, "message": run.trajectory.message}


def evaluate_part(ref: ReferenceSolution, engine: str, part: list[dict], points: tuple[Tolerances, ...], asked: int,
                  bounds: list[float] | None = None, per_point: bool = False) -> list[dict[str, Any]]:
    """The rows of ``part``'s candidates, their runs made as one batch of the engine (``batch_runs``: each the run
    alone) and each judged (``evaluate``); a refused candidate's row is ``refused``'s. In a worker process."""
    rows, made = [], batch_runs(ref, engine, part, points[asked])
    for k, params in enumerate(part):
        ran, made[k] = made[k], None  # each run let go once judged: a part holds its runs, not their judgements too
        try:
            if isinstance(ran, InputError):
                raise ran
            rows.append(evaluate(ref, engine, params, points, asked, bounds, ran, per_point))
        except InputError as exc:
            rows.append(refused(params, exc))
    return rows


def parts_of(dts: list[float], duration: float) -> list[list[int]]:
    """Candidates of timesteps ``dts`` [s] of a scene of ``duration`` [s] cut into parts for the workers, as lists of
    their indices: candidates whose dts are within ``PART_DT_RATIO`` of each other (a batch steps its longest run: a
    world of a coarser dt steps on unread), at most ``PART_RUNS`` a part and ``PART_SAMPLES`` samples (a longer run
    alone: a part holds what its longest run alone would), of sizes that differ by one at most, and at least two
    parts where there are two candidates (two workers busy).

        >>> from chatterbench.comparisons.studies.tune.rows import parts_of
        >>> parts_of([1e-3], 2.0), parts_of([1e-3] * 3, 2.0), parts_of([1e-3, 1e-5, 1.2e-3, 1e-5], 2.0)
        ([[0]], [[0], [1, 2]], [[1, 3], [0, 2]])
        >>> [len(part) for part in parts_of([1e-3] * 16, 2.0)], [len(part) for part in parts_of([1e-3] * 57, 2.0)]
        ([8, 8], [7, 7, 7, 7, 7, 7, 7, 8])
        >>> [len(part) for part in parts_of([1e-4] * 8, 40.0)]      # 400,001 samples a run: 4 of them at most
        [4, 4]
    """
    order = sorted(range(len(dts)), key=lambda i: dts[i])
    groups: list[list[int]] = []
    for i in order:
        if groups and dts[i] <= PART_DT_RATIO * dts[groups[-1][0]]:
            groups[-1].append(i)
        else:
            groups.append([i])
    whole = len(groups) == 1
    out = []
    for g in groups:
        most = max(1, min(PART_RUNS, int(PART_SAMPLES // (duration / dts[g[0]] + 1))))  # the group's longest run
        count = max(min(2, len(g)) if whole else 1, math.ceil(len(g) / most))
        cuts = [k * len(g) // count for k in range(count + 1)]
        out += [g[c0:c1] for c0, c1 in zip(cuts[:-1], cuts[1:])]
    return out


def judged_points(engine: str, settings: Any, steps: float, bounds: list[float] | None, asked: int,
                  n_points: int) -> list[int]:
    """The ladder points a run of ``steps`` steps per simulated second is judged at: where it can still matter
    (``tune.passes.need`` of the search's ``bounds``), or all ``n_points`` without bounds or for an engine whose
    steps are not 1 / dt (its cost is not known before it runs)."""
    fixed = adapter(engine).cost_lever(settings) == "dt" and math.isfinite(steps)
    return need(steps, bounds, asked) if bounds is not None and fixed else list(range(n_points))


def refused(params: dict, exc: Exception) -> dict[str, Any]:
    """The row of a candidate whose settings the scene cannot run (e.g. past the stability limit)."""
    return {**params, "settings": settings_label(params), "verdict": "refused", "n_episodes": 0, "n_match": 0,
            "failed": f"refused: {exc}", **{c: math.nan for c in [*RATIO_COLUMNS, *METRIC_COLUMNS]}, "passes": (), "margins": (),
            "limits": (), "rests": (), "unjudged": (),
            "worst_ratio": math.inf, "cost_per_sim_s": math.nan, "cost_repeats": 0, "status": "refused", "message": str(exc)}


def evaluator(executor: Executor, ref: ReferenceSolution, engine: str, points: tuple[Tolerances, ...], asked: int,
              batched: bool = False, per_point: bool = False, shared: bool = True, parts: bool | None = None):
    """A function running a batch of candidates in parallel, one row each, in order; ``batched``: the candidates'
    runs and strikes made here as one batch of the engine (``batch_runs``), only their judging in parallel.
    ``parts``: the candidates cut into parts (``parts_of``), each part's runs one batch of the engine in a worker
    (``evaluate_part``); None: where the engine batches on the CPU (``runs.batches_in_workers``). The rows are the
    same every way (a batch's run is the run alone).

    ``shared``: candidates of one run (``runs.run_key``: they differ only in settings fields the run does not read,
    Drake's integrator in discrete mode) make one run, in the search so far or in the batch; the others take its row
    (``shared_row``), the same, value for value, as their own run would give. False: each makes its own (the check)."""
    made: dict[tuple, dict] = {}  # run key -> the row of the run made for it (not refused)

    in_parts = (not batched and batches_in_workers(engine)) if parts is None else parts

    def submit(batch: list[dict], bounds: list[float] | None) -> list[dict]:
        if in_parts and not batched and len(batch) > 1:
            parts = [[batch[i] for i in part] for part in parts_of([p["dt"] for p in batch], ref.scene.duration)]
            futures = [executor.submit(evaluate_part, ref, engine, part, points, asked, bounds, per_point)
                       for part in parts]
            made = {id(params): row for fut, part in zip(futures, parts) for params, row in zip(part, _rows(fut, part))}
            return [made[id(params)] for params in batch]
        ran = batch_runs(ref, engine, batch, points[asked]) if batched else [None] * len(batch)
        futures = [r if isinstance(r, InputError) else executor.submit(evaluate, ref, engine, p, points, asked, bounds, r,
                                                                             per_point)
                   for p, r in zip(batch, ran)]  # a refusal of the batch's own checks stands in for its future
        return [_row(fut, params) for fut, params in zip(futures, batch)]

    def run_batch(batch: list[dict], stage: str, bounds: list[float] | None = None) -> list[dict]:
        keys = [run_key(engine, p) if shared else None for p in batch]
        rows: list[dict | None] = [None] * len(batch)
        first: dict[tuple, int] = {}  # run key -> the candidate of the batch that runs it
        for i, (params, key) in enumerate(zip(batch, keys)):
            if key is None:
                continue
            if key in made:
                rows[i] = shared_row(made[key], params, engine, len(points), asked, bounds)
            if rows[i] is None:
                first.setdefault(key, i)
        runs = [i for i, row in enumerate(rows) if row is None and (keys[i] is None or first[keys[i]] == i)]
        for i, row in zip(runs, submit([batch[i] for i in runs], bounds)):
            rows[i] = row
            if keys[i] is not None and row["verdict"] != "refused":
                made[keys[i]] = row
        rest = [i for i, row in enumerate(rows) if row is None]  # the batch's others of a run made above
        for i in rest:
            rows[i] = shared_row(made[keys[i]], batch[i], engine, len(points), asked, bounds) if keys[i] in made else None
        again = [i for i in rest if rows[i] is None]  # of a refused run: each refused by itself, by name
        for i, row in zip(again, submit([batch[i] for i in again], bounds)):
            rows[i] = row
        run_batch.shared += len(batch) - len(runs) - len(again)
        return [{**row, "stage": stage} for row in rows]
    run_batch.shared = 0  # rows that took another candidate's run (the search's ``searched["shared_runs"]``)
    return run_batch


def shared_row(made: dict[str, Any], params: dict, engine: str, n_points: int, asked: int,
               bounds: list[float] | None) -> dict[str, Any] | None:
    """The row of a candidate whose run is ``made``'s (``runs.run_key``): ``made`` with the candidate's own settings and
    its ladder judged where the candidate can still matter (``evaluate``'s rule with today's ``bounds``: a subset of
    where ``made`` was judged, bounds only fall); None where it would be judged at a point ``made`` was not (it runs)."""
    judged = set(judged_points(engine, candidate_settings(engine, params), made["steps_per_sim_s"], bounds, asked,
                               n_points))
    if judged & set(made["unjudged"]):
        return None
    keep = [k for k, p in enumerate(made["passes"]) if p in judged]
    return {**made, **params, "settings": settings_label(params),
            **{c: tuple(made[c][k] for k in keep) for c in ("passes", "margins", "limits", "rests")},
            "unjudged": tuple(i for i in range(n_points) if i not in judged)}


def _row(fut, params: dict) -> dict[str, Any]:
    """A candidate's row from its future, or the row of its refused settings."""
    try:
        if isinstance(fut, InputError):
            return refused(params, fut)
        return waits.result(fut)  # in slices: a Ctrl-C is acted on while the workers run
    except InputError as exc:
        return refused(params, exc)


def _rows(fut, part: list[dict]) -> list[dict[str, Any]]:
    """A part's rows from its future (``evaluate_part``), or each candidate's refused row where the part was refused
    as a whole."""
    try:
        return waits.result(fut)  # in slices: a Ctrl-C is acted on while the workers run
    except InputError as exc:
        return [refused(params, exc) for params in part]


def table_of(rows: list[dict], space: dict[str, tuple]) -> pd.DataFrame:
    """The candidates as a table (``TUNE_COLUMNS`` plus one column per searched setting), cheapest (fewest steps)
    first."""
    table = pd.DataFrame(rows)
    table["dt"] = table["dt"].astype(float)
    if "steps_per_sim_s" not in table:  # every candidate refused
        table["steps_per_sim_s"] = math.nan
    table["steps_per_sim_s"] = table["steps_per_sim_s"].astype(float).fillna(1.0 / table["dt"].where(
        table["verdict"] == "refused"))
    defaults = {k: v[0] for k, v in space.items() if k != "dt"}
    table["n_non_default"] = (table[list(defaults)] != pd.Series(defaults)).sum(axis=1) if defaults else 0
    table["robust"] = table["robust"].astype(object).where(table["robust"].notna(), None)
    cols = TUNE_COLUMNS + list(defaults)
    return (table[[c for c in cols if c in table.columns]]
            .sort_values(["steps_per_sim_s", "n_non_default", "cost_per_sim_s"], na_position="last")
            .reset_index(drop=True))
