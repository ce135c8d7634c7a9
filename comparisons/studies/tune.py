"""Engine tuning: for a scene and tolerances, the cheapest robust settings that pass, how far the search looked, and every candidate.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (5e-3, 4e-3, 3.1e-3), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> three = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...              phases=(), transfer=False)     # robust at dt x 0.8 and x 1.25 alone: the old three-point rule
    >>> three.best["settings"]
    'dt=0.0031, pybullet.restitution_velocity_threshold=0.1'
    >>> band = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...             transfer=False)                 # the default: every dt of [0.8, 1.25] x dt, 4 impact phases
    >>> band.best is None, band.table.set_index("settings").loc[three.best["settings"], "neighbourhood"]
    (True, 'dt x1.06: late; dt x1.15 at phase 0.25: late; dt x1.25 at phase 0.25: late')
    >>> [(p["tolerances"]["stick"], p["tolerances"]["restitution"], p["dt"]) for p in band.frontier]  # what is robust
    [(0.1, 0.05, 0.00410763)]

``outputs/guide.py`` turns the result into the tuning guide; ``tune_answer.recommended`` into ``recommended.json``.

The space (``search_space``): dt from the scene's own scales (``dt_range``: the coarsest dt
worth trying is the tightest timing tolerance in seconds, a step that places an event no
better than the tolerance, or a quarter of the flight time across the gap at the fastest
strike, whichever is less; the finest needed is ``FINEST`` (1/1000) of that tolerance, but
never finer than the finest dt the engine declares),
and each engine's contact knobs as its adapter declares them (``EngineAdapter.tuning_space``).
The search (``tune_search.py``): a coarse joint grid over dt and every knob, refined where
verdicts change and around the best candidates, each pass's neighbourhood run (dt x 0.8 and
x 1.25, the main knob's adjacent values, half-way to the adjacent values of every other
real-valued knob), within ``max_runs`` runs. Every candidate is judged by the one judge
(``pipeline.compare.judge_run``) against one reference solution, condensed to the summary row
(``pipeline.summary.metrics``) plus each check's error over its tolerance (``tune_checks``):
``failed`` names the checks that failed with their measures. The settings are also struck
under the scene's own forces at the impacts the judge resolves (``tune_checks.scene_strikes``):
a robust candidate whose strikes miss R where the judge holds a time-stepper to it
(``scene_restitution_ratio`` > 1) is recommended only when no robust one meets R there.
The budget (``max_runs``, default ``MAX_RUNS``) counts runs of up to ``UNIT_STEPS`` steps, a
longer run as several, so that a scene of long runs searches fewer of them in about the time
a short scene searches many. When the whole lattice fits the budget it is all run
(``searched["exhaustive"]``); else the adaptive search says how much of it ran and what it
skipped. ``max_cost`` caps the steps per simulated second of every candidate run or answered.

The frontier. Each run is also judged at every point of a ladder of tolerances
(``tune_ladder``: timing levels x restitution levels, the asked tolerances among them), and
the neighbourhood of every pass that could be the answer somewhere is run, so that each
point has its own cheapest robust setting (``tune_frontier``); ``frontier`` lists the points
no other beats (as tight on both axes and as cheap), cheapest first, each with its tolerances,
dt, settings, cost and margin. A search with ``ladder=None`` judges the asked tolerances alone.

Cost and choice. The cost of a candidate is its steps per simulated second (1 / dt: every
searched setting makes one force evaluation per step, so this is the work, and it is free
of timing noise), with the wall-clock stepping time per simulated second beside it
(``cost_per_sim_s``: the minimum over ``repeats`` runs for the candidates the choice is
between, interleaved, one run for the others; ``cost_repeats`` says which): reported, never
deciding, since on a shared machine it follows the load (``TIE_BAND``'s comment). The
recommendation (``best``) is the *robust* passing candidate (verdicts ``match`` or ``none`` in
every episode, and in every episode of each neighbour) of fewest steps; those within
``tie_band`` (10%) of it in steps are tied, and the tie goes to the simplest: fewest settings
away from the engine's defaults, then the larger dt, then the smaller wall time. Beside it,
``fragile``: the cheapest pass whose neighbourhood fails, when it is cheaper than the answer
(an isolated point: a small change of the model can land on a failure). The margin is the
answer's worst error over its tolerance among the judge's checks (restitution under the
scene's forces beside it). When nothing robust passes, ``best_reachable`` is the
pass whose neighbourhood fails least (fewest failing neighbours, then the smallest worst ratio
over the neighbourhood, then the fewest steps), else the candidate with the most matching
episodes, then the smallest ``worst_ratio``, then the fewest steps.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Sequence

import pandas as pd

from chatterbench.engines.registry import adapter, check_engine
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene, SceneError

from .limits import MAX_RUNS  # the budget's default, shown by `tune --help` without loading this module
from ..pipeline.compare import judge_run
from ..pipeline.solution import ReferenceSolution, solve
from ..pipeline.summary import METRIC_COLUMNS, metrics
from ..pipeline.tolerances import Tolerances
from .tune_checks import RATIO_COLUMNS, STRIKE_COLUMNS, check_ratios, describe_failures, judged_margin, strike_summary
from .tune_frontier import answers, frontier_entries, json_value, tightest, tightest_point
from .phases import PHASES, phase_solution
from .tune_ladder import Ladder, judge_levels, margin_at, reference_levels
from .transfer import attach_transfer
from .tune_grid import FINEST, FLIGHT_STEPS, band_rule, dt_range  # noqa: F401  (tune's names: here too)
from .tune_search import DT_RATIO, ROBUST_FRACTION, SEARCH_COLUMNS, Grid, agrees, need, round_dt, search
from . import waits
from .tune_runs import (batch_runs, batches_on_device, candidate_settings, run_and_strike, settings_label, steps_per_sim_s,
                        time_runs)

TUNE_COLUMNS = ["stage", "dt", "phase", "settings", "verdict", "n_episodes", "n_match", "failed", *SEARCH_COLUMNS, "passes",
                "robust_at", "margins", "limits", "rests", "unjudged", *RATIO_COLUMNS,
                *STRIKE_COLUMNS,
                *METRIC_COLUMNS, "steps_per_sim_s", "cost_per_sim_s", "cost_repeats", "n_non_default", "status", "message"]
TIE_BAND = 0.1  # [-] steps per simulated second within 10% of each other are a tie
UNIT_STEPS = 100_000  # a run of more steps counts as steps / UNIT_STEPS runs of the budget (its work)
DEPTH = 2  # refinement levels: the finest dt lattice is DT_RATIO apart, the coarse grid DT_RATIO ** 4
# Wall time decides nothing: on this shared 2-core machine the least of 3 interleaved timings of PyBullet at
# dt = 4.05e-4 with 10 and 50 solver iterations (identical trajectories) came out 1.10x apart in one measurement
# and 2.2x in another (tune feigin-pair --engine pybullet --tolerance 0.01): a choice by it follows the load.


class TuneError(SceneError):
    """A search space tune cannot use (no dt ladder, an empty list, an engine that declares none)."""


@dataclass(frozen=True)
class TuneResult:
    """Every candidate tried (``table``, cheapest first), the recommendation, the fragile pass and the best reachable."""

    scene: Scene
    engine: str
    tolerance: Tolerances
    table: pd.DataFrame  # TUNE_COLUMNS plus one column per searched setting
    best: dict[str, Any] | None  # the cheapest robust pass (module docstring), None if none
    best_reachable: dict[str, Any] | None  # when nothing robust passes: the closest (module docstring)
    extra: dict[str, Any] = field(default_factory=dict)  # space, grid, searched, defaults, tie band, repeats, wall time
    fragile: dict[str, Any] | None = None  # the cheapest pass whose neighbourhood fails, if cheaper than ``best``
    frontier: list[dict[str, Any]] = field(default_factory=list)  # tune_frontier.frontier_entries, cheapest first
    written: int | None = None  # nothing robust at the asked tolerances: the ladder point whose answer is written

    @property
    def written_row(self) -> dict[str, Any] | None:
        """The answer of the ladder point ``written`` (None: none)."""
        return None if self.written is None else self.extra["answers"][self.written]

    @property
    def chosen(self) -> dict[str, Any] | None:
        """What is written: the recommendation; when nothing robust passes the asked tolerances, the tightest robust
        frontier point's answer (``written``: robust at its own tolerances); when nothing is robust anywhere, the
        best reachable candidate."""
        if self.best is not None:
            return self.best
        return self.written_row if self.written is not None else self.best_reachable

    @property
    def chosen_tolerance(self) -> Tolerances:
        """The tolerances the chosen candidate is judged at: the asked ones, or the written frontier point's."""
        return self.tolerance if self.written is None else self.extra["points"][self.written]

    @property
    def margin(self) -> float:
        """The chosen candidate's worst measured error over its tolerance among the judge's checks [-] (<= 1: passes,
        the smaller the more room; inf: an episode with no error to measure; NaN: none ran), at its tolerances
        (``chosen_tolerance``). Restitution under the scene's forces is ``scene_restitution_ratio`` beside it."""
        c = self.chosen
        if c is None:
            return math.nan
        return margin_at(c, self.written) if self.written is not None else judged_margin(c)

    def cheaper(self, fragile: bool = False) -> pd.DataFrame:
        """The failing candidates no more expensive than the chosen one (steps within the tie band), cheapest first;
        ``fragile``: the passes among them whose neighbourhood fails instead."""
        c = self.chosen
        if c is None:
            return self.table.iloc[0:0]
        t = self.table
        key = cost_key(t[t["verdict"] != "refused"])
        limit = c[key] * (1.0 + self.extra.get("tie_band", TIE_BAND))
        which = (passing(t["verdict"]) & (t["robust"] == False)) if fragile else ~passing(t["verdict"])  # noqa: E712
        searched = t["phase"].isna() if "phase" in t else True  # a band's run checks a candidate: it is none itself
        return t[(t[key] <= limit) & which & searched & (t["settings"] != c["settings"])].sort_values(key, kind="stable")


def passing(verdicts: pd.Series) -> pd.Series:
    """Whether each candidate's verdict agrees with the reference (``match``, or ``none`` when nothing sticks)."""
    return verdicts.map(agrees).astype(bool)


def short_label(row: dict[str, Any], defaults: dict[str, Any]) -> str:
    """A candidate as dt and the settings it changes from the engine's defaults, without the engine prefix."""
    changed = [f"{k.split('.', 1)[-1]}={row[k]}" for k, v in defaults.items() if k in row and row[k] != v]
    return ", ".join([f"dt={row['dt']:g}", *changed])


def _evaluate(ref: ReferenceSolution, engine: str, params: dict, points: tuple[Tolerances, ...], asked: int,
              bounds: list[float] | None = None, ran: tuple | None = None, per_point: bool = False) -> dict[str, Any]:
    """Run one candidate, judge it at the asked tolerances ``points[asked]`` and at every ladder point where it can
    still matter (``tune_search.need`` of the search's ``bounds``; all of them for an engine whose steps are not
    1 / dt); in a worker process. ``ran``: its (trajectory, strikes) already made (``batch_runs``); ``per_point``: the
    ladder judged one point at a time (``tune_ladder.reference_levels``, the same values: ``bench atlas``'s baseline)."""
    tol = points[asked]
    settings = candidate_settings(engine, params)
    band = "phase" in params  # a band run (``tune_search.Grid.neighbourhood``): the scene started phase x dt later
    ref = phase_solution(ref, params["dt"], params["phase"]) if band else ref
    trajectory, strikes = ran if ran is not None else run_and_strike(ref, engine, settings, tol, not band)
    run, table, impacts = judge_run(ref, engine, settings, tol, trajectory=trajectory)
    ratios = check_ratios(table, impacts, tol, tol.penetration * ref.length_scale, strikes)
    steps = steps_per_sim_s(engine, settings, run)
    fixed = adapter(engine).cost_lever(settings) == "dt" and math.isfinite(steps)
    judged = need(steps, bounds, asked) if bounds is not None and fixed else range(len(points))
    levels = (reference_levels if per_point else judge_levels)(ref, engine, settings, run.trajectory, points,
                                                               known={asked: (run, table, impacts)}, only=judged)
    return {**params, "settings": settings_label(params), **metrics(table), **ratios, **strike_summary(strikes, tol), **levels,
            "failed": describe_failures(table, ratios, tol), "steps_per_sim_s": steps,
            "cost_per_sim_s": run.cost_per_sim_s, "cost_repeats": 1, "status": run.status, "message": run.trajectory.message}


def _refused(params: dict, exc: Exception) -> dict[str, Any]:
    """The row of a candidate whose settings the scene cannot run (e.g. past the stability limit)."""
    return {**params, "settings": settings_label(params), "verdict": "refused", "n_episodes": 0, "n_match": 0,
            "failed": f"refused: {exc}", **{c: math.nan for c in [*RATIO_COLUMNS, *METRIC_COLUMNS]}, "passes": (), "margins": (),
            "limits": (), "rests": (), "unjudged": (),
            "worst_ratio": math.inf, "cost_per_sim_s": math.nan, "cost_repeats": 0, "status": "refused", "message": str(exc)}


def _evaluator(executor: Executor, ref: ReferenceSolution, engine: str, points: tuple[Tolerances, ...], asked: int,
               batched: bool = False, per_point: bool = False):
    """A function running a batch of candidates in parallel, one row each, in order; ``batched``: the candidates'
    runs and strikes made here as one batch of the engine (``batch_runs``), only their judging in parallel."""
    def run_batch(batch: list[dict], stage: str, bounds: list[float] | None = None) -> list[dict]:
        ran = batch_runs(ref, engine, batch, points[asked]) if batched else [None] * len(batch)
        futures = [r if isinstance(r, InputError) else executor.submit(_evaluate, ref, engine, p, points, asked, bounds, r,
                                                                             per_point)
                   for p, r in zip(batch, ran)]  # a refusal of the batch's own checks stands in for its future
        return [{**_row(fut, params), "stage": stage} for fut, params in zip(futures, batch)]
    return run_batch


def _row(fut, params: dict) -> dict[str, Any]:
    """A candidate's row from its future, or the row of its refused settings."""
    try:
        if isinstance(fut, InputError):
            return _refused(params, fut)
        return waits.result(fut)  # in slices: a Ctrl-C is acted on while the workers run
    except InputError as exc:
        return _refused(params, exc)


def cost_key(frame: pd.DataFrame) -> str:
    """The column that ranks cost in ``frame``: steps when every candidate has them, else wall time."""
    return "steps_per_sim_s" if frame["steps_per_sim_s"].notna().all() else "cost_per_sim_s"


def _tied(frame: pd.DataFrame, column: str, band: float) -> pd.DataFrame:
    low = frame[column].min()
    return frame[frame[column] <= low * (1.0 + band)] if pd.notna(low) else frame


def choose(table: pd.DataFrame, band: float = TIE_BAND, max_cost: float = math.inf,
           checked: bool = True) -> dict[str, Any] | None:
    """The recommendation among ``table``'s robust passing candidates of at most ``max_cost`` steps per simulated
    second (module docstring); None if none.

    ``checked`` False (no neighbourhood was run), or a table without ``robust``: every pass counts. Otherwise a pass
    whose neighbourhood the budget left unrun is no answer.
    """
    ok = table[passing(table["verdict"]) & ~(table["steps_per_sim_s"] > max_cost)]
    if "robust" in ok and checked:
        ok = ok[ok["robust"] == True]  # noqa: E712 (an object column: True, False or None)
    if ok.empty:
        return None
    meets_r = ok[~(ok["scene_restitution_ratio"] > 1.0)] if "scene_restitution_ratio" in ok else ok
    ok = meets_r if len(meets_r) else ok  # R missed under the scene's forces counts against a candidate
    tied = _tied(ok, cost_key(ok), band)
    return tied.sort_values(["n_non_default", "dt", "cost_per_sim_s"], ascending=[True, False, True]).iloc[0].to_dict()


def fragile(table: pd.DataFrame, best: dict[str, Any] | None) -> dict[str, Any] | None:
    """The cheapest pass whose neighbourhood fails, when it is cheaper than ``best`` (or there is no ``best``)."""
    if "robust" not in table:
        return None
    weak = table[passing(table["verdict"]) & (table["robust"] == False)]  # noqa: E712
    if best is not None:
        weak = weak[weak["steps_per_sim_s"] < best["steps_per_sim_s"]]
    return None if weak.empty else weak.sort_values("steps_per_sim_s").iloc[0].to_dict()


def reachable(table: pd.DataFrame, max_cost: float = math.inf) -> dict[str, Any] | None:
    """The best reachable candidate (module docstring): a fragile pass failing least, else most matching episodes,
    then the smallest worst ratio, then the fewest steps.

    Among the searched candidates of at most ``max_cost`` steps per simulated second: a run made only as another's
    neighbour (dt x 0.8 or x 1.25, off the searched lattice; stage ``neighbourhood``) checks that one and is no
    answer, unless nothing else ran.
    """
    ran = table[table["verdict"] != "refused"]
    if "stage" in ran:
        searched = ran[(ran["stage"] != "neighbourhood") & ~(ran["steps_per_sim_s"] > max_cost)]
        ran = searched if len(searched) else ran
    if ran.empty:
        return None
    if "robust" in ran:
        weak = ran[passing(ran["verdict"]) & (ran["robust"] == False)]  # noqa: E712
        if len(weak):
            n_fail = weak["neighbourhood"].str.count(";") + 1
            return (weak.assign(_n=n_fail).sort_values(["_n", "neighbourhood_worst_ratio", "steps_per_sim_s"])
                    .drop(columns="_n").iloc[0].to_dict())
    return ran.sort_values(["n_match", "worst_ratio", "steps_per_sim_s"], ascending=[False, True, True]).iloc[0].to_dict()


def search_space(engine: str, scene: Scene, tol: Tolerances, solution: ReferenceSolution | None = None,
                 depth: int = DEPTH) -> dict[str, tuple]:
    """The space ``tune`` searches: coarse dt from ``dt_range`` (DT_RATIO ** 2**depth apart, coarse to fine; never
    finer than the finest dt the engine declares), the engine's declared knobs (``engine_space``), checked."""
    fine, coarse = dt_range(solution or solve(scene), tol)
    declared = engine_space(engine, scene)
    fine = min(max(fine, min(declared["dt"])), coarse)  # never finer than the engine's own finest declared dt
    ratio = DT_RATIO ** (2 ** depth)
    n = math.floor(math.log(coarse / fine) / math.log(ratio) + 1e-9) + 1  # the finest row at or above ``fine``
    return {"dt": tuple(round_dt(coarse / ratio ** k) for k in range(n)), **{k: v for k, v in declared.items() if k != "dt"}}


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
            candidate_settings(engine, {"dt": space["dt"][0], key: v})
    return space


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
    frontier over a ladder of tolerances (module docstring).

    Parameters
    ----------
    tolerance : Tolerances or float
        The verdict tolerances; a number sets the sticking, exit and first-impact
        tolerances at once (fractions of each episode's chatter or sliding duration).
    space : dict, optional
        ``"dt"`` -> coarse timesteps [s] and ``"engine.field"`` -> values, defaults first (default:
        ``search_space``: dt from the scene's scales, the knobs the engine declares).
    refine_steps : int
        Refinement levels of the lattice (``tune_search``); 0: the coarse grid only.
    repeats : int
        Timed runs, the minimum taken, of the candidates the choice is between (>= 1).
    tie_band : float
        Relative cost difference under which candidates are tied [-].
    max_runs : int
        The budget: runs of up to ``UNIT_STEPS`` engine steps, a longer run counting as its steps /
        ``UNIT_STEPS`` (a pass's neighbourhood, once begun, is completed).
    check_robust : bool
        Run each pass's neighbourhood (False: every pass counts, ``robust`` stays None).
    ladder : Ladder or None
        The tolerance levels of the frontier (``tune_ladder``); None: the asked tolerances alone.
    max_cost : float
        No candidate of more steps per simulated second is run or answered [1/s] (> 0; inf: no cap).
    solution : ReferenceSolution, optional
        ``solve(scene)`` when the caller already has it (the CLI solves once for every engine's space).
    batched : bool, optional
        Each search pass's candidates run here as one batch of the engine, only their judging in the workers;
        None: where the engine runs thousands at once (``batches_on_device``: MuJoCo Warp on cuda). The rows
        are the same either way (a batch's run is the run alone).
    phases : tuple of float
        The impact phases of the band (fractions of a step, ``studies.phases``): a robust candidate passes at every
        dt of its band at each (``tune_search``); empty: the three-point rule (dt x 0.8 and x 1.25, the knobs).
    robust_fraction : float
        The share of a candidate's neighbourhood (band and knobs) that must pass for it to be robust, in (0, 1].
    transfer : bool
        Recheck the answer and every frontier point on the scene's family (``studies.transfer``: other energies
        and masses, 10 s): ``extra["transfer"]``, each frontier entry's ``transfer``.
    per_point : bool
        Judge the ladder one point at a time (``tune_ladder.reference_levels``) instead of from one prepared run
        (``judge_levels``): the same values, slower; ``bench atlas``'s baseline.
    """
    check_engine(engine)
    tol = tolerance if isinstance(tolerance, Tolerances) else Tolerances(stick=tolerance, exit=tolerance, first_impact=tolerance)
    for name, value, lo in (("repeats", repeats, 1), ("refine_steps", refine_steps, 0), ("max_runs", max_runs, 1)):
        if not (isinstance(value, int) and value >= lo):
            raise TuneError(f"tune {name} = {value!r}: must be an integer >= {lo}")
    if not max_cost > 0:
        raise TuneError(f"tune max_cost = {max_cost!r}: must be > 0 steps per simulated second (inf: no cap)")
    if not (isinstance(robust_fraction, (int, float)) and 0 < robust_fraction <= 1):
        raise TuneError(f"tune robust_fraction = {robust_fraction!r}: must be in (0, 1]")
    phases = tuple(float(p) for p in phases)
    if any(not 0 <= p < 1 for p in phases):
        raise TuneError(f"tune phases = {phases!r}: each must be in [0, 1) (a fraction of a step)")
    started = time.perf_counter()
    ref = solution if solution is not None else solve(scene)
    space = engine_space(engine, scene, space) if space is not None else search_space(engine, scene, tol, ref, refine_steps)
    grid = Grid.make(space, refine_steps)
    if not any(1.0 / dt <= max_cost for dt in grid.dt):
        raise TuneError(f"tune max_cost = {max_cost:g}: every dt searched costs more (the coarsest, {max(grid.dt):.3g} s, "
                        f"is {1 / max(grid.dt):.3g} steps per simulated second)")
    points = ladder.points(tol) if ladder is not None else (tol,)
    asked = points.index(tol)
    own = executor is None
    executor = executor or ProcessPoolExecutor(max_workers=workers)
    try:
        batched = batches_on_device(engine) if batched is None else batched
        done = search(_evaluator(executor, ref, engine, points, asked, batched, per_point), grid, max_runs, tie_band, check_robust,
                      weight=lambda p: run_weight(scene, p["dt"]), levels=[(p.stick, p.restitution) for p in points],
                      asked=asked, max_cost=max_cost, phases=phases, fraction=robust_fraction)
        result = _result(scene, engine, tol, ref, done, space, grid, points, asked, ladder, batched, started, tie_band,
                         repeats, max_cost, max_runs, check_robust, phases, robust_fraction)
        if transfer and check_robust:
            attach_transfer(result, executor)
        return result
    finally:
        if own:
            executor.shutdown()


def _result(scene: Scene, engine: str, tol: Tolerances, ref: ReferenceSolution, done, space: dict, grid: Grid,
            points: tuple, asked: int, ladder, batched: bool, started: float, tie_band: float, repeats: int,
            max_cost: float, max_runs: int, check_robust: bool, phases: tuple, robust_fraction: float) -> TuneResult:
    """The ``TuneResult`` of a finished search ``done`` (``tune``'s arguments)."""
    table = _frame(done.rows, space)
    best = choose(table, tie_band, max_cost, check_robust)
    if best is not None and repeats > 1:  # time the candidates the choice is between again, and choose again
        _retime(table, scene, engine, space, repeats, tie_band, max_cost)
        best = choose(table, tie_band, max_cost, check_robust)
    wall = time.perf_counter() - started
    band = table["phase"].notna() if "phase" in table else pd.Series(False, index=table.index)
    work = float(sum(run_weight(scene, dt) for dt in table.loc[~band, "dt"]))  # the band's runs are checks, not search
    found = answers(table, points, max_cost) if check_robust else {}
    keys = [k for k in space if k != "dt"]
    within = [dt for dt in grid.dt if 1.0 / dt <= max_cost] or list(grid.dt)
    searched = {**grid.describe(), "dt": [min(within), max(within)], "runs": len(table), "band_runs": int(band.sum()),
                "max_runs": max_runs, "budget_used": round(work, 1),
                "budget_spent": work >= max_runs - 1, "exhaustive": done.exhaustive, "lattice": done.lattice,
                "lattice_run": done.lattice_run, "skipped_costlier": done.costlier, "max_cost": json_value(max_cost),
                "capped": done.capped, "unchecked_passes": done.unchecked,
                "levels": sorted({int(v) for v in table["level"].dropna()}), "robustness_checked": check_robust,
                "batched": batched, "band": band_rule(phases, robust_fraction) if check_robust else None}
    frontier = frontier_entries(found, points, keys)
    return TuneResult(scene=scene, engine=engine, tolerance=tol, table=table, best=best,
                      best_reachable=None if best is not None else reachable(table, max_cost), fragile=fragile(table, best),
                      frontier=frontier, written=None if best is not None else tightest_point(found, points, tol),
                      extra={"space": space, "grid": grid, "searched": searched, "points": points, "asked": asked,
                             "answers": found, "tightest": tightest(found, points), "ladder": ladder,
                             "defaults": {k: v[0] for k, v in space.items() if k != "dt"},
                             "tie_band": tie_band, "repeats": repeats, "wall_time_s": wall, "solution": ref})


def _retime(table: pd.DataFrame, scene: Scene, engine: str, space: dict[str, tuple], repeats: int, tie_band: float,
            max_cost: float) -> None:
    """Time the passing candidates tied with the cheapest ``repeats`` - 1 more times (``time_runs``); each keeps its
    least wall time (``cost_per_sim_s``) and how many runs it took (``cost_repeats``), in ``table``."""
    ok = table[passing(table["verdict"]) & (table["steps_per_sim_s"] <= max_cost)]
    ok = ok[ok["robust"] != False]  # noqa: E712
    tied = _tied(ok, cost_key(ok), tie_band).index
    more = time_runs(scene, engine, [{k: table.at[i, k] for k in space} for i in tied], repeats - 1)
    for i, times in zip(tied, more):
        times = [table.at[i, "cost_per_sim_s"], *times]
        table.at[i, "cost_per_sim_s"] = min(times)
        table.at[i, "cost_repeats"] = len(times)


def run_weight(scene: Scene, dt: float) -> float:
    """What one run at ``dt`` [s] costs of the budget: its steps / ``UNIT_STEPS``, at least one run."""
    return max(1.0, scene.duration / dt / UNIT_STEPS)


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
    table["robust"] = table["robust"].astype(object).where(table["robust"].notna(), None)
    cols = TUNE_COLUMNS + list(defaults)
    return (table[[c for c in cols if c in table.columns]]
            .sort_values(["steps_per_sim_s", "n_non_default", "cost_per_sim_s"], na_position="last")
            .reset_index(drop=True))
