"""Benchmarks run from the command line (``chatterbench bench ...``), never as timed tests.

    >>> figures = bench_reference(periods=100, repeats=5)
    >>> figures["feigin_ms_per_100_periods"], figures["exhaustive_us_per_impact"]

Each figure is the best of ``repeats`` runs after one warm-up run (which also compiles
the numba kernels), measured with ``time.perf_counter`` on one core.
"""

from __future__ import annotations

import math
import time

from chatterbench.reference import load_scene, simulate


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

    from chatterbench.engines.registry import ENGINE_NAMES, adapter, make_settings

    scene = load_scene("feigin-pair")
    rows = []
    for name in ENGINE_NAMES:
        figures = adapter(name).benchmark(scene, make_settings(name), steps, repeats)
        adapter = figures["adapter_steps_per_s"]
        raw = figures["raw_steps_per_s"]
        rows.append({"engine": name, "steps": steps, "adapter_steps_per_s": adapter, "raw_steps_per_s": raw,
                     "ratio": adapter / raw})
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
