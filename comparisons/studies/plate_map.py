"""The sliding-plate map: which strikes on a wall end in sliding, by strike phase and speed.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.plate_map import plate_map
    >>> table = plate_map(load_scene("feigin-pair"), "lower", n_phase=12, n_speed=8)
    >>> int(table["reference"].sum()) > 0, bool((table["feigin"] <= table["reference"]).all())
    (True, True)

``outputs/plate_map_figure.py`` draws it.

For a grid of strikes (time t within one forcing period, incoming speed |y'|) on one wall:

- ``reference``: the true region, every impact followed to the accumulation point
  (``reference.chatter.strike_fates``, exhaustive mode, compiled);
- ``feigin``: Feigin's sufficient region (2.1)-(2.2) (``reference.simulate.in_plate``);
  for feigin-pair at R = 0.5 its boundary is the paper's 0.21 sin^2(tau);
- one column per engine: the engine started in free flight a little before the strike
  (the exact reference flight carried back by ``lead`` seconds) sticks on that wall,
  per the extraction's stick definition, before the run ends; the strikes go to the engine
  ``STRIKES_PER_BATCH`` at a time (MuJoCo Warp: the worlds of one model; MuJoCo: its
  compatible runs rolled out together; each run as it is alone).

Columns: t [s], phase [rad] (omega t mod 2 pi), speed [m/s] (|y'| at the strike),
reference, feigin, and each engine (bool).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from chatterbench.comparisons.pipeline.compare import engine_settings
from chatterbench.comparisons.pipeline.extract import extract_episodes
from chatterbench.engines.registry import run_engine, run_engine_batch
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.chatter import strike_fates
from chatterbench.reference.flow import Flow
from chatterbench.reference.linear import V1, VY, X1, Y, LinearSystem
from chatterbench.reference.scene import Scene, SceneError, scene_from_dict
from chatterbench.reference.simulate import in_plate


def strike_grid(scene: Scene, n_phase: int, n_speed: int, max_speed: float | None = None):
    """Strike times over one forcing period and speeds up to ``max_speed`` [m/s], as 2-D arrays.

    The default ``max_speed`` is the largest of Feigin's bound 5 (1 - R) / (24 R) |y''|^2 / Y
    over the period, times 2, so the map shows the sufficient region and well beyond it.
    """
    if n_phase < 2 or n_speed < 2:
        raise SceneError(f"plate map grid {n_phase} x {n_speed}: needs at least 2 phases and 2 speeds")
    T = scene.time_scale
    t = scene.initial.t + (np.arange(n_phase) + 0.5) * T / n_phase
    if max_speed is None:
        R = max(scene.restitution, 1e-3)
        system = LinearSystem.from_scene(scene)
        acc = np.array([system.accel_row @ system.state(tt, 0.0, 0.0, scene.gap.lower, 0.0) for tt in t])
        jerk_row = system.accel_row @ system.free
        jerk = np.array([jerk_row @ system.state(tt, 0.0, 0.0, scene.gap.lower, 0.0) for tt in t])
        Y = max(float(np.abs(jerk).max()), 1e-12)
        max_speed = 2.0 * 5.0 * (1.0 - R) / (24.0 * R) * float((acc**2).max()) / Y
        max_speed = max_speed if max_speed > 0 else 1.0
    speeds = np.linspace(max_speed / n_speed, max_speed, n_speed)
    return np.meshgrid(t, speeds, indexing="ij")


STRIKES_PER_BATCH = 256  # engine strikes handed over at once (MuJoCo Warp: one model of that many worlds)


def _strike_start(scene: Scene, wall: str, t_strike: float, v: float, lead: float, t_zeno: float) -> Scene:
    """The engine's run of one strike: started ``lead`` s before it (exact free flight back), run to its Zeno point
    (or a quarter period) and 5% of a period on."""
    system = LinearSystem.from_scene(scene)
    back = Flow(-system.free, horizon=scene.time_scale / 4.0)  # the same flow run backwards
    s = system.state(t_strike, 0.0, 0.0, scene.gap.position(wall), v)
    s0 = back.advance(s, lead)
    data = scene.to_dict()
    t0 = t_strike - lead
    horizon = (t_zeno - t_strike if math.isfinite(t_zeno) else 0.25 * scene.time_scale) + 0.05 * scene.time_scale
    data["initial"] = {"t": t0, "x1": float(s0[X1]), "v1": float(s0[V1]), "y": float(s0[Y]), "vy": float(s0[VY])}
    data["duration"] = lead + horizon
    lo, hi = scene.gap.lower, scene.gap.upper
    data["initial"]["y"] = min(max(data["initial"]["y"], lo), hi if hi is not None else math.inf)
    return scene_from_dict(data)


def _sticks(traj, start: Scene, wall: str, t_strike: float, lead: float) -> bool:
    """Whether the engine's run of a strike sticks on ``wall`` after it (the extraction's stick definition)."""
    if traj.status != "ok" or len(traj.t) < 2:
        return False
    eps = extract_episodes(traj, start)
    return bool(((eps["wall"] == wall) & (eps["t_stick"] >= t_strike - lead)).any())


def _engine_column(scene: Scene, wall: str, engine: str, settings, strikes: list[tuple[float, float, float]],
                   lead: float, progress: Callable[[str], None] | None) -> list[bool]:
    """Per strike (t, signed v, Zeno time), whether ``engine`` sticks; the runs handed over ``STRIKES_PER_BATCH`` at a
    time (``run_engine_batch``: MuJoCo Warp steps them as worlds of one model, each run as alone), one by one where a
    batch fails as a whole."""
    out = []
    for k in range(0, len(strikes), STRIKES_PER_BATCH):
        part = strikes[k:k + STRIKES_PER_BATCH]
        starts = [_strike_start(scene, wall, t, v, lead, tz) for t, v, tz in part]
        try:
            runs = run_engine_batch(engine, [(start, settings) for start in starts])
        except SettingsError:
            raise
        except Exception:  # noqa: BLE001  a batch that fails as a whole (a test fault): each run alone, classified
            runs = [run_engine(engine, start, settings) for start in starts]
        for (t, _, _), start, traj in zip(part, starts, runs):
            out.append(_sticks(traj, start, wall, t, lead))
            if progress is not None:
                progress(engine)
    return out


def plate_map(
    scene: Scene,
    wall: str = "lower",
    n_phase: int = 48,
    n_speed: int = 32,
    max_speed: float | None = None,
    engines: Sequence[str] = (),
    lead: float | None = None,
    progress: Callable[[str], None] | None = None,
    settings: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """Map which strikes on ``wall`` end in sliding (module docstring); one row per strike.

    ``progress``, when given, is called with the engine's name after each engine strike is run.
    ``settings``: engine name -> settings object (``registry.settings_for`` makes them from a timestep and text);
    engines without one run at their defaults.
    """
    made = engine_settings(engines, settings)  # every refusal before any run
    if wall not in scene.gap.walls:
        raise SceneError(f"wall = {wall!r}: must be one of {', '.join(scene.gap.walls)}")
    if not scene.forcing_omegas:  # strikes are placed by the phase of a forcing period
        raise SceneError(f"scene {scene.name!r} has no forcing (no harmonic force, no prescribed motion), so a strike "
                         "has no phase to map; a plate map needs a forced scene (feigin-pair, impact-damper)")
    T, S = strike_grid(scene, n_phase, n_speed, max_speed)
    sign = -1.0 if wall == "lower" else 1.0  # incoming y' points into the wall
    fates = strike_fates(scene, wall, T, sign * S)
    table = pd.DataFrame({
        "t": T.ravel(),
        "phase": np.mod(T.ravel() * (2 * math.pi / scene.time_scale), 2 * math.pi),
        "speed": S.ravel(),
        "reference": fates.slides.ravel(),
        "feigin": in_plate(scene, wall, T, sign * S).ravel(),
    })
    lead = lead if lead is not None else 0.02 * scene.time_scale
    strikes = [(float(t), sign * float(v), float(tz)) for t, v, tz in zip(T.ravel(), S.ravel(), fates.t_stick.ravel())]
    for name in engines:
        table[name] = _engine_column(scene, wall, name, made[name], strikes, lead, progress)
    return table
