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
