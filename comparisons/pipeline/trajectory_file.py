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
``force_lower``, ``force_upper`` [N]: that wall's contact force on body 2 along the wall's
normal, signed, compressive positive (the wall pushes body 2 into the gap); 0 where the wall
does not touch it. A negative force is a wall that pulls: no unilateral contact does, but it
is data, not clipped: the wall holds body 2 (contact) and the output says when and how long
it pulled. Samples may be unevenly spaced (the extraction takes each step as it comes and
the median spacing as the step dt of its rules). Without the force columns, contact is
inferred from the gap (``gap_contact.py``: a sample on a wall or past it, to the rounding of
the positions' precision, declared or inferred); a resting offset (a contact skin, a steady
penetration) is measured and reported in every case. ``Judged.contact`` and the command's
output say which rule was used; where the force columns and the gap alone would give other
verdicts, one line says so and why (``gap_difference``).

Refused (``TrajectoryError``, one line naming the column and the row as a user counts it:
the first data row is row 1, on line 2 of a CSV): a missing column, a cell that is not a
number (its text shown), times that do not increase strictly or leave the scene's time span,
a NaN or inf before the last rows, fewer than two samples, a body 1 that the scene fixes or
prescribes moving elsewhere, a first sample away from the scene's state at that time (``check_start``: each by more
than the penetration allowance; a contact skin of millimetres passes). Non-finite values in the
last rows only end the run there: it is judged as ``diverged`` from that time (a blow-up, not
bad input). Files are read bounded and by kind (``table_file.py``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.dense import sample
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene, load_scene

from .compare import COLUMNS, Comparison, EngineRun
from .extract import extract, free_relative_acceleration
from .extract_options import ExtractionOptions
from .gap_contact import PRECISIONS, ROUNDING, infer_precision, on_wall, resting_offsets, rounding
from .judge import judge
from .solution import ReferenceSolution, solve
from .table_file import TableFile, TableFileError, read_table_file
from .tolerances import Tolerances
from .vocabulary import combine

REQUIRED = ("t", "x1", "x2", "v1", "v2")
FORCES = {"lower": "force_lower", "upper": "force_upper"}
TRAJECTORY_COLUMNS = [*REQUIRED, *FORCES.values()]
CONTACT_FROM_FORCE = "contact from the force columns (force != 0)"
CONTACT_FROM_GAP = "contact inferred from the gap (no force columns): a sample on or past a wall is in contact"


class TrajectoryError(InputError):
    """A trajectory table that cannot be judged; the message names the column or row and what is allowed."""


@dataclass(frozen=True)
class Judged:
    """A read trajectory, how its contact was taken (``CONTACT_FROM_FORCE`` or ``CONTACT_FROM_GAP``), its
    positions' precision (``float64``, ``float32``) and how it was known, and the facts worth a line each."""

    trajectory: Trajectory
    contact: str
    source: str  # the file, or "table"
    precision: str = "float64"
    precision_from: str = "inferred"  # or "declared"
    offsets: dict = field(default_factory=dict)  # wall -> gap_contact.RestingOffset
    notes: tuple[str, ...] = ()  # one line each: resting offsets, a wall that pulls


def read_table(source: str | Path | pd.DataFrame) -> TableFile:
    """The table and its name: a DataFrame as is, a ``.parquet`` file, else CSV (``table_file.py``)."""
    if isinstance(source, pd.DataFrame):
        return TableFile(source, "table", csv=False)
    try:
        return read_table_file(source, TRAJECTORY_COLUMNS)
    except TableFileError as exc:
        raise TrajectoryError(str(exc)) from None


def _row(table: TableFile, k: int) -> str:
    """Sample ``k`` (0-based) as a user finds it: "row 6 (line 7)" of a CSV, the index label of a DataFrame."""
    if table.source == "table":
        return f"row {table.frame.index[k]!r}"
    return table.row(k)


def _numbers(table: TableFile, columns: list[str], where: str) -> dict[str, np.ndarray]:
    """Each column as floats; a cell that is not a number (text, "n/a") refused with its text."""
    data = {}
    for c in columns:
        raw = table.frame[c]
        # true/false is no number: pandas reads a CSV column of "True"/"False" as booleans, which to_numeric makes 1/0
        truth = (np.ones(len(raw), dtype=bool) if pd.api.types.is_bool_dtype(raw) else
                 raw.map(lambda v: isinstance(v, (bool, np.bool_))).to_numpy(dtype=bool) if raw.dtype == object else
                 np.zeros(len(raw), dtype=bool))
        values = np.where(truth, np.nan, pd.to_numeric(raw.where(~truth), errors="coerce").to_numpy(dtype=float))
        text = raw.notna().to_numpy() & np.isnan(values)
        if text.any():
            k = int(np.argmax(text))
            raise TrajectoryError(f"{where}: column {c!r}, {_row(table, k)}: {str(raw.iloc[k])[:40]!r} is not a number")
        data[c] = values
    return data


def _times(t: np.ndarray, scene: Scene, table: TableFile, where: str) -> None:
    """Times that increase strictly, inside the scene's span (a step's slack at each end, at most the duration)."""
    step = np.diff(t)
    if not (step > 0).all():
        k = int(np.argmax(~(step > 0))) + 1
        raise TrajectoryError(f"{where}: column 't', {_row(table, k)}: {float(t[k])!r} after {float(t[k - 1])!r}; "
                              "times must increase strictly")
    t0, t1 = scene.initial.t, scene.t_end
    slack = min(max(float(np.median(step)), 1e-9 * max(1.0, abs(t1))), scene.duration)  # a last step past the end
    out = (t < t0 - slack) | (t > t1 + slack)
    if out.any():
        k = int(np.argmax(out))
        raise TrajectoryError(f"{where}: column 't', {_row(table, k)}: {float(t[k]):.6g} s is outside the scene's time, "
                              f"{t0:g} to {t1:g} s (initial.t to initial.t + duration); times are in seconds")


def _walls(frame: pd.DataFrame, scene: Scene, where: str) -> list[str]:
    """The walls with a force column, after refusing a table that misses a required column."""
    found = [str(c) for c in frame.attrs.get("columns", frame.columns)]
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise TrajectoryError(f"{where}: missing column {missing[0]!r}; needed: {', '.join(REQUIRED)} "
                              f"(optional: {', '.join(FORCES.values())}); found: {', '.join(found)[:300]}")
    return [w for w in scene.gap.walls if FORCES[w] in frame.columns]


def _finite_rows(table: TableFile, data: dict[str, np.ndarray], where: str) -> int:
    """How many rows from the start are finite: only the last rows may be non-finite (a run that blew up)."""
    n = len(table.frame)
    if n < 2:
        raise TrajectoryError(f"{where}: {n} rows; at least 2 samples are needed")
    empty = next((c for c, v in data.items() if not np.isfinite(v).any()), None)
    if empty is not None:
        raise TrajectoryError(f"{where}: column {empty!r} has no finite value in any of its {n} rows")
    bad = ~np.all([np.isfinite(v) for v in data.values()], axis=0)
    last_good = n - int(np.argmax(~bad[::-1])) if not bad.all() else 0
    if bad[:last_good].any():
        k = int(np.argmax(bad[:last_good]))
        c = next(c for c, v in data.items() if not np.isfinite(v[k]))
        raise TrajectoryError(f"{where}: column {c!r}, {_row(table, k)}: {float(data[c][k])!r} before the end of the "
                              "run (only the last rows may be non-finite: a run that blew up)")
    if last_good < 2:
        raise TrajectoryError(f"{where}: fewer than 2 finite samples")
    return last_good


def read_trajectory(source: str | Path | pd.DataFrame, scene: Scene, engine: str = "engine",
                    precision: str | None = None) -> Judged:
    """Check a trajectory table (module docstring) and make it a ``Trajectory`` of ``engine``.

    ``precision``: ``float64`` or ``float32``, the positions' floating-point type; None: inferred.
    """
    if precision is not None and precision not in PRECISIONS:
        raise TrajectoryError(f"precision {precision!r}: must be one of {', '.join(PRECISIONS)}")
    table = read_table(source)
    where = f"trajectory {table.source}" if table.source != "table" else "trajectory"
    walls = _walls(table.frame, scene, where)
    data = _numbers(table, [*REQUIRED, *(FORCES[w] for w in walls)], where)
    last_good = _finite_rows(table, data, where)
    cut = {c: v[:last_good] for c, v in data.items()}
    t, x1, x2, v1, v2 = (cut[c] for c in REQUIRED)
    _times(t, scene, table, where)
    chosen = precision or infer_precision(x1, x2)
    forces = {w: cut[FORCES[w]] for w in walls}  # signed: a pulling wall (< 0) is data, not clipped
    acc = free_relative_acceleration(scene, t, x1, v1, x2 - x1, v2 - v1)
    rests = resting_offsets(scene, t, x2 - x1, v2 - v1, acc, rounding(chosen, x1, x2))
    contact = {**on_wall(scene, x1, x2, v1, v2, chosen, rests), **{w: f != 0 for w, f in forces.items()}}
    status, message = ("diverged", f"non-finite values from {_row(table, last_good)} (t after {t[-1]:.9g} s)") \
        if last_good < len(table.frame) else ("ok", "")
    traj = Trajectory(engine=engine, t=t, x1=x1, x2=x2, v1=v1, v2=v2, contact=contact, normal_force=forces,
                      wall_time=0.0, settings={"dt": float(np.median(np.diff(t))), "source": table.source,
                                               "precision": chosen}, status=status, message=message)
    gap_walls = [w for w in scene.gap.walls if w not in walls]
    how = (CONTACT_FROM_GAP if not walls else CONTACT_FROM_FORCE if not gap_walls else
           f"{CONTACT_FROM_FORCE} on the {' and '.join(walls)} wall; {CONTACT_FROM_GAP.split(' (')[0]} on the "
           f"{' and '.join(gap_walls)} wall (no {', '.join(FORCES[w] for w in gap_walls)} column)")
    notes = [r.describe() for r in rests.values()] + [_pulling(w, t, f) for w, f in forces.items() if (f < 0).any()]
    return Judged(traj, how, table.source, chosen, "declared" if precision else "inferred", rests, tuple(notes))


def _pulling(wall: str, t: np.ndarray, force: np.ndarray) -> str:
    """One line: where a wall pulled body 2 (a negative force), which no unilateral contact does."""
    pull = force < 0
    k = int(np.argmax(pull))
    steps = np.diff(t, append=t[-1])
    return (f"the {wall} wall pulls body 2 ({FORCES[wall]} < 0, down to {float(force.min()):.3g} N) at {int(pull.sum())} "
            f"samples from t = {float(t[k]):.6g} s, {float(steps[pull].sum()):.3g} s in all: a contact that pulls is "
            "none of Feigin's; judged as contact (the wall holds body 2)")


def trajectory_table(traj: Trajectory) -> pd.DataFrame:
    """A ``Trajectory`` as the table ``read_trajectory`` reads (``TRAJECTORY_COLUMNS``; force columns
    for the walls whose force the trajectory carries): what any engine's adapter or script writes."""
    table = pd.DataFrame({"t": traj.t, "x1": traj.x1, "x2": traj.x2, "v1": traj.v1, "v2": traj.v2})
    for wall, force in (traj.normal_force or {}).items():
        if force is not None and len(force) == len(traj.t):
            table[FORCES[wall]] = np.asarray(force, dtype=float)
    return table


def check_body1(scene: Scene, traj: Trajectory, allowance: float, where: str = "trajectory") -> None:
    """A body 1 the scene fixes or prescribes must be where the scene puts it, to ``allowance`` [m]."""
    if not scene.body1_infinite:
        return
    t = np.asarray(traj.t, dtype=float)
    expected = scene.prescribed.position(t) if scene.prescribed is not None else np.full(len(t), scene.initial.x1)
    off = np.abs(np.asarray(traj.x1, dtype=float) - expected)
    if (off > allowance).any():
        k = int(np.argmax(off > allowance))
        kind = "prescribes body 1's motion" if scene.prescribed is not None else f"fixes body 1 at x1 = {scene.initial.x1:g} m"
        raise TrajectoryError(f"{where}: column 'x1': the scene {kind}, but the file's x1 is {float(traj.x1[k]):.6g} m at "
                              f"t = {float(traj.t[k]):.6g} s, {float(off[k]):.3g} m away (up to {float(off.max()):.3g} m; "
                              f"allowed: the penetration allowance, {allowance:.3g} m): it did not run this scene")


def check_start(ref: ReferenceSolution, traj: Trajectory, allowance: float, where: str = "trajectory") -> None:
    """The file's first sample where the scene's reference is at that time: y = x2 - x1 (and x1 where body 1 moves
    under forces) within ``allowance`` [m], the penetration allowance: a contact skin (millimetres) passes, a file
    that started elsewhere (the ball 300 mm higher) did not run this scene."""
    scene, t0 = ref.scene, float(traj.t[0])
    at = sample(scene, ref.exhaustive.log, [t0]).iloc[0]
    x1, x2 = float(traj.x1[0]), float(traj.x2[0])
    pairs = [("y = x2 - x1", x2 - x1, float(at["y"]))]
    if not scene.body1_infinite:  # a fixed or prescribed body 1 is check_body1's
        pairs.append(("x1", x1, float(at["x1"])))
    for name, got, want in pairs:
        if math.isfinite(allowance) and math.isfinite(got) and not abs(got - want) <= allowance:
            raise TrajectoryError(f"{where}: the first sample, t = {t0:.6g} s, has {name} = {got:.6g} m where the scene's "
                                  f"run has {want:.6g} m, {abs(got - want):.3g} m away (allowed: the penetration "
                                  f"allowance, {allowance:.3g} m): it did not run this scene")


def judge_trajectory(scene: Scene | str | Path, table_or_path: str | Path | pd.DataFrame, engine: str = "engine",
                     tol: Tolerances | None = None, solution: ReferenceSolution | None = None,
                     options: ExtractionOptions | None = None, version: str = "",
                     precision: str | None = None) -> Comparison:
    """Judge one trajectory table against the reference of ``scene`` (a Scene, a built-in name or a TOML path).

    Returns the ``compare.Comparison`` that ``compare`` would for a built-in engine: the same
    table (``compare.COLUMNS``; ``dt`` is the median spacing, cost NaN), impacts, summary and
    files (``outputs.comparison_files.write_comparison``); ``provenance["trajectory"]`` names the
    source, the contact rule, the precision and ``notes`` (a line each). ``precision``: the
    positions' ``float64`` or ``float32`` (None: inferred). Raises ``TrajectoryError`` for a
    table that cannot be judged.
    """
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    tol = tol or Tolerances()
    read = read_trajectory(table_or_path, scene, engine, precision)
    traj = read.trajectory
    ref = solution if solution is not None else solve(scene)
    where = "trajectory" if read.source == "table" else f"trajectory {read.source}"
    check_body1(scene, traj, tol.penetration * ref.length_scale, where)
    check_start(ref, traj, tol.penetration * ref.length_scale, where)
    options = options or ExtractionOptions(
        jump_atol=max(ExtractionOptions().jump_atol, float(np.max(rounding(read.precision, traj.v1, traj.v2)))),
        position_rounding=float(np.max(rounding(read.precision, traj.x1, traj.x2))) / ROUNDING)
    skins = {w: r.offset for w, r in read.offsets.items() if r.skin}
    found = extract(traj, scene, ref.stick_tolerance(tol.stick), options, skins)
    judged = judge(ref, found, traj, tol)
    notes = [*read.notes, *gap_difference(read, ref, tol, options, skins, judged.table)]
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
        "trajectory": {"source": read.source, "samples": int(len(traj.t)), "contact": read.contact,
                       "precision": read.precision, "precision_from": read.precision_from, "notes": notes,
                       "resting_offsets_m": {w: r.offset for w, r in read.offsets.items()}},
        "tolerances": tol.as_dict(),
    }
    return Comparison(scene=scene, table=table[COLUMNS], solution=ref, tolerances=tol,
                      impacts=impacts[["engine", *judged.impacts.columns]], runs={engine: run}, provenance=provenance)


def gap_difference(read: Judged, ref: ReferenceSolution, tol: Tolerances, options: ExtractionOptions,
                   skins: dict[str, float], table: pd.DataFrame) -> list[str]:
    """One line when the gap alone would judge a file with force columns otherwise (``[]`` when it agrees)."""
    traj = read.trajectory
    if not traj.normal_force:
        return []
    scene = ref.scene
    gap = on_wall(scene, traj.x1, traj.x2, traj.v1, traj.v2, read.precision, read.offsets)
    plain = dataclasses.replace(traj, contact=gap, normal_force={})
    other = judge(ref, extract(plain, scene, ref.stick_tolerance(tol.stick), options, skins), plain, tol).table
    if other["verdict"].tolist() == table["verdict"].tolist():
        return []
    differ = [(a, b) for a, b in zip(table.itertuples(), other.itertuples()) if a.verdict != b.verdict]
    a, b = differ[0] if differ else (None, None)
    where = f" ({a.wall} episode at {a.ref_t_stick:.4g} s: {b.verdict}, {b.reason or 'within tolerance'})" if a else ""
    return [f"from the force columns: {combine(table['verdict'])}; from the gap alone it would be "
            f"{combine(other['verdict'])}{where}: the force and the positions disagree on when body 2 touches the wall"]
