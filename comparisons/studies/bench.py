"""Benchmarks run from the command line (``chatterbench bench ...``), never as timed tests.

    >>> figures = bench_reference(periods=10, repeats=1)
    >>> sorted(figures)
    ['exhaustive_impacts', 'exhaustive_ms', 'exhaustive_us_per_impact', 'feigin_events', 'feigin_ms_per_100_periods',
     'periods']

Each figure is the best of ``repeats`` runs after one warm-up run (which also compiles
the numba kernels), measured with ``time.perf_counter`` on one core.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from chatterbench.reference import load_scene, simulate

from .sweep import Sweep, run_sweep


def _best(fn, repeats: int) -> tuple[float, object]:
    fn()  # warm-up: numba compilation, caches
    best, out = math.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def bench_reference(periods: int = 100, repeats: int = 5) -> dict[str, float]:
    """Time the reference on feigin-pair over ``periods`` forcing periods in both chatter modes.

    Returns
    -------
    dict
        ``feigin_ms_per_100_periods``, ``feigin_events``, ``exhaustive_ms``,
        ``exhaustive_impacts``, ``exhaustive_us_per_impact``.
    """
    scene = load_scene("feigin-pair", [f"duration={periods * 2.0 * math.pi!r}"])
    t_feigin, res_f = _best(lambda: simulate(scene, "feigin"), repeats)
    t_exh, res_e = _best(lambda: simulate(scene, "exhaustive"), repeats)
    return {
        "periods": periods,
        "feigin_ms_per_100_periods": 1e3 * t_feigin * 100.0 / periods,
        "feigin_events": float(len(res_f.log)),
        "exhaustive_ms": 1e3 * t_exh,
        "exhaustive_impacts": float(res_e.n_impacts),
        "exhaustive_us_per_impact": 1e6 * t_exh / max(res_e.n_impacts, 1),
    }


def bench_engines(steps: int = 200_000, repeats: int = 3):
    """Steps per second of each adapter on feigin-pair next to the raw engine loop, same run.

    Raw loops: MuJoCo, one ``mujoco.rollout`` of the same model with no adapter work;
    PyBullet, ``stepSimulation`` plus the two joint-state reads. Returns a DataFrame with
    columns engine, steps, adapter_steps_per_s, raw_steps_per_s, ratio.
    """
    import pandas as pd

    from chatterbench.engines.registry import adapter, available_engines, make_settings

    scene = load_scene("feigin-pair")
    rows = []
    for name in available_engines():
        figures = adapter(name).benchmark(scene, make_settings(name), steps, repeats)
        ours, raw = figures["adapter_steps_per_s"], figures["raw_steps_per_s"]
        rows.append({"engine": name, "steps": steps, "adapter_steps_per_s": ours, "raw_steps_per_s": raw,
                     "ratio": ours / raw})
    return pd.DataFrame(rows)


def bench_platemap(strikes: int = 100_000, repeats: int = 3) -> dict[str, float]:
    """Time the reference's strike fates (exhaustive mode) for random strikes on feigin-pair's lower wall."""
    import numpy as np

    from chatterbench.reference.chatter import strike_fates

    scene = load_scene("feigin-pair")
    rng = np.random.default_rng(0)
    t = rng.uniform(0.0, 2.0 * math.pi, strikes)
    v = -rng.uniform(0.0, 0.3, strikes)
    strike_fates(scene, "lower", t[:10], v[:10])  # warm-up (numba cache)
    best, fates = _best(lambda: strike_fates(scene, "lower", t, v), repeats)
    return {
        "strikes": strikes,
        "seconds": best,
        "us_per_strike": 1e6 * best / strikes,
        "impacts_followed": float(fates.n_impacts.sum()),
        "fraction_sliding": float(fates.slides.mean()),
    }


def bench_sweep(points: int = 200, workers: int = 2, out_dir: str | Path | None = None) -> dict[str, float]:
    """Time a sweep of feigin-pair comparisons: how much the machinery adds, how it scales.

    ``points`` initial phases (``initial.t`` over one forcing period), both engines, 3 forcing
    periods, dt = 1e-4, run with 1 and with ``workers`` local processes.

    Returns
    -------
    dict
        ``points``, ``runs``, ``workers``, ``wall_s`` (sweep with ``workers``), ``run_s_sum``
        (the isolated runs' own wall time: reference, engine, extraction, judging),
        ``engine_s_sum`` (engine stepping only), ``overhead_ratio`` = wall / (run_s_sum /
        workers) (goal <= 1.15), ``engine_ratio`` = wall / (engine_s_sum / workers),
        ``wall_1_worker_s`` and ``speedup`` = wall_1_worker / wall (goal >= 1.7).
    """
    import tempfile

    period = 2.0 * math.pi  # feigin-pair forcing: omega = 1 rad/s
    sweep = Sweep(scene="feigin-pair", engines=("mujoco", "pybullet"), fixed={"dt": 1e-4, "duration": 3.0 * period},
                  grid={"initial.t": tuple(period * i / points for i in range(points))}, timeout=600.0)
    figures: dict[str, float] = {"points": points, "workers": workers}
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        for n in sorted({1, workers}, reverse=True):
            stats = run_sweep(sweep, Path(tmp, f"w{n}"), workers=n, progress=False).attrs["sweep"]
            if n == workers:
                figures.update(runs=stats["runs"], wall_s=stats["wall_s"], run_s_sum=stats["run_s_sum"],
                               engine_s_sum=stats["engine_s_sum"])
            if n == 1:
                figures["wall_1_worker_s"] = stats["wall_s"]
    figures["overhead_ratio"] = figures["wall_s"] / (figures["run_s_sum"] / workers)
    figures["engine_ratio"] = figures["wall_s"] / (figures["engine_s_sum"] / workers)
    figures["speedup"] = figures["wall_1_worker_s"] / figures["wall_s"]
    return figures
