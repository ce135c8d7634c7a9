"""One engine run from the command line: settings, trajectory, recovered events and episodes.

    >>> log, episodes, summary = run_engine_events(scene, "mujoco", dt=1e-4, overrides=[], export_model=None)

The event log is recovered from the trajectory by ``pipeline/extract.py`` with the same
resolution ``compare`` uses (the tightest sticking tolerance of the scene's reference
visits), and has the reference's format, so the same episode table describes the engine's run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import pandas as pd

from chatterbench.engines.registry import adapter, make_settings, run_engine
from chatterbench.reference.log import episodes, log_frame
from chatterbench.reference.scene import Scene

from .atomic import write_text
from .pipeline.extract import extract_events
from .pipeline.solution import solve
from .pipeline.tolerances import Tolerances


def run_engine_events(
    scene: Scene, engine: str, dt: float | None, overrides: Sequence[str], export_model: str | None
) -> tuple[pd.DataFrame, pd.DataFrame, str]:
    """Run ``scene`` in ``engine``; returns (event log, episodes, one-line summary)."""
    settings = make_settings(engine, dt, overrides)
    if export_model:
        if engine != "mujoco":
            from .cli import UsageError

            raise UsageError("--export-model: only MuJoCo models can be exported (use --engine mujoco)")
        write_text(Path(export_model), adapter("mujoco").snippet(scene, settings))
    resolution = solve(scene).stick_tolerance(Tolerances().stick)
    traj = run_engine(engine, scene, settings)
    log = extract_events(traj, scene, resolution) if len(traj.t) > 1 else log_frame([])
    n_imp = int((log["kind"] == "impact").sum())
    summary = (f"{engine} dt={settings.dt:g} s: status {traj.status}{' (' + traj.message + ')' if traj.message else ''}, "
               f"{len(traj.t)} samples, {n_imp} impacts, {traj.wall_time:.3f} s stepping")
    if export_model:
        summary += f"; MJCF written to {export_model}"
    return log, episodes(log), summary
