"""The tune itself: for a scene, an engine and tolerances, the search run, its rows judged, the answer chosen.

    >>> from chatterbench.comparisons.studies.tune.runner import Limits
    >>> Limits(max_runs=40, phases=[0.5]).phases       # checked on construction, the phases as floats
    (0.5,)

The search (``tune/search.py``): a coarse joint grid over dt and every knob of the space
(``tune.space``), refined where verdicts change and around the best candidates, each pass's
neighbourhood run (dt x 0.8 and x 1.25, the main knob's adjacent values, half-way to the
adjacent values of every other real-valued knob), within ``max_runs`` runs. Every candidate is
judged by the one judge (``tune.rows``): ``failed`` names the checks that failed with their
measures. The settings are also struck under the scene's own forces at the impacts the judge
resolves (``tune.checks.scene_strikes``): a robust candidate whose strikes miss R where the
judge holds a time-stepper to it (``scene_restitution_ratio`` > 1) is recommended only when no
robust one meets R there (``tune.choice``).
The budget (``max_runs``, default ``MAX_RUNS``) counts runs of up to ``UNIT_STEPS`` steps, a
longer run as several (``tune.runs.run_weight``), so that a scene of long runs searches fewer of them in about the time
a short scene searches many. When the whole lattice fits the budget it is all run
(``searched["exhaustive"]``); else the adaptive search says how much of it ran and what it
skipped. ``max_cost`` caps the steps per simulated second of every candidate run or answered.

The frontier. Each run is also judged at every point of a ladder of tolerances
(``tune.ladder``: timing levels x restitution levels, the asked tolerances among them), and
the neighbourhood of every pass that could be the answer somewhere is run, so that each
point has its own cheapest robust setting (``tune.frontier``); ``frontier`` lists the points
no other beats (as tight on both axes and as cheap), cheapest first, each with its tolerances,
dt, settings, cost and margin. A search with ``ladder=None`` judges the asked tolerances alone.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import Executor
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Sequence

import pandas as pd

from chatterbench.engines.registry import check_engine
from chatterbench.reference.scene import Scene

from ..limits import MAX_RUNS, ROBUST_FRACTION  # the budget's default, shown by `tune --help` without loading this module
from ...pipeline.solution import ReferenceSolution, solve
from ...pipeline.tolerances import Tolerances
from ..phases import PHASES
from ..pools import RENEW_TASKS, process_pool
from ..transfer import attach_transfer
from .choice import TIE_BAND, choose, cost_key, fragile, passing, reachable, tied
from .frontier import answers, frontier_entries, json_value, tightest, tightest_point
from .grid import DEPTH, Grid, band_rule
from .ladder import Ladder
from .result import TuneResult
from .rows import evaluator, table_of
from .runs import batches_on_device, run_weight, time_runs
from .search import search
from .space import TuneError, engine_space, search_space


@dataclass(frozen=True)
class Limits:
    """How far a tune searches and how it chooses: ``tune``'s arguments of these names, checked on construction."""

    refine_steps: int = DEPTH  # refinement levels of the lattice (``tune.search``); 0: the coarse grid only
    repeats: int = 1  # timed runs, the minimum taken, of the candidates the choice is between (>= 1)
    tie_band: float = TIE_BAND  # [-] relative cost difference under which candidates are tied
    # the budget: runs of up to UNIT_STEPS engine steps, a longer run counting as its steps / UNIT_STEPS (a pass's
    # neighbourhood, once begun, is completed)
    max_runs: int = MAX_RUNS
    check_robust: bool = True  # run each pass's neighbourhood (False: every pass counts, ``robust`` stays None)
    max_cost: float = math.inf  # [1/s] no candidate of more steps per simulated second is run or answered (> 0; inf: no cap)
    # the impact phases of the band (fractions of a step, ``studies.phases``): a robust candidate passes at every dt of
    # its band at each (``tune.search``); empty: the three-point rule (dt x 0.8 and x 1.25, the knobs)
    phases: tuple[float, ...] = PHASES
    robust_fraction: float = ROBUST_FRACTION  # the share of a neighbourhood (band and knobs) that must pass, in (0, 1]

    def __post_init__(self) -> None:
        for name, lo in (("repeats", 1), ("refine_steps", 0), ("max_runs", 1)):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= lo):
                raise TuneError(f"tune {name} = {value!r}: must be an integer >= {lo}")
        if not self.max_cost > 0:
            raise TuneError(f"tune max_cost = {self.max_cost!r}: must be > 0 steps per simulated second (inf: no cap)")
        if not (isinstance(self.robust_fraction, (int, float)) and 0 < self.robust_fraction <= 1):
            raise TuneError(f"tune robust_fraction = {self.robust_fraction!r}: must be in (0, 1]")
        phases = tuple(float(p) for p in self.phases)
        if any(not 0 <= p < 1 for p in phases):
            raise TuneError(f"tune phases = {phases!r}: each must be in [0, 1) (a fraction of a step)")
        object.__setattr__(self, "phases", phases)


def tune(
    scene: Scene,
    engine: str,
    tolerance: Tolerances | float,
    space: dict[str, Sequence] | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
    refine_steps: int = DEPTH,
    repeats: int = 1,
    tie_band: float = TIE_BAND,
    max_runs: int = MAX_RUNS,
    check_robust: bool = True,
    ladder: Ladder | None = Ladder(),
    max_cost: float = math.inf,
    solution: ReferenceSolution | None = None,
    batched: bool | None = None,
    phases: tuple[float, ...] = PHASES,
    robust_fraction: float = ROBUST_FRACTION,
    transfer: bool = True,
    per_point: bool = False,
) -> TuneResult:
    """The cheapest robust settings of ``engine`` whose every episode passes within ``tolerance``, and the robust
    frontier over a ladder of tolerances (module docstring; ``tune.choice``: which candidate is the answer).

    Parameters
    ----------
    tolerance : Tolerances or float
        The verdict tolerances; a number sets the sticking, exit and first-impact
        tolerances at once (fractions of each episode's chatter or sliding duration).
    space : dict, optional
        ``"dt"`` -> coarse timesteps [s] and ``"engine.field"`` -> values, defaults first (default:
        ``search_space``: dt from the scene's scales, the knobs the engine declares).
    refine_steps, repeats, tie_band, max_runs, check_robust, max_cost, phases, robust_fraction
        How far the search goes and how the answer is chosen: ``Limits``, each field's comment.
    ladder : Ladder or None
        The tolerance levels of the frontier (``tune.ladder``); None: the asked tolerances alone.
    solution : ReferenceSolution, optional
        ``solve(scene)`` when the caller already has it (the CLI solves once for every engine's space).
    batched : bool, optional
        Each search pass's candidates run here as one batch of the engine, only their judging in the workers;
        None: where the engine runs thousands at once (``batches_on_device``: MuJoCo Warp on cuda). The rows
        are the same either way (a batch's run is the run alone).
    transfer : bool
        Recheck the answer and every frontier point on the scene's family (``studies.transfer``: other energies
        and masses, 10 s): ``extra["transfer"]``, each frontier entry's ``transfer``.
    per_point : bool
        Judge the ladder one point at a time (``tune.ladder.reference_levels``) instead of from one prepared run
        (``judge_levels``): the same values, slower; ``bench atlas``'s baseline.
    """
    check_engine(engine)
    tol = tolerance if isinstance(tolerance, Tolerances) else Tolerances(stick=tolerance, exit=tolerance, first_impact=tolerance)
    limits = Limits(refine_steps=refine_steps, repeats=repeats, tie_band=tie_band, max_runs=max_runs, check_robust=check_robust,
                    max_cost=max_cost, phases=phases, robust_fraction=robust_fraction)
    started = time.perf_counter()
    ref = solution if solution is not None else solve(scene)
    space = engine_space(engine, scene, space) if space is not None else search_space(engine, scene, tol, ref, refine_steps)
    grid = _grid(space, limits)
    points = ladder.points(tol) if ladder is not None else (tol,)
    asked = points.index(tol)
    with nullcontext(executor) if executor is not None else process_pool(workers, renew=RENEW_TASKS) as executor:
        batched = batches_on_device(engine) if batched is None else batched
        run_batch = evaluator(executor, ref, engine, points, asked, batched, per_point)
        done = search(run_batch, grid, max_runs, tie_band,
                      check_robust, weight=lambda p: run_weight(scene, p["dt"]),
                      levels=[(p.stick, p.restitution) for p in points], asked=asked, max_cost=max_cost,
                      phases=limits.phases, fraction=robust_fraction)
        result = _result(scene, engine, tol, ref, done, space, grid, points, ladder, batched, started, limits)
        result.extra["searched"]["shared_runs"] = run_batch.shared
        if transfer and check_robust:
            attach_transfer(result, executor)
        return result


def _grid(space: dict[str, tuple], limits: Limits) -> Grid:
    """The lattice of ``space`` refined ``limits.refine_steps`` times, with a dt within ``limits.max_cost``."""
    grid = Grid.make(space, limits.refine_steps)
    if not any(1.0 / dt <= limits.max_cost for dt in grid.dt):
        raise TuneError(f"tune max_cost = {limits.max_cost:g}: every dt searched costs more (the coarsest, "
                        f"{max(grid.dt):.3g} s, is {1 / max(grid.dt):.3g} steps per simulated second)")
    return grid


def _result(scene: Scene, engine: str, tol: Tolerances, ref: ReferenceSolution, done, space: dict, grid: Grid,
            points: tuple, ladder: Ladder | None, batched: bool, started: float, limits: Limits) -> TuneResult:
    """The ``TuneResult`` of a finished search ``done`` (``tune``'s arguments)."""
    table = table_of(done.rows, space)
    best = choose(table, limits.tie_band, limits.max_cost, limits.check_robust)
    if best is not None and limits.repeats > 1:  # time the candidates the choice is between again, and choose again
        _retime(table, scene, engine, space, limits)
        best = choose(table, limits.tie_band, limits.max_cost, limits.check_robust)
    wall = time.perf_counter() - started
    found = answers(table, points, limits.max_cost) if limits.check_robust else {}
    return TuneResult(scene=scene, engine=engine, tolerance=tol, table=table, best=best,
                      best_reachable=None if best is not None else reachable(table, limits.max_cost),
                      fragile=fragile(table, best), frontier=frontier_entries(found, points, [k for k in space if k != "dt"]),
                      written=None if best is not None else tightest_point(found, points, tol),
                      extra={"space": space, "grid": grid, "searched": _searched(table, scene, grid, done, batched, limits),
                             "points": points, "asked": points.index(tol), "answers": found,
                             "tightest": tightest(found, points), "ladder": ladder,
                             "defaults": {k: v[0] for k, v in space.items() if k != "dt"},
                             "tie_band": limits.tie_band, "repeats": limits.repeats, "wall_time_s": wall, "solution": ref})


def _searched(table: pd.DataFrame, scene: Scene, grid: Grid, done, batched: bool, limits: Limits) -> dict:
    """How far the search ``done`` looked (``recommended.json``'s ``searched``): the space, the runs, the budget, the
    lattice run and skipped, the band rule."""
    band = table["phase"].notna() if "phase" in table else pd.Series(False, index=table.index)
    work = float(sum(run_weight(scene, dt) for dt in table.loc[~band, "dt"]))  # the band's runs are checks, not search
    within = [dt for dt in grid.dt if 1.0 / dt <= limits.max_cost] or list(grid.dt)
    return {**grid.describe(), "dt": [min(within), max(within)], "runs": len(table), "band_runs": int(band.sum()),
            "max_runs": limits.max_runs, "budget_used": round(work, 1),
            "budget_spent": work >= limits.max_runs - 1, "exhaustive": done.exhaustive, "lattice": done.lattice,
            "lattice_run": done.lattice_run, "skipped_costlier": done.costlier, "max_cost": json_value(limits.max_cost),
            "capped": done.capped, "unchecked_passes": done.unchecked,
            "skipped_stalled": done.stalled, "stalled_dt": done.stalled_dt,
            "levels": sorted({int(v) for v in table["level"].dropna()}), "robustness_checked": limits.check_robust,
            "batched": batched, "band": band_rule(limits.phases, limits.robust_fraction) if limits.check_robust else None}


def _retime(table: pd.DataFrame, scene: Scene, engine: str, space: dict[str, tuple], limits: Limits) -> None:
    """Time the passing candidates tied with the cheapest ``limits.repeats`` - 1 more times (``time_runs``); each keeps
    its least wall time (``cost_per_sim_s``) and how many runs it took (``cost_repeats``), in ``table``."""
    ok = table[passing(table["verdict"]) & (table["steps_per_sim_s"] <= limits.max_cost)]
    ok = ok[ok["robust"] != False]  # noqa: E712
    even = tied(ok, cost_key(ok), limits.tie_band).index
    more = time_runs(scene, engine, [{k: table.at[i, k] for k in space} for i in even], limits.repeats - 1)
    for i, times in zip(even, more):
        times = [table.at[i, "cost_per_sim_s"], *times]
        table.at[i, "cost_per_sim_s"] = min(times)
        table.at[i, "cost_repeats"] = len(times)
