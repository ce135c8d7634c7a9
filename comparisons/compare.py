"""One call, one table: run the reference and the engines on a scene and judge every episode.

    >>> from chatterbench.comparisons.compare import compare
    >>> result = compare(load_scene("feigin-pair"), engines=("mujoco", "pybullet"), dt=1e-4)
    >>> result.table[["engine", "wall", "verdict", "exit_error", "stick_error_zeno"]]

The table has one row per (engine, reference or engine episode) with the columns of
``verdict.TABLE_COLUMNS`` plus ``engine``, ``dt`` [s], ``status`` (the engine run's
status) and ``cost_per_sim_s`` (wall-clock seconds of engine stepping per simulated
second). A failing engine never raises: its run is classified (``error``, ``diverged``)
and its rows say so; the other engines' results are kept.
"""

from __future__ import annotations

import math
import platform
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from chatterbench.engines.registry import check_engine, engine_version, make_settings, run_engine, settings_dict
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene, SceneError
from chatterbench.reference.simulate import Result, simulate

from .extract import extract_events
from .verdict import TABLE_COLUMNS, Tolerances, judge, reference_episodes, run_failures
from chatterbench.reference.log import episodes as episodes_from_log

COLUMNS = ["engine", "dt"] + TABLE_COLUMNS + ["status", "cost_per_sim_s"]


@dataclass(frozen=True)
class EngineRun:
    """One engine's run on the scene: trajectory, recovered events, settings and cost."""

    engine: str
    settings: dict[str, Any]
    trajectory: Trajectory
    log: pd.DataFrame
    episodes: pd.DataFrame
    wall_time: float  # [s] spent stepping
    version: str
    t_diverged: float  # [s], NaN if none
    t_penetrated: float  # [s], NaN if none

    @property
    def status(self) -> str:
        return self.trajectory.status

    @property
    def cost_per_sim_s(self) -> float:
        """Wall-clock seconds per simulated second."""
        sim = float(self.trajectory.t[-1] - self.trajectory.t[0]) if len(self.trajectory.t) > 1 else 0.0
        return self.wall_time / sim if sim > 0 else math.nan


@dataclass(frozen=True)
class Comparison:
    """Everything ``compare`` produced; ``table`` is the headline."""

    scene: Scene
    table: pd.DataFrame
    reference: pd.DataFrame  # reference_episodes: plate entry, Zeno point, exit
    feigin: Result
    exhaustive: Result
    runs: dict[str, EngineRun] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> pd.DataFrame:
        """One row per engine: verdict counts, worst errors [s] and cost."""
        rows = []
        for name, run in self.runs.items():
            sub = self.table[self.table["engine"] == name]
            counts = sub["verdict"].value_counts()
            worst = "match" if len(sub) and (sub["verdict"] == "match").all() else (
                counts.drop("match", errors="ignore").idxmax() if len(counts.drop("match", errors="ignore")) else "none")
            rows.append({
                "scene": self.scene.name,
                "engine": name,
                "verdict": worst,
                "episodes": len(sub),
                "matches": int(counts.get("match", 0)),
                "max_exit_error": float(sub["exit_error"].abs().max()) if len(sub) else math.nan,
                "max_stick_error": float(sub["stick_error_zeno"].abs().max()) if len(sub) else math.nan,
                "cost_per_sim_s": run.cost_per_sim_s,
                "status": run.status,
            })
        return pd.DataFrame(rows)


def allowed_penetration(scene: Scene, traj: Trajectory, v_max: float) -> float:
    """How far past a wall an engine may go before the run counts as ``penetrated`` [m].

    A soft contact (the adapter reports its natural frequency ``w0`` [rad/s]) sinks by
    design: a strike at speed v reaches at most about v / w0 (undamped), one more step of
    travel, v dt, before the contact reacts; twice that, (2 / w0 + dt) v_max, with
    ``v_max`` the reference's fastest strike, is allowed. A hard contact (no ``w0``) may
    overshoot by 1% of the gap width (of 1 m for a one-sided gap). Past that, the body
    went through the wall.
    """
    w0 = traj.settings.get("w0")
    if w0 is not None and math.isfinite(w0) and w0 > 0:
        return (2.0 / w0 + traj.settings.get("dt", 0.0)) * v_max
    width = (scene.gap.upper - scene.gap.lower) if scene.gap.upper is not None else 1.0
    return 0.01 * width


def _failed_trajectory(name: str, scene: Scene, settings: Any, exc: BaseException) -> Trajectory:
    empty = np.empty(0)
    return Trajectory(
        engine=name, t=empty, x1=empty, x2=empty, v1=empty, v2=empty,
        contact={w: np.empty(0, bool) for w in scene.gap.walls},
        normal_force={w: empty for w in scene.gap.walls},
        wall_time=0.0, settings=settings_dict(settings), status="error", message=f"{type(exc).__name__}: {exc}",
    )


def run_one(scene: Scene, name: str, settings: Any, ref_energy_max: float, v_max: float, tol: Tolerances,
            trajectory: Trajectory | None = None) -> EngineRun:
    """Run one engine (or take its ``trajectory``, already run) and recover its events.

    Exceptions of the engine become an ``error`` run.
    """
    try:
        traj = trajectory if trajectory is not None else run_engine(name, scene, settings)
    except Exception as exc:  # an engine fault must not lose the other results
        traj = _failed_trajectory(name, scene, settings, exc)
    if len(traj.t) > 1:
        log = extract_events(traj, scene)
    else:
        from chatterbench.reference.log import log_frame

        log = log_frame([])
    t_div, t_pen = run_failures(scene, traj, ref_energy_max, tol, allowed_penetration(scene, traj, v_max))
    return EngineRun(
        engine=name, settings=dict(traj.settings) or settings_dict(settings), trajectory=traj, log=log,
        episodes=episodes_from_log(log), wall_time=traj.wall_time, version=engine_version(name),
        t_diverged=t_div, t_penetrated=t_pen,
    )


def _energy_max(scene: Scene, result: Result) -> float:
    """Largest relative kinetic energy along the reference's impacts and initial state [J]."""
    m_red = scene.mass2 if math.isinf(scene.mass1) else scene.mass1 * scene.mass2 / (scene.mass1 + scene.mass2)
    v = np.concatenate(([scene.initial.vy], result.log["v_minus"].to_numpy(), result.log["v_plus"].to_numpy()))
    # the forcing can raise the energy between impacts: take the dense maximum too, on 200
    # samples per time scale (a smooth maximum is then underestimated by < 2e-4 relative,
    # far inside the 5% energy-gain alarm), at least 1001
    from chatterbench.reference.dense import sample

    n = max(1001, int(math.ceil(200.0 * scene.duration / scene.time_scale)) + 1)
    tt = np.linspace(scene.initial.t, scene.t_end, n)
    dense = sample(scene, result.log, tt)
    v = np.concatenate((v, dense["vy"].to_numpy()))
    return 0.5 * m_red * float(np.max(v * v))


def compare(
    scene: Scene,
    engines: Sequence[str] = ("mujoco", "pybullet"),
    dt: float | None = None,
    overrides: Sequence[str] = (),
    tol: Tolerances | None = None,
    trajectories: Mapping[str, Trajectory] | None = None,
) -> Comparison:
    """Run the reference (both chatter modes) and each engine on ``scene``; judge every episode.

    Parameters
    ----------
    engines : sequence of {"mujoco", "pybullet"}
    dt : float, optional
        Engine timestep [s]; default: each engine's default settings.
    overrides : sequence of str
        ``mujoco.KEY=VALUE`` / ``pybullet.KEY=VALUE`` engine settings.
    tol : Tolerances, optional
    trajectories : mapping engine name -> Trajectory, optional
        Engine runs already made with these settings (a sweep's MuJoCo batch); those
        engines are judged on them instead of being run again.
    """
    tol = tol or Tolerances()
    settings = {name: make_settings(check_engine(name), dt, overrides) for name in engines}  # validate all first
    start = time.perf_counter()
    feigin = simulate(scene, "feigin")
    feigin_time = time.perf_counter() - start
    exhaustive = simulate(scene, "exhaustive")
    ref_time = time.perf_counter() - start
    for ref_run in (feigin, exhaustive):  # no engine runs against a reference that did not finish
        if ref_run.status != "ok":
            raise SceneError(f"scene {scene.name!r}: the reference run stopped ({ref_run.status}, "
                             f"{ref_run.options.chatter} mode): {ref_run.message}")
    ref = reference_episodes(feigin, exhaustive, scene)
    e_max = _energy_max(scene, exhaustive)
    v_max = float(np.abs(exhaustive.log["v_minus"]).max()) if len(exhaustive.log) else abs(scene.initial.vy)
    runs, tables = {}, []
    for name in engines:
        run = run_one(scene, name, settings[name], e_max, v_max, tol, (trajectories or {}).get(name))
        runs[name] = run
        table = judge(scene, ref, run.episodes, run.log, run.t_diverged, run.t_penetrated, tol)
        if run.status in ("error", "timeout"):
            # episodes the run did not finish take the run's failure class
            t_end = float(run.trajectory.t[-1]) if len(run.trajectory.t) else -math.inf
            unfinished = table["ref_t_exit"].fillna(math.inf) > t_end
            table.loc[unfinished, "verdict"] = run.status
        table.insert(0, "dt", run.trajectory.dt if len(run.trajectory.t) > 1 else getattr(settings[name], "dt", math.nan))
        table.insert(0, "engine", name)
        table["status"] = run.status
        table["cost_per_sim_s"] = run.cost_per_sim_s
        tables.append(table)
    table = pd.concat(tables, ignore_index=True) if tables else pd.DataFrame(columns=COLUMNS)
    provenance = {
        "scene": scene.name,
        "scene_data": scene.to_dict(),
        "engines": {name: {"version": run.version, "settings": run.settings, "status": run.status,
                           "message": run.trajectory.message, "wall_time_s": run.wall_time} for name, run in runs.items()},
        # the reference's own cost is Feigin's model (the exhaustive chase is a cross-check)
        "reference": {"chatter_modes": ["feigin", "exhaustive"], "wall_time_s": ref_time,
                      "cost_per_sim_s": feigin_time / scene.duration},
        "tolerances": tol.__dict__,
        "machine": f"{platform.machine()} {platform.processor() or ''} {platform.system()} python {platform.python_version()}".strip(),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    return Comparison(scene=scene, table=table[COLUMNS], reference=ref, feigin=feigin, exhaustive=exhaustive, runs=runs, provenance=provenance)
