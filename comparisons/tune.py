"""Engine tuning: the cheapest settings whose episodes all match the reference within a tolerance.

    >>> result = tune(load_scene("feigin-pair"), "mujoco", tolerance=0.01)
    >>> result.best            # the recommended settings' row (None if nothing met the tolerance)
    >>> print(guide_markdown(result))

The search is a coarse grid over the settings that matter (MuJoCo: dt, w0 dt, integrator;
PyBullet: dt, restitution velocity threshold, solver iterations), then a refinement near
the front: the timestep of the cheapest matching candidates is bisected (geometrically)
towards the next cheaper timestep until the step that fails is found to within a factor
of ``refine_ratio``. Candidates run in parallel through a ``concurrent.futures`` executor
(a local process pool by default). The reference runs once; every candidate is judged
against it with ``Tolerances(stick=T, exit=T, first_impact=T)``, T the tolerance in units
of the forcing period.
"""

from __future__ import annotations

import itertools
import math
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import pandas as pd

from chatterbench.engines.registry import check_engine, make_settings
from chatterbench.reference.scene import Scene, SceneError, scene_from_dict
from chatterbench.reference.simulate import simulate

from .compare import _energy_max, run_one
from .rows import point_verdict
from .verdict import Tolerances, judge, reference_episodes

# the coarse grid per engine: setting -> values (dt in seconds)
SEARCH_SPACE: dict[str, dict[str, tuple]] = {
    "mujoco": {"dt": (1e-3, 3e-4, 1e-4, 3e-5), "mujoco.w0_dt": (0.01, 0.03, 0.1), "mujoco.integrator": ("euler", "implicitfast")},
    "pybullet": {"dt": (1e-3, 3e-4, 1e-4, 3e-5), "pybullet.restitution_velocity_threshold": (0.0, 0.01, 0.1),
                 "pybullet.num_solver_iterations": (10, 50)},
}
TUNE_COLUMNS = ["stage", "dt", "settings", "verdict", "n_episodes", "n_match", "exit_error_max", "stick_error_max",
                "cost_per_sim_s", "status"]


@dataclass(frozen=True)
class TuneResult:
    """Every candidate tried (``table``), the recommendation and the best reachable error."""

    scene: Scene
    engine: str
    tolerance: float  # fraction of the forcing period
    table: pd.DataFrame  # TUNE_COLUMNS plus one column per searched setting
    best: dict[str, Any] | None  # cheapest all-match candidate, None if none met the tolerance
    best_reachable: dict[str, Any] | None  # candidate with the smallest exit error, whatever its verdict
    extra: dict[str, Any] = field(default_factory=dict)


def _evaluate(scene_data: dict, engine: str, params: dict, ref: pd.DataFrame, e_max: float, v_max: float,
              tol: Tolerances) -> dict[str, Any]:
    """Run one candidate and judge it (runs in a worker process)."""
    scene = scene_from_dict(scene_data)
    overrides = [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in params.items() if k != "dt"]
    settings = make_settings(engine, params["dt"], overrides)
    run = run_one(scene, engine, settings, e_max, v_max, tol)
    table = judge(scene, ref, run.episodes, run.log, run.t_diverged, run.t_penetrated, tol)
    absmax = lambda s: float(s.abs().max()) if s.notna().any() else math.nan  # noqa: E731
    return {
        **params,
        "settings": ", ".join(f"{k}={v}" for k, v in params.items()),
        "verdict": point_verdict(table["verdict"]),
        "n_episodes": len(table),
        "n_match": int((table["verdict"] == "match").sum()),
        "exit_error_max": absmax(table["exit_error"]),
        "stick_error_max": absmax(table["stick_error_zeno"]),
        "cost_per_sim_s": run.cost_per_sim_s,
        "status": run.status,
        "_run_settings": run.settings,
    }


def _run_batch(executor: Executor, scene: Scene, engine: str, batch: list[dict], ctx: tuple, stage: str) -> list[dict]:
    futures = [executor.submit(_evaluate, scene.to_dict(), engine, p, *ctx) for p in batch]
    rows = []
    for fut, params in zip(futures, batch):
        try:
            row = fut.result()
        except SceneError as exc:  # e.g. w0 dt past the stability limit for this scene's zeta
            row = {**params, "settings": ", ".join(f"{k}={v}" for k, v in params.items()), "verdict": "refused",
                   "n_episodes": 0, "n_match": 0, "exit_error_max": math.nan, "stick_error_max": math.nan,
                   "cost_per_sim_s": math.nan, "status": f"refused: {exc}", "_run_settings": {}}
        row["stage"] = stage
        rows.append(row)
    return rows


def tune(
    scene: Scene,
    engine: str,
    tolerance: float,
    space: dict[str, Sequence] | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
    refine_steps: int = 3,
) -> TuneResult:
    """Find the cheapest settings of ``engine`` whose episodes all ``match`` within ``tolerance``.

    Parameters
    ----------
    tolerance : float
        Allowed error in sticking start, exit and first impact, as a fraction of the
        forcing period (0.01 = 1% of the period), 0 < tolerance < 1.
    space : dict, optional
        Setting -> candidate values (default ``SEARCH_SPACE[engine]``; must include ``dt``).
    refine_steps : int
        Bisections of the timestep between the cheapest match and the next cheaper step.
    """
    check_engine(engine)
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not 0 < tolerance < 1:
        raise SceneError(f"tolerance = {tolerance!r}: must be a fraction of the forcing period in (0, 1)")
    space = dict(space or SEARCH_SPACE[engine])
    if "dt" not in space or not all(len(v) for v in space.values()):
        raise SceneError("tune search space: needs a non-empty 'dt' list and non-empty lists for every setting")
    for values in itertools.product(*space.values()):  # validate every candidate before running any
        p = dict(zip(space, values))
        make_settings(engine, p["dt"], [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in p.items() if k != "dt"])
    tol = Tolerances(stick=tolerance, exit=tolerance, first_impact=tolerance)
    feigin, exhaustive = simulate(scene, "feigin"), simulate(scene, "exhaustive")
    ref = reference_episodes(feigin, exhaustive, scene)
    e_max = _energy_max(scene, exhaustive)
    v_max = float(np.abs(exhaustive.log["v_minus"]).max()) if len(exhaustive.log) else abs(scene.initial.vy)
    ctx = (ref, e_max, v_max, tol)
    own = executor is None
    executor = executor or ProcessPoolExecutor(max_workers=workers)
    try:
        coarse = [dict(zip(space, values)) for values in itertools.product(*space.values())]
        rows = _run_batch(executor, scene, engine, coarse, ctx, "coarse")
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
            rows += _run_batch(executor, scene, engine, batch, ctx, "refine")
    finally:
        if own:
            executor.shutdown()
    table = pd.DataFrame(rows)
    cols = TUNE_COLUMNS + [k for k in space if k != "dt"] + ["_run_settings"]
    table = table[[c for c in cols if c in table.columns]].sort_values("cost_per_sim_s", na_position="last").reset_index(drop=True)
    matches = table[table["verdict"] == "match"]
    best = matches.iloc[0].to_dict() if len(matches) else None
    # best reachable: the smallest worst error over exit and sticking start, whatever the verdict
    table["error_max"] = table[["exit_error_max", "stick_error_max"]].max(axis=1, skipna=True)
    finite = table.dropna(subset=["error_max"])
    reach = finite.sort_values(["error_max", "cost_per_sim_s"]).iloc[0].to_dict() if len(finite) else None
    return TuneResult(scene=scene, engine=engine, tolerance=tolerance, table=table, best=best, best_reachable=reach,
                      extra={"dts": dts})
