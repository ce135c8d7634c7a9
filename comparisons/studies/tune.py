"""Engine tuning: the cheapest settings whose episodes all match the reference within a tolerance.

    >>> space = {"dt": (1e-3, 3e-4), "mujoco.w0_dt": (0.1,)}
    >>> result = tune(load_scene("feigin-pair", ["duration=12.6"]), "mujoco", Tolerances(), space=space, workers=1,
    ...               refine_steps=0)
    >>> result.best["settings"]            # the recommended settings (None if nothing met the tolerances)
    'dt=0.0003, mujoco.w0_dt=0.1'

``outputs/guide.py`` turns the result into the tuning guide.

The search is a coarse grid over the settings that matter (MuJoCo: dt, w0 dt, integrator;
PyBullet: dt, restitution velocity threshold, solver iterations), then a refinement near
the front: the timestep of the cheapest matching candidates is bisected (geometrically)
towards the next cheaper timestep until the step that fails is found to within a factor
of ``refine_ratio``. Candidates run in parallel through a ``concurrent.futures`` executor
(a local process pool by default). The reference is solved once; every candidate is
judged against it by the one judge (``pipeline.compare.judge_run``) with the given
``Tolerances`` (fractions of each episode's own scales), and condensed to the one summary
row (``pipeline.summary.metrics``): the same column names as ``compare`` and sweeps, plus
``timing_score``, the worst timing error as a multiple of its tolerance (<= 1 passes).
"""

from __future__ import annotations

import itertools
import math
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Sequence

import pandas as pd

from chatterbench.engines.registry import check_engine, make_settings
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene, SceneError

from chatterbench.comparisons.pipeline.compare import judge_run
from chatterbench.comparisons.pipeline.solution import ReferenceSolution, solve
from chatterbench.comparisons.pipeline.summary import metrics
from chatterbench.comparisons.pipeline.tolerances import Tolerances

# the coarse grid per engine: setting -> values (dt in seconds)
SEARCH_SPACE: dict[str, dict[str, tuple]] = {
    "mujoco": {"dt": (1e-3, 3e-4, 1e-4, 3e-5), "mujoco.w0_dt": (0.01, 0.03, 0.1), "mujoco.integrator": ("euler", "implicitfast")},
    "pybullet": {"dt": (1e-3, 3e-4, 1e-4, 3e-5), "pybullet.restitution_velocity_threshold": (0.0, 0.01, 0.1),
                 "pybullet.num_solver_iterations": (10, 50)},
}
TUNE_COLUMNS = ["stage", "dt", "settings", "verdict", "n_episodes", "n_match", "exit_error_max", "stick_error_max",
                "exit_error_rel_max", "stick_error_rel_max", "restitution_error_max", "penetration_max", "timing_score",
                "cost_per_sim_s", "status"]


@dataclass(frozen=True)
class TuneResult:
    """Every candidate tried (``table``), the recommendation and the best reachable error."""

    scene: Scene
    engine: str
    tolerance: Tolerances
    table: pd.DataFrame  # TUNE_COLUMNS plus one column per searched setting
    best: dict[str, Any] | None  # cheapest all-match candidate, None if none met the tolerance
    best_reachable: dict[str, Any] | None  # candidate with the smallest timing score, whatever its verdict
    extra: dict[str, Any] = field(default_factory=dict)


def timing_score(row: dict[str, Any], tol: Tolerances) -> float:
    """The worst timing error as a multiple of its tolerance: max(stick / stick tol, exit / exit tol); NaN if none."""
    parts = [row["stick_error_rel_max"] / tol.stick, row["exit_error_rel_max"] / tol.exit]
    parts = [p for p in parts if not math.isnan(p)]
    return max(parts) if parts else math.nan


def _evaluate(ref: ReferenceSolution, engine: str, params: dict, tol: Tolerances) -> dict[str, Any]:
    """Run one candidate and judge it (runs in a worker process)."""
    overrides = [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in params.items() if k != "dt"]
    settings = make_settings(engine, params["dt"], overrides)
    run, table, _ = judge_run(ref, engine, settings, tol)
    row = {**params, "settings": ", ".join(f"{k}={v}" for k, v in params.items()), **metrics(table),
           "cost_per_sim_s": run.cost_per_sim_s, "status": run.status, "_run_settings": run.settings}
    row["timing_score"] = timing_score(row, tol)
    return row


def _run_batch(executor: Executor, ref: ReferenceSolution, engine: str, batch: list[dict], tol: Tolerances,
               stage: str) -> list[dict]:
    futures = [executor.submit(_evaluate, ref, engine, p, tol) for p in batch]
    rows = []
    for fut, params in zip(futures, batch):
        try:
            row = fut.result()
        except InputError as exc:  # e.g. w0 dt past the stability limit for this scene's zeta
            row = {**params, "settings": ", ".join(f"{k}={v}" for k, v in params.items()), "verdict": "refused",
                   "n_episodes": 0, "n_match": 0, **{c: math.nan for c in TUNE_COLUMNS if c.endswith(("_max", "_score"))},
                   "cost_per_sim_s": math.nan, "status": f"refused: {exc}", "_run_settings": {}}
        row["stage"] = stage
        rows.append(row)
    return rows


def tune(
    scene: Scene,
    engine: str,
    tolerance: Tolerances | float,
    space: dict[str, Sequence] | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
    refine_steps: int = 3,
) -> TuneResult:
    """Find the cheapest settings of ``engine`` whose episodes all ``match`` within ``tolerance``.

    Parameters
    ----------
    tolerance : Tolerances or float
        The verdict tolerances; a number sets the sticking, exit and first-impact
        tolerances at once (fractions of each episode's chatter or sliding duration).
    space : dict, optional
        Setting -> candidate values (default ``SEARCH_SPACE[engine]``; must include ``dt``).
    refine_steps : int
        Bisections of the timestep between the cheapest match and the next cheaper step.
    """
    check_engine(engine)
    tol = tolerance if isinstance(tolerance, Tolerances) else Tolerances(stick=tolerance, exit=tolerance, first_impact=tolerance)
    space = dict(space or SEARCH_SPACE[engine])
    if "dt" not in space or not all(len(v) for v in space.values()):
        raise SceneError("tune search space: needs a non-empty 'dt' list and non-empty lists for every setting")
    for values in itertools.product(*space.values()):  # validate every candidate before running any
        p = dict(zip(space, values))
        make_settings(engine, p["dt"], [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in p.items() if k != "dt"])
    ref = solve(scene)
    own = executor is None
    executor = executor or ProcessPoolExecutor(max_workers=workers)
    try:
        coarse = [dict(zip(space, values)) for values in itertools.product(*space.values())]
        rows = _run_batch(executor, ref, engine, coarse, tol, "coarse")
        # refinement near the front: for each setting combination whose cheapest match is
        # not the largest dt, bisect dt (geometrically) towards the next larger dt
        dts = sorted(space["dt"])
        for _ in range(refine_steps):
            frame = pd.DataFrame(rows)
            batch = []
            others = [k for k in space if k != "dt"]
            groups = frame.groupby(others, dropna=False) if others else [((), frame)]
            for key, grp in groups:
                ok = grp[grp["verdict"] == "match"]
                if ok.empty:
                    continue
                lo = float(ok["dt"].max())  # largest matching dt (cheapest)
                bigger = sorted(float(d) for d in grp["dt"] if d > lo)
                if not bigger:
                    continue
                hi = bigger[0]
                if hi / lo < 1.3:
                    continue
                mid = math.sqrt(lo * hi)
                params = dict(zip(others, key if isinstance(key, tuple) else (key,)))
                batch.append({"dt": float(f"{mid:.3g}"), **params})
            if not batch:
                break
            rows += _run_batch(executor, ref, engine, batch, tol, "refine")
    finally:
        if own:
            executor.shutdown()
    table = pd.DataFrame(rows)
    cols = TUNE_COLUMNS + [k for k in space if k != "dt"] + ["_run_settings"]
    table = table[[c for c in cols if c in table.columns]].sort_values("cost_per_sim_s", na_position="last").reset_index(drop=True)
    matches = table[table["verdict"] == "match"]
    best = matches.iloc[0].to_dict() if len(matches) else None
    # best reachable: the smallest timing score (worst timing error over its tolerance), whatever the verdict
    finite = table.dropna(subset=["timing_score"])
    reach = finite.sort_values(["timing_score", "cost_per_sim_s"]).iloc[0].to_dict() if len(finite) else None
    return TuneResult(scene=scene, engine=engine, tolerance=tol, table=table, best=best, best_reachable=reach,
                      extra={"dts": dts})
