"""Benchmarks run from the command line (``chatterbench bench ...``), never as timed tests.

    >>> from chatterbench.comparisons.studies.bench import bench_reference
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

from .sweep import Sweep, load_sweep, run_sweep


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
        ours, raw = figures.adapter_steps_per_s, figures.raw_steps_per_s
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

    ``points`` initial phases (``initial.t`` over one forcing period), the default engines, 3 forcing
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
    sweep = Sweep(scene="feigin-pair", fixed={"dt": 1e-4, "duration": 3.0 * period},
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


def refine_bench_sweep() -> Sweep:
    """The adaptive map `bench sweep` times by default: feigin-pair over one forcing period, dt x R, the default engines.

    Depth 2 on a 5 x 5 grid, standing for 17 x 17 (578 runs of the fine grid, a couple of minutes on 2 cores).
    """
    return Sweep(scene="feigin-pair", fixed={"duration": 2.0 * math.pi},
                 grid={"dt": (1e-4, 10 ** -3.5, 1e-3, 10 ** -2.5, 1e-2), "restitution": (0.1, 0.3, 0.5, 0.7, 0.9)},
                 timeout=600.0, refine={"axes": ["dt", "restitution"], "depth": 2})


def bench_refine(spec: str | Path | Sweep | None = None, workers: int = 2, out_dir: str | Path | None = None):
    """Cells per minute of an adaptive map (a spec with ``[refine]``) against the full fine grid it stands for.

    Runs ``sweep.adaptive.fine_sweep(spec)`` (default ``refine_bench_sweep()``) and then the adaptive sweep, each from scratch on
    ``workers`` local processes, and fills the fine map from the adaptive rows
    (``sweep.adaptive.agreement``).

    Returns
    -------
    (dict, DataFrame)
        Figures: ``depth``, ``cells`` (fine points x engines), ``fine_runs``, ``adaptive_runs``,
        ``run_ratio`` = adaptive / fine runs, ``fine_wall_s``, ``adaptive_wall_s``,
        ``fine_cells_per_min``, ``adaptive_cells_per_min`` (cells / wall time), ``speedup``
        = fine / adaptive wall time, ``agreement`` (fraction of cells whose label the adaptive
        map gets right); and ``agreement``'s table, one row per engine.
    """
    import tempfile

    from .sweep.adaptive import agreement, fine_sweep

    sweep = refine_bench_sweep() if spec is None else spec if isinstance(spec, Sweep) else load_sweep(spec)
    if sweep.refine is None:
        raise sweep.fail("no [refine] table: `bench sweep --refine` needs an adaptive map spec")
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        fine = run_sweep(fine_sweep(sweep), Path(tmp, "fine"), workers=workers, progress=False)
        adaptive = run_sweep(sweep, Path(tmp, "adaptive"), workers=workers, progress=False)
    table = agreement(sweep, adaptive, fine)
    cells = int(table["cells"].sum())
    fine_s, adaptive_s = fine.attrs["sweep"]["wall_s"], adaptive.attrs["sweep"]["wall_s"]
    figures = {"depth": sweep.refine.depth, "cells": cells, "fine_runs": len(fine), "adaptive_runs": len(adaptive),
               "run_ratio": len(adaptive) / len(fine), "fine_wall_s": fine_s, "adaptive_wall_s": adaptive_s,
               "fine_cells_per_min": 60.0 * cells / fine_s, "adaptive_cells_per_min": 60.0 * cells / adaptive_s,
               "speedup": fine_s / adaptive_s, "agreement": int(table["agree"].sum()) / cells}
    return figures, table


C_RUNS = 256  # [runs] MuJoCo C's rates are measured on at most this many runs per thread (its cost is linear in runs)


def bench_warp(worlds: tuple[int, ...] = (1, 16, 256), steps: int = 500, repeats: int = 1, threads: int | None = None):
    """World-steps per second of MuJoCo Warp on the device it finds, per number of worlds, beside MuJoCo C's.

    Each world is feigin-pair at dt = 1e-3 for ``steps`` steps from its own phase and a strike
    of 0.4 m/s towards a wall (so that its contacts are stepped too). First one short run loads
    MuJoCo Warp's kernels (compiling them the first time on a machine): its time is the
    warm-up, reported apart and counted nowhere else. Per number of worlds:

    - the adapter: the runs through ``iter_batch`` as a user's batch goes (prepared, stepped as
      one model of many worlds in blocks within the host memory, every sample recorded and
      each trajectory made; only a count kept), timed whole;
    - its bare loop, ``mujoco_warp.step`` on that many copies of the first run, nothing
      recorded (``world_steps_per_s``): launched step by step from Python (``bare``), and
      captured as a graph and replayed (``bare_captured``, where warp can capture);
    - MuJoCo C, bare ``mujoco.rollout`` of the same runs in one call (``rollout_steps_per_s``):
      one thread (``C_RUNS`` runs at most) and ``threads`` threads (``C_RUNS`` per thread).

    Returns a DataFrame with columns device, precision, nworld, steps, warp_world_steps_per_s,
    warp_bare_world_steps_per_s, warp_bare_captured_world_steps_per_s, adapter_over_bare,
    adapter_s (the batch's wall time), blocks (blocks of worlds the batch went in), warmup_s,
    kernels (``compiled`` or ``cached``: the warm-up), capture_s (graph capture of the last
    block), mujoco_c_steps_per_s, mujoco_c_threaded_steps_per_s, threads, warp_over_mujoco_c
    (adapter against threaded C), host_peak_gib (the process's peak resident memory so far),
    statuses (the runs' statuses and counts).
    """
    import collections
    import os
    import resource

    import pandas as pd

    from chatterbench.engines.mujoco_engine import rollout_steps_per_s
    from chatterbench.engines.mujoco_warp_engine import world_steps_per_s
    from chatterbench.engines.registry import adapter, make_settings

    threads = threads or os.cpu_count() or 1
    dt, period = 1e-3, 2.0 * math.pi  # feigin-pair forcing: omega = 1 rad/s
    warp_settings, c_settings = make_settings("mujoco_warp", dt), make_settings("mujoco", dt)
    warp = adapter("mujoco_warp")
    first = warp.run(load_scene("feigin-pair", ["duration=0.05"]), warp_settings)  # the kernels, loaded
    warm = {"warmup_s": first.settings.get("warmup_s", math.nan), "kernels": first.settings.get("kernels", "")}
    duration = [f"duration={steps * dt!r}"]
    rows = []
    for n in worlds:
        scenes = [load_scene("feigin-pair", duration + [f"initial.t={period * i / n!r}", f"initial.vy={0.4 * (-1) ** i}"])
                  for i in range(n)]
        statuses: collections.Counter = collections.Counter()
        last = first
        start = time.perf_counter()
        for _, traj in warp.iter_batch([(s, warp_settings) for s in scenes]):
            statuses[str(traj.status)] += 1
            last = traj
        adapter_s = time.perf_counter() - start
        bare = world_steps_per_s(scenes[0], warp_settings, nworld=n, repeats=repeats, captured=False)
        captured = world_steps_per_s(scenes[0], warp_settings, nworld=n, repeats=repeats, captured=True)
        one = rollout_steps_per_s([(s, c_settings) for s in scenes[:min(n, C_RUNS)]], threads=1)
        many = rollout_steps_per_s([(s, c_settings) for s in scenes[:min(n, C_RUNS * threads)]], threads=threads)
        rate = n * steps / adapter_s
        rows.append({"device": last.settings.get("device", ""), "precision": last.settings.get("precision", ""),
                     "nworld": n, "steps": steps, "warp_world_steps_per_s": rate,
                     "warp_bare_world_steps_per_s": bare["world_steps_per_s"],
                     "warp_bare_captured_world_steps_per_s": captured["world_steps_per_s"] if captured["captured"]
                     else math.nan, "adapter_over_bare": rate / bare["world_steps_per_s"], "adapter_s": adapter_s,
                     "blocks": math.ceil(n / last.settings.get("batch_size", n)), **warm, "capture_s": last.settings.get("capture_s", math.nan),
                     "mujoco_c_steps_per_s": one["steps_per_s"], "mujoco_c_threaded_steps_per_s": many["steps_per_s"],
                     "threads": threads, "warp_over_mujoco_c": rate / many["steps_per_s"],
                     "host_peak_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
                     "statuses": ", ".join(f"{k} {v}" for k, v in sorted(statuses.items()))})
    return pd.DataFrame(rows)
