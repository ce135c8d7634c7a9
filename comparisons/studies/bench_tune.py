"""The tune benchmarks (``chatterbench bench tune``, ``bench ladder``, ``bench atlas``): a tune per case timed as a user
waits for it, a run judged at every ladder point, and the atlas serial against batched.

    >>> from chatterbench.comparisons.studies.bench_tune import frontier_points
    >>> frontier_points([{"tolerances": {"stick": 0.05, "restitution": 0.05}, "cost_steps_per_s": 391.2, "dt": 0.00255657,
    ...                   "checked": {"passed": 1.0, "runs": 69}}])     # how each case's frontier is printed
    '5/5% 391/s dt 0.00255657 band 100% of 69'

Like ``bench``'s, these run from the command line, never as timed tests.
"""

from __future__ import annotations

import json
import math
import time
from typing import Callable

from chatterbench.reference import load_scene

# tune's benchmark: the four built-in scenes x MuJoCo and PyBullet; (scene, engine, tolerance T for stick, exit and first
# impact): spring-pair at 0.1, as the tuning issue's brute force had it, the others at 0.05
TUNE_CASES = tuple((scene, engine, 0.1 if scene == "spring-pair" else 0.05)
                   for scene in ("bouncing-ball", "feigin-pair", "impact-damper", "spring-pair")
                   for engine in ("mujoco", "pybullet"))


def frontier_points(frontier: list[dict]) -> str:
    """Each frontier point in a few words: ``5/5% 391/s dt 0.00255657 band 100% of 69``."""
    out = []
    for e in frontier:
        band = e.get("checked") or {}
        passed = "" if band.get("passed") is None else f" band {band['passed']:.0%} of {band['runs']}"
        out.append(f"{100 * e['tolerances']['stick']:g}/{100 * e['tolerances']['restitution']:g}% "
                   f"{e['cost_steps_per_s']:,.0f}/s dt {e['dt']:g}{passed}")
    return "; ".join(out)


def bench_tune(cases=TUNE_CASES, workers: int = 2, max_runs: int | None = None,
               started: Callable[[str, str, float], None] | None = None,
               finished: Callable[[dict], None] | None = None):
    """One ``tune`` per case, timed as a user waits for it (the reference, the search, the repeats' timing).

    Returns a DataFrame, one row per case: scene, engine, tolerance, answer (the chosen settings),
    robust, margin (worst error / tolerance of the judge's checks), steps_per_sim_s, runs, wall_s, fragile (the cheapest
    isolated pass, if cheaper), exhaustive (the whole lattice ran), frontier (its points), tightest_stick and
    tightest_restitution (the tightest tolerances reached robustly; NaN: none), band_runs (the band checks among the
    runs), band_passed_min (the least share of a frontier point's band that passed: 1.0 when every point is
    band-robust), points (each frontier point: tolerances, cost, dt and the share of its band runs that passed),
    transfers (the written answer on the scene's family, ``transfer.transfer_sentence``), and answer_line (the answer's first
    sentence: robust at T or not, then the frontier, ``tune.answer.frontier_line``). ``started(scene, engine,
    tolerance)`` is called as each case begins (the CLI's progress line), ``finished(row)`` as it ends (the CLI prints
    the case's row then: a long benchmark stopped halfway keeps what it measured).
    """
    import pandas as pd

    from .transfer import transfer_sentence
    from .limits import MAX_RUNS
    from .tune import tune
    from .tune.answer import frontier_line

    rows = []
    for scene_name, engine, tol in cases:
        if started is not None:
            started(scene_name, engine, tol)
        start = time.perf_counter()
        result = tune(load_scene(scene_name), engine, tol, workers=workers, max_runs=max_runs or MAX_RUNS, repeats=3)
        wall = time.perf_counter() - start
        c, f = result.chosen, result.fragile
        reach = result.extra["tightest"]
        rows.append({"scene": scene_name, "engine": engine, "tolerance": tol, "answer": c["settings"] if c else "",
                     "robust": result.best is not None, "margin": result.margin,
                     "steps_per_sim_s": c["steps_per_sim_s"] if c else math.nan, "runs": len(result.table),
                     "wall_s": wall,
                     "fragile": f["settings"] if f is not None and c is not None and f["settings"] != c["settings"] else "",
                     "exhaustive": result.extra["searched"]["exhaustive"], "frontier": len(result.frontier),
                     "tightest_stick": math.nan if reach["stick"] is None else reach["stick"],
                     "tightest_restitution": math.nan if reach["restitution"] is None else reach["restitution"],
                     "band_runs": result.extra["searched"].get("band_runs", 0),
                     "band_passed_min": min(((e.get("checked") or {}).get("passed") or math.nan for e in result.frontier),
                                            default=math.nan),
                     "points": frontier_points(result.frontier),
                     "transfers": transfer_sentence(result.extra.get("transfer", [])),
                     "answer_line": frontier_line(result)})
        if finished is not None:
            finished(rows[-1])
    return pd.DataFrame(rows)


# runs judged at every point of tune's ladder (``bench_ladder``): (scene, engine, dt [s], settings), passing ones and
# failing ones (late, rebound, buzz, penetrated), at a coarse dt (one extraction serves every timing level) and fine
LADDER_CASES = (
    ("bouncing-ball", "pybullet", 0.00255657, {"pybullet.restitution_velocity_threshold": 0.1}),  # passes everywhere
    ("bouncing-ball", "mujoco", 1e-3, {"mujoco.w0_dt": 0.3, "mujoco.impedance": 0.9}),  # late, rebound; passes loose
    ("bouncing-ball", "pybullet", 1e-4, {}),  # buzz everywhere (an extraction per timing level)
    ("feigin-pair", "pybullet", 2e-3, {"pybullet.restitution_velocity_threshold": 0.01}),  # late at 1%, then passes
    ("feigin-pair", "mujoco", 1e-3, {"mujoco.w0_dt": 0.1}),
    ("impact-damper", "mujoco", 1e-3, {}),
    ("impact-damper", "pybullet", 1e-3, {}),
)


def _extractions(ref, run, points, asked, repeats: int) -> float:
    """CPU seconds [s] of the extractions a ladder needs beside the asked point's (one per other f_min): the same
    work before and after (``bench_ladder``), the best of ``repeats``."""
    from ..pipeline.extract import extract, flight_floor

    dt = run.trajectory.dt
    floors = {flight_floor(dt, ref.scene.restitution, ref.stick_tolerance(p.stick)): p.stick for p in points}
    floors.pop(flight_floor(dt, ref.scene.restitution, ref.stick_tolerance(asked.stick)), None)
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        for stick in floors.values():
            extract(run.trajectory, ref.scene, ref.stick_tolerance(stick))
        best = min(best, time.process_time() - start)
    return best


def bench_ladder(cases=LADDER_CASES, repeats: int = 3):
    """CPU seconds of judging one run at every point of ``tune``'s ladder (``Ladder()`` around stick = exit = first
    impact = 5%, restitution 5%), one point at a time as before (``tune.ladder.reference_levels``) against the
    prepared run (``tune.ladder.judge_levels``), the asked point already judged as ``tune`` has it; each the best of
    ``repeats`` after a warm-up, ``time.process_time`` (the engine's run is not timed).

    Returns (figures, table): ``figures`` with ``points`` (ladder points of a run), ``runs_per_cpu_s_before`` and
    ``_after`` (runs judged at the whole ladder per CPU second, over all cases), ``points_per_cpu_s_before`` and
    ``_after``, ``speedup`` (their ratio), ``extract_share_after`` (the share of the extractions at the other
    f_mins in the time after: the same work before and after, one per f_min), ``judge_speedup`` (the speed-up with
    them left out of both), ``same`` (1.0 when both give the same values at every case) and ``hash_before``,
    ``hash_after`` (of the outputs, equal when they agree); ``table`` one row per case: scene, engine, dt,
    settings, ms_before, ms_after, ms_extract (those extractions), speedup, passes (points passed), same.
    """
    import hashlib

    import pandas as pd

    from chatterbench.engines.registry import make_settings

    from ..pipeline.compare import judge_run
    from ..pipeline.solution import solve
    from ..pipeline.tolerances import Tolerances
    from .tune.ladder import Ladder, judge_levels, reference_levels

    asked = Tolerances(stick=0.05, exit=0.05, first_impact=0.05)
    points = Ladder().points(asked)
    at = points.index(asked)
    solutions, rows, outputs = {}, [], {"before": [], "after": []}
    for scene_name, engine, dt, overrides in cases:
        if scene_name not in solutions:
            solutions[scene_name] = solve(load_scene(scene_name))
        ref = solutions[scene_name]
        settings = make_settings(engine, dt, overrides)
        run, table, impacts = judge_run(ref, engine, settings, asked)
        known = {at: (run, table, impacts)}
        times, passes = {}, {}
        for name, fn in (("before", reference_levels), ("after", judge_levels)):
            call = lambda fn=fn: fn(ref, engine, settings, run.trajectory, points, known=known)  # noqa: E731
            out = call()  # warm-up
            best = math.inf
            for _ in range(repeats):
                start = time.process_time()
                call()
                best = min(best, time.process_time() - start)
            times[name], passes[name] = best, len(out["passes"])
            outputs[name].append(repr(out))
        times["extract"] = _extractions(ref, run, points, asked, repeats)
        rows.append({"scene": scene_name, "engine": engine, "dt": dt,
                     "settings": " ".join(f"{k}={v:g}" for k, v in overrides.items()),
                     "ms_before": 1e3 * times["before"], "ms_after": 1e3 * times["after"],
                     "ms_extract": 1e3 * times["extract"],
                     "speedup": times["before"] / times["after"], "passes": passes["after"],
                     "same": outputs["before"][-1] == outputs["after"][-1]})
    table = pd.DataFrame(rows)
    before, after = table["ms_before"].sum() / 1e3, table["ms_after"].sum() / 1e3
    extracting = table["ms_extract"].sum() / 1e3
    digest = {k: hashlib.sha256("\n".join(v).encode()).hexdigest()[:16] for k, v in outputs.items()}
    figures = {"points": len(points), "runs_per_cpu_s_before": len(table) / before, "runs_per_cpu_s_after": len(table) / after,
               "points_per_cpu_s_before": len(table) * len(points) / before,
               "points_per_cpu_s_after": len(table) * len(points) / after, "speedup": before / after,
               "extract_share_after": extracting / after, "judge_speedup": (before - extracting) / (after - extracting),
               "same": float(table["same"].all()), "hash_before": digest["before"], "hash_after": digest["after"]}
    return figures, table


# the atlas's benchmark: a small atlas (scene, engine), each engine's knobs held where its frontier lies (its tune on
# the ball), dt capped at 300 steps per simulated second: seconds a case, so serial and batched fit in one run
ATLAS_CASES = (("bouncing-ball", "pybullet"), ("bouncing-ball", "mujoco"), ("feigin-pair", "pybullet"),
               ("feigin-pair", "mujoco"))
ATLAS_FIXED = {"pybullet.restitution_velocity_threshold": 0.1, "pybullet.num_solver_iterations": 50,
               "mujoco.integrator": "euler", "mujoco.impedance": 0.9, "mujoco.w0_dt": 0.3}


def bench_atlas(cases=ATLAS_CASES, workers: int = 2, max_runs: int = 40, max_cost: float = 300.0,
                finished: Callable[[dict], None] | None = None):
    """Each atlas case (``studies.atlas.run_case``) run twice: *serial* (one worker process, the ladder judged one
    point at a time: ``tune.ladder.reference_levels``, as before the prepared run) and *batched* (``workers``
    processes, the ladder judged from one prepared run: ``judge_levels``). One row per case and way: scene, engine,
    way, runs, judged (ladder judgements: a run at each point it was judged at), wall_s, runs_per_s, judged_per_s,
    and same (the batched case's frontier and answer equal the serial one's, on the batched row). ``finished(row)``
    as each row is made.
    """
    from .pools import process_pool

    import pandas as pd

    from .atlas import AtlasSpec, run_case
    from .tune.ladder import Ladder

    rows = []
    for scene, engine in cases:
        spec = AtlasSpec(scenes=(scene,), engines=(engine,), tolerance=0.05, max_runs=max_runs, max_cost=max_cost,
                         fixed={k: v for k, v in ATLAS_FIXED.items() if k.startswith(engine + ".")})
        answers = {}
        for way, n, per_point in (("serial", 1, True), ("batched", workers, False)):
            with process_pool(n) as pool:
                start = time.perf_counter()
                case, table = run_case(spec, scene, engine, executor=pool, per_point=per_point)
                wall = time.perf_counter() - start
            n = len(Ladder().points(spec.tolerances()))
            judged = 0 if table is None else int(sum(points_judged(r, n) for r in table.to_dict("records")))
            rec = case.get("recommended") or {}
            answers[way] = json.dumps({k: rec.get(k) for k in ("dt", "settings", "robust", "tightest", "frontier")},
                                      sort_keys=True, default=str)
            rows.append({"scene": scene, "engine": engine, "way": way, "runs": case["runs"], "judged": judged,
                         "wall_s": wall, "runs_per_s": case["runs"] / wall if wall > 0 else math.nan,
                         "judged_per_s": judged / wall if wall > 0 else math.nan,
                         "same": None if way == "serial" else answers["batched"] == answers["serial"]})
            if finished is not None:
                finished(rows[-1])
    return pd.DataFrame(rows)


def points_judged(row: dict, points: int) -> int:
    """The ladder points (of ``points``) a tune row was judged at: all but its ``unjudged`` (none for a refused row)."""
    if row.get("status") == "refused":
        return 0
    unjudged = row.get("unjudged")
    return points - (len(unjudged) if isinstance(unjudged, (tuple, list)) else 0)
