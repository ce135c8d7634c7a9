"""Any simulator's trajectory, from a table (CSV, Parquet or a DataFrame), judged against the reference.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import judge_trajectory, reference_trajectory, trajectory_table
    >>> scene = load_scene("bouncing-ball")
    >>> table = trajectory_table(reference_trajectory(scene, dt=1e-3))     # or your engine's samples
    >>> judge_trajectory(scene, table, engine="mine").table["verdict"].tolist()
    ['match']

The table has one row per sample and the columns (``TRAJECTORY_COLUMNS``, the scene's
conventions of ``reference/scene.py``): ``t`` [s], ``x1``, ``x2`` [m] (positions of body 1
and body 2 along the axis; the gap is y = x2 - x1), ``v1``, ``v2`` [m/s], and optionally
``force_lower``, ``force_upper`` [N] (the magnitude of that wall's contact force on body 2,
>= 0). Samples may be unevenly spaced (the extraction takes each step as it comes and the
median spacing as the step dt of its rules). Without the force columns, contact is inferred
from the gap: a sample is in contact with a wall when y = x2 - x1 is on it or past it, to the
rounding of that subtraction (``on_wall``; rule 1 of ``extract.py``); ``Judged.contact`` and
the command's output say which rule was used.

Refused (``TrajectoryError``, one line naming the column or row): a missing column, a
value that is not a number, times that do not increase strictly, a NaN or inf before the
last rows, fewer than two samples. Non-finite values in the last rows only end the run
there: it is judged as ``diverged`` from that time (a blow-up, not bad input).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene, load_scene

from .compare import Comparison, EngineRun, COLUMNS
from .extract import ExtractionOptions, extract
from .judge import judge
from .solution import ReferenceSolution, solve
from .tolerances import Tolerances

REQUIRED = ("t", "x1", "x2", "v1", "v2")
FORCES = {"lower": "force_lower", "upper": "force_upper"}
TRAJECTORY_COLUMNS = [*REQUIRED, *FORCES.values()]
CONTACT_FROM_FORCE = "contact from the force columns (force > 0)"
CONTACT_FROM_GAP = "contact inferred from the gap (no force columns): a sample on or past a wall is in contact"
ROUNDING = 16.0  # [ulp] y = x2 - x1 within this many roundings of a wall is on it


class TrajectoryError(InputError):
    """A trajectory table that cannot be judged; the message names the column or row and what is allowed."""


@dataclass(frozen=True)
class Judged:
    """A read trajectory and how its contact was taken (``CONTACT_FROM_FORCE`` or ``CONTACT_FROM_GAP``)."""

    trajectory: Trajectory
    contact: str
    source: str  # the file, or "table"


def read_table(source: str | Path | pd.DataFrame) -> tuple[pd.DataFrame, str]:
    """The table and its name: a DataFrame as is, a ``.parquet`` file, else CSV."""
    if isinstance(source, pd.DataFrame):
        return source, "table"
    path = Path(source)
    if not path.is_file():
        raise TrajectoryError(f"trajectory {str(path)!r}: no such file")
    try:
        frame = pd.read_parquet(path) if path.suffix.lower() in (".parquet", ".pq") else pd.read_csv(path)
    except Exception as exc:  # a parser's own error, in one line
        raise TrajectoryError(f"trajectory {str(path)!r}: cannot be read as "
                              f"{'Parquet' if path.suffix.lower() in ('.parquet', '.pq') else 'CSV'}: "
                              f"{type(exc).__name__}: {exc}") from None
    return frame, str(path)


def read_trajectory(source: str | Path | pd.DataFrame, scene: Scene, engine: str = "engine") -> Judged:
    """Check a trajectory table (module docstring) and make it a ``Trajectory`` of ``engine``."""
    frame, name = read_table(source)
    where = f"trajectory {name!r}" if name != "table" else "trajectory"
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise TrajectoryError(f"{where}: missing column {missing[0]!r}; needed: {', '.join(REQUIRED)} "
                              f"(optional: {', '.join(FORCES.values())}); found: {', '.join(map(str, frame.columns))}")
    walls = [w for w in scene.gap.walls if FORCES[w] in frame.columns]
    columns = [*REQUIRED, *(FORCES[w] for w in walls)]
    data = {}
    for c in columns:
        values = pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float)
        text = frame[c].notna().to_numpy() & np.isnan(values)
        if text.any():
            k = int(np.argmax(text))
            raise TrajectoryError(f"{where}: column {c!r}, row {k}: {frame[c].iloc[k]!r} is not a number")
        data[c] = values
    n = len(frame)
    if n < 2:
        raise TrajectoryError(f"{where}: {n} rows; at least 2 samples are needed")
    bad = ~np.all([np.isfinite(data[c]) for c in columns], axis=0)
    # a run that blew up ends in non-finite rows: judged diverged from there; one before the end is bad input
    last_good = n - int(np.argmax(~bad[::-1])) if not bad.all() else 0
    if bad[:last_good].any():
        k = int(np.argmax(bad[:last_good]))
        c = next(c for c in columns if not np.isfinite(data[c][k]))
        raise TrajectoryError(f"{where}: column {c!r}, row {k}: {data[c][k]!r} before the end of the run "
                              f"(only the last rows may be non-finite: a run that blew up)")
    if last_good < 2:
        raise TrajectoryError(f"{where}: fewer than 2 finite samples")
    t = data["t"][:last_good]
    step = np.diff(t)
    if not (step > 0).all():
        k = int(np.argmax(~(step > 0))) + 1
        raise TrajectoryError(f"{where}: column 't', row {k}: {t[k]!r} after {t[k - 1]!r}; times must increase strictly")
    cut = {c: data[c][:last_good] for c in columns}
    forces = {w: np.maximum(cut[FORCES[w]], 0.0) for w in walls}
    contact = {**on_wall(scene, cut["x1"], cut["x2"]), **{w: f > 0 for w, f in forces.items()}}
    status, message = ("diverged", f"non-finite values from row {last_good} (t after {t[-1]:.9g} s)") \
        if last_good < n else ("ok", "")
    traj = Trajectory(engine=engine, t=t, x1=cut["x1"], x2=cut["x2"], v1=cut["v1"], v2=cut["v2"],
                      contact=contact, normal_force=forces, wall_time=0.0,
                      settings={"dt": float(np.median(step)), "source": name}, status=status, message=message)
    gap_walls = [w for w in scene.gap.walls if w not in walls]
    how = (CONTACT_FROM_GAP if not walls else CONTACT_FROM_FORCE if not gap_walls else
           f"{CONTACT_FROM_FORCE} on the {' and '.join(walls)} wall; {CONTACT_FROM_GAP.split(' (')[0]} on the "
           f"{' and '.join(gap_walls)} wall (no {', '.join(FORCES[w] for w in gap_walls)} column)")
    return Judged(traj, how, name)


def on_wall(scene: Scene, x1: np.ndarray, x2: np.ndarray) -> dict[str, np.ndarray]:
    """Contact inferred from the gap, per wall: y = x2 - x1 on the wall or past it, to the rounding of the
    subtraction (``ROUNDING`` x the machine epsilon x the largest of |x1|, |x2| and |wall|): a body resting
    on a wall whose positions went through a file is on it, not 1e-17 m above it."""
    out = {}
    for wall in scene.gap.walls:
        y_wall = scene.gap.position(wall)
        slack = ROUNDING * np.finfo(float).eps * np.maximum(np.maximum(np.abs(x1), np.abs(x2)), abs(y_wall))
        d = (x2 - x1 - y_wall) * (1.0 if wall == "lower" else -1.0)
        out[wall] = d <= slack
    return out


def trajectory_table(traj: Trajectory) -> pd.DataFrame:
    """A ``Trajectory`` as the table ``read_trajectory`` reads (``TRAJECTORY_COLUMNS``; force columns
    for the walls whose force the trajectory carries): what any engine's adapter or script writes."""
    table = pd.DataFrame({"t": traj.t, "x1": traj.x1, "x2": traj.x2, "v1": traj.v1, "v2": traj.v2})
    for wall, force in (traj.normal_force or {}).items():
        if force is not None and len(force) == len(traj.t):
            table[FORCES[wall]] = np.asarray(force, dtype=float)
    return table


def judge_trajectory(scene: Scene | str | Path, table_or_path: str | Path | pd.DataFrame, engine: str = "engine",
                     tol: Tolerances | None = None, solution: ReferenceSolution | None = None,
                     options: ExtractionOptions | None = None, version: str = "") -> Comparison:
    """Judge one trajectory table against the reference of ``scene`` (a Scene, a built-in name or a TOML path).

    Returns the ``compare.Comparison`` that ``compare`` would for a built-in engine: the same
    table (``compare.COLUMNS``; ``dt`` is the median spacing, cost NaN), impacts, summary and
    files (``outputs.comparison_files.write_comparison``); ``provenance["trajectory"]`` names the
    source and the contact rule used. Raises ``TrajectoryError`` for a table that cannot be judged.
    """
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    tol = tol or Tolerances()
    read = read_trajectory(table_or_path, scene, engine)
    traj = read.trajectory
    ref = solution if solution is not None else solve(scene)
    found = extract(traj, scene, ref.stick_tolerance(tol.stick), options)
    judged = judge(ref, found, traj, tol)
    run = EngineRun(engine=engine, settings=dict(traj.settings), trajectory=traj, found=found, wall_time=math.nan,
                    version=version, t_diverged=judged.t_diverged, t_penetrated=judged.t_penetrated)
    table = judged.table
    table.insert(0, "dt", traj.settings["dt"])
    table.insert(0, "engine", engine)
    table["status"] = traj.status
    table["cost_per_sim_s"] = math.nan  # a file says nothing of what it cost
    impacts = judged.impacts.assign(engine=engine)
    provenance: dict[str, Any] = {
        "scene": scene.name, "scene_data": scene.to_dict(),
        "engines": {engine: {"version": version, "settings": run.settings, "status": traj.status,
                             "message": traj.message, "wall_time_s": math.nan}},
        "trajectory": {"source": read.source, "samples": int(len(traj.t)), "contact": read.contact},
        "tolerances": tol.as_dict(),
    }
    return Comparison(scene=scene, table=table[COLUMNS], solution=ref, tolerances=tol,
                      impacts=impacts[["engine", *judged.impacts.columns]], runs={engine: run}, provenance=provenance)
