"""Sweeps: one scene, some engines, a grid of scene fields and engine settings -> one row per run.

    >>> sweep = load_sweep("examples/sweeps/bouncing-ball-dt.toml")
    >>> rows = run_sweep(sweep, Path("out/bb"), workers=4)        # or executor=client.get_executor()
    >>> rows.groupby(["engine", "dt"])["verdict"].value_counts()

Spec file (TOML)::

    scene = "feigin-pair"              # built-in scene, or a scene TOML path (relative to this file)
    engines = ["mujoco", "pybullet"]   # default: both
    timeout = 120                      # [s] wall-clock limit of one run (one engine at one point)
    description = "free text"          # optional

    [set]                              # fixed for every point
    duration = 18.85

    [grid]                             # cartesian product of these lists (last key varies fastest)
    dt = [1e-4, 3e-4]
    restitution = [0.3, 0.5, 0.8]
    mujoco.w0_dt = [0.03, 0.1]
    pybullet.restitution_velocity_threshold = [0.0, 0.2]

    [[points]]                         # explicit points, run after the grid's (each merged over [set])
    dt = 1e-3
    initial.t = 1.0

    [tolerances]                       # verdict tolerances (pipeline.tolerances.Tolerances), optional
    exit = 0.02                        # (--tolerance KEY=VALUE on the command line sets them too)

Keys in ``[set]``, ``[grid]`` and ``[[points]]`` are the dotted keys of ``--set``: ``dt`` is
the engine timestep [s] (every engine); ``mujoco.KEY`` / ``pybullet.KEY`` are that engine's
settings and apply to that engine only; every other key is a scene override
(``restitution``, ``mass2``, ``gap.upper``, ``initial.t``, ``forces.0.amplitude``). A key is
either fixed (``[set]``) or varied (``[grid]``/``[[points]]``), never both. Grid values are
non-empty arrays of one kind (numbers, strings or booleans; integers mixed with floats
become floats). At least one of ``[grid]`` and ``[[points]]`` is required.

The unit of work is a *run*: one engine at one point. A run's parameters are the point's
keys minus the other engines' settings, so a pybullet run does not repeat for every value
of ``mujoco.w0_dt`` (identical runs are run once). Each run yields one row of
``pipeline.summary.ROW_COLUMNS`` (one column per parameter, named by its dotted key).

Promises:

- The whole spec is checked before any engine starts: unknown or misplaced keys, wrong
  types, empty grids and every point's scene and settings; a refusal is one ``SpecError``
  (a ``SceneError``) naming the file, the key, the value and what is allowed.
- Every run goes through ``isolate.run_isolated`` inside the function submitted to the
  executor, so under a local process pool and under Dask alike a run that segfaults is a
  ``crashed`` row, one past the timeout a ``timeout`` row, one that raises an ``error``
  row, and the sweep goes on.
- Runs go to workers in units of a few runs of one engine, each unit in one isolated child
  (``work_units``); MuJoCo runs of a unit share dt and duration, and those whose models are
  compatible go through one ``mujoco.rollout`` call (a list of models: restitution,
  masses, gap, initial state, forcing, w0 dt, solver options may all differ). The rows
  are the same as run one by one, bit for bit; a unit that does not come back whole is
  rerun one run at a time, so a faulty run is still classified alone.
- Rows reach ``OUT/rows/part-*.parquet`` as runs finish, each part written atomically. A
  sweep killed at any moment and resumed (``resume=True``) ends with exactly the rows of an
  uninterrupted one: finished rows are never re-run, unfinished runs are run once.

Layout of OUT: ``sweep.toml`` (the resolved spec, written first), ``rows/`` (the Parquet
dataset, one part per batch of finished runs), ``rows.parquet`` (all rows in run order,
written at the end).
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
import sys
import threading
import time
import tomllib
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import pandas as pd

from chatterbench.engines.registry import ENGINE_NAMES, can_batch, engine_version, make_settings, run_engine_batch
from chatterbench.reference.errors import InputError
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import SceneError, did_you_mean, load_scene

from .atomic import write_frame, write_text
from .isolate import die_with_parent, run_isolated
from .pipeline.summary import METRIC_COLUMNS, ROW_COLUMNS, failure_row, mass_ratio, point_id
from .pipeline.tolerances import make_tolerances

SPEC_KEYS = ("scene", "engines", "timeout", "description", "set", "grid", "points", "tolerances")
DEFAULT_TIMEOUT = 120.0  # [s] per run
FAILED = ("crashed", "timeout", "error")  # run statuses counted as failures by the progress bar (a sweep's isolation)
_FLOAT_COLUMNS = ("dt", "mass_ratio", *METRIC_COLUMNS, "cost_per_sim_s", "reference_cost_per_sim_s", "wall_time_s")
_INT_COLUMNS = ("n_episodes", "n_match")
_MESSAGE_CHARS = 4000  # a failure row keeps the end of a traceback, where the cause is


class SpecError(InputError):
    """A sweep spec is malformed or names something not allowed; the message says where."""


# -- the spec ------------------------------------------------------------------------

def _kind(value: Any) -> str | None:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, (int, float)):
        return "number"
    if isinstance(value, str):
        return "string"
    return None


def _key_role(key: str) -> str:
    """``dt``, an engine name (engine setting) or ``scene`` (scene override)."""
    if key == "dt":
        return "dt"
    head = key.split(".")[0]
    return head if head in ENGINE_NAMES else "scene"


@dataclass(frozen=True)
class RunTask:
    """One engine at one point: everything a worker needs, as plain picklable data."""

    index: int  # position in the sweep's run order
    point_id: str  # rows.point_id(scene name, engine, params)
    scene: str  # built-in scene name or absolute path of a scene TOML file
    scene_name: str
    engine: str
    params: tuple[tuple[str, Any], ...]  # the row's parameter columns, in spec order
    dt: float  # [s] the engine timestep the run uses
    timeout: float  # [s]
    tolerances: tuple[tuple[str, Any], ...] = ()

    def scene_overrides(self) -> dict[str, Any]:
        return {k: v for k, v in self.params if _key_role(k) == "scene"}

    def engine_overrides(self) -> dict[str, Any]:
        return {k: v for k, v in self.params if _key_role(k) == self.engine}


@dataclass(frozen=True)
class Sweep:
    """A validated sweep (see the module docstring for the meaning of each part)."""

    scene: str  # built-in scene name or path of a scene TOML file
    engines: tuple[str, ...] = ENGINE_NAMES
    fixed: Mapping[str, Any] = field(default_factory=dict)  # [set]: dotted key -> value
    grid: Mapping[str, tuple] = field(default_factory=dict)  # [grid]: dotted key -> values
    points: tuple[Mapping[str, Any], ...] = ()  # [[points]]
    timeout: float = DEFAULT_TIMEOUT  # [s] per run, > 0
    tolerances: Mapping[str, Any] = field(default_factory=dict)  # pipeline.tolerances.Tolerances fields
    description: str = ""
    source: str = ""  # the spec file, for messages ("" when built in Python)

    def __post_init__(self) -> None:
        _validate(self)

    def fail(self, message: str) -> SpecError:
        """A SpecError naming this sweep's file."""
        where = f"sweep spec {self.source!r}" if self.source else "sweep"
        return SpecError(f"{where}: {message}")

    @property
    def scene_name(self) -> str:
        return load_scene(self.scene, {}).name

    def to_toml(self) -> str:
        """The resolved spec as TOML (``load_sweep`` reads it back to an equal Sweep)."""
        lines = [f"scene = {_toml(self.scene)}", f"engines = {_toml(list(self.engines))}",
                 f"timeout = {_toml(self.timeout)}"]
        if self.description:
            lines.append(f"description = {_toml(self.description)}")
        for name, table in (("set", self.fixed), ("grid", {k: list(v) for k, v in self.grid.items()}),
                            ("tolerances", self.tolerances)):
            if table:
                lines += ["", f"[{name}]"] + [f"{_toml(k)} = {_toml(v)}" for k, v in table.items()]
        for p in self.points:
            lines += ["", "[[points]]"] + [f"{_toml(k)} = {_toml(v)}" for k, v in p.items()]
        return "\n".join(lines) + "\n"

    def identity(self) -> dict[str, Any]:
        """What decides the rows (everything but timeout, description and source)."""
        return {"scene": self.scene, "engines": list(self.engines), "set": dict(self.fixed),
                "grid": {k: list(v) for k, v in self.grid.items()}, "points": [dict(p) for p in self.points],
                "tolerances": dict(self.tolerances)}


def _toml(value: Any) -> str:
    """A TOML literal for a scalar, a string key or an array of scalars."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # JSON's escapes are TOML basic-string escapes
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    raise TypeError(f"no TOML form for {value!r}")


def _flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested TOML tables (``mujoco.w0_dt = ...`` parses as {"mujoco": {"w0_dt": ...}}) -> dotted keys."""
    out: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _scalar(sweep: Sweep, where: str, value: Any) -> Any:
    if _kind(value) is None:
        raise sweep.fail(f"{where} = {value!r}: must be a number, a string or a boolean")
    return value


def _values(sweep: Sweep, key: str, values: Any) -> tuple:
    where = f"grid.{key}"
    if not isinstance(values, (list, tuple)):
        raise sweep.fail(f"{where} = {values!r}: must be an array of values, e.g. {key} = [{_toml(values) if _kind(values) else '0.5'}]")
    if not values:
        raise sweep.fail(f"{where} = []: empty grid; give at least one value")
    kinds = {_kind(_scalar(sweep, f"{where}[{i}]", v)) for i, v in enumerate(values)}
    if len(kinds) > 1:
        raise sweep.fail(f"{where} = {list(values)!r}: mixes {', '.join(sorted(kinds))}; give values of one kind")
    if kinds == {"number"} and any(isinstance(v, float) for v in values):
        values = [float(v) for v in values]  # one column type, and one point id per value
    return tuple(values)


def _check_key(sweep: Sweep, where: str, key: str) -> None:
    role = _key_role(key)
    if role in ENGINE_NAMES and role not in sweep.engines:
        raise sweep.fail(f"{where}: {key!r} is a {role} setting but {role} is not in engines = {list(sweep.engines)!r}")


def _validate(sweep: Sweep) -> None:
    """Normalize the fields in place (frozen: through object.__setattr__) and check every point."""
    set_ = lambda name, value: object.__setattr__(sweep, name, value)  # noqa: E731
    if not isinstance(sweep.scene, str) or not sweep.scene:
        raise sweep.fail(f"scene = {sweep.scene!r}: must be a built-in scene ({', '.join(CATALOGUE)}) or a scene TOML path")
    if sweep.scene not in CATALOGUE and Path(sweep.scene).exists():  # a file: the same one from any directory
        set_("scene", str(Path(sweep.scene).resolve()))
    engines = sweep.engines
    if isinstance(engines, str) or not isinstance(engines, (list, tuple)) or not engines:
        raise sweep.fail(f"engines = {engines!r}: must be a non-empty array of {', '.join(repr(e) for e in ENGINE_NAMES)}")
    for e in engines:
        if e not in ENGINE_NAMES:
            raise sweep.fail(f"engines: {e!r} is not an engine; allowed: {', '.join(ENGINE_NAMES)}" + did_you_mean(str(e), ENGINE_NAMES))
    if len(set(engines)) != len(engines):
        raise sweep.fail(f"engines = {list(engines)!r}: lists an engine twice")
    set_("engines", tuple(engines))
    t = sweep.timeout
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not (t > 0 and math.isfinite(t)):
        raise sweep.fail(f"timeout = {t!r}: must be a finite number of seconds > 0")
    set_("timeout", float(t))
    if not isinstance(sweep.description, str):
        raise sweep.fail(f"description = {sweep.description!r}: must be a string")
    for name in ("fixed", "grid", "tolerances"):
        if not isinstance(getattr(sweep, name), Mapping):
            raise sweep.fail(f"{'set' if name == 'fixed' else name} = {getattr(sweep, name)!r}: must be a table")
    fixed = {k: _scalar(sweep, f"set.{k}", v) for k, v in _flatten(sweep.fixed).items()}
    grid = {k: _values(sweep, k, v) for k, v in _flatten(sweep.grid).items()}
    if isinstance(sweep.points, Mapping) or not isinstance(sweep.points, (list, tuple)):
        raise sweep.fail(f"points = {sweep.points!r}: must be an array of tables ([[points]])")
    points = []
    for i, p in enumerate(sweep.points):
        if not isinstance(p, Mapping):
            raise sweep.fail(f"points[{i}] = {p!r}: must be a table of KEY = value")
        flat = {k: _scalar(sweep, f"points[{i}].{k}", v) for k, v in _flatten(p).items()}
        if not flat:
            raise sweep.fail(f"points[{i}]: empty; give at least one KEY = value")
        points.append(flat)
    if not grid and not points:
        raise sweep.fail("no points: give a [grid] of KEY = [values] or [[points]] tables")
    for where, keys in [("set", fixed), ("grid", grid)] + [(f"points[{i}]", p) for i, p in enumerate(points)]:
        for k in keys:
            _check_key(sweep, f"{where}.{k}", k)
            if where != "set" and k in fixed:
                raise sweep.fail(f"{where}.{k}: also in [set]; a key is either fixed or varied")
    set_("fixed", fixed)
    set_("grid", grid)
    set_("points", tuple(points))
    tol = _flatten(sweep.tolerances)
    try:
        make_tolerances(tol)
    except InputError as exc:  # ToleranceError: names the key and what is allowed
        raise sweep.fail(str(exc)) from None
    set_("tolerances", tol)
    # every point's scene and settings, one key at a time first so the message names the key
    _resolve(sweep, fixed, "[set]")
    for k, values in grid.items():
        for v in values:
            _resolve(sweep, {**fixed, k: v}, f"grid.{k} = {_toml(v)}")
    for i, p in enumerate(points):
        _resolve(sweep, {**fixed, **p}, f"points[{i}]")
    if len(grid) > 1:
        for p in _grid_product(grid):
            _resolve(sweep, {**fixed, **p}, "grid point " + ", ".join(f"{k} = {_toml(v)}" for k, v in p.items()))


def _resolve(sweep: Sweep, params: Mapping[str, Any], where: str) -> dict[str, float]:
    """Build the point's scene and each engine's settings; returns each engine's dt [s]."""
    scene_over = {k: v for k, v in params.items() if _key_role(k) == "scene"}
    try:
        load_scene(sweep.scene, scene_over)
        return {e: make_settings(e, params.get("dt"), {k: v for k, v in params.items() if _key_role(k) == e}).dt
                for e in sweep.engines}
    except InputError as exc:  # SettingsError too
        raise sweep.fail(f"{where}: {exc}") from None


def _grid_product(grid: Mapping[str, tuple]) -> Iterable[dict[str, Any]]:
    keys = list(grid)
    for combo in itertools.product(*(grid[k] for k in keys)):
        yield dict(zip(keys, combo))


def load_sweep(path: str | Path) -> Sweep:
    """Read and fully validate a sweep spec file (format in the module docstring).

    A scene given as a path is resolved relative to the spec file. Raises ``SpecError``.
    """
    path = Path(path)
    where = f"sweep spec {str(path)!r}"
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SpecError(f"{where}: cannot be read ({exc.strerror or exc})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SpecError(f"{where}: not valid TOML ({exc})") from None
    for k in data:
        if k not in SPEC_KEYS:
            raise SpecError(f"{where}: {k}: unknown key; allowed: {', '.join(SPEC_KEYS)}" + did_you_mean(k, SPEC_KEYS))
    if "scene" not in data:
        raise SpecError(f"{where}: scene: missing; give a built-in scene ({', '.join(CATALOGUE)}) or a scene TOML path")
    scene = data["scene"]
    if isinstance(scene, str) and scene not in CATALOGUE:
        scene_path = Path(scene)
        if not scene_path.is_absolute():
            scene_path = path.parent / scene_path
        if scene_path.exists() or scene_path.suffix == ".toml":
            scene = str(scene_path.resolve())
    points = data.get("points", ())
    return Sweep(
        scene=scene, engines=data.get("engines", ENGINE_NAMES), fixed=data.get("set", {}), grid=data.get("grid", {}),
        points=points if not isinstance(points, list) else tuple(points), timeout=data.get("timeout", DEFAULT_TIMEOUT),
        tolerances=data.get("tolerances", {}), description=data.get("description", ""), source=str(path),
    )


def sweep_points(sweep: Sweep) -> list[dict[str, Any]]:
    """Every point as ``{dotted key: value}`` ([set] merged in): grid product, then [[points]]; no repeats."""
    seen, out = set(), []
    for p in itertools.chain(_grid_product(sweep.grid) if sweep.grid else (), sweep.points):
        full = {**sweep.fixed, **p}
        key = json.dumps(full, sort_keys=True)
        if key not in seen:
            seen.add(key)
            out.append(full)
    return out


def sweep_runs(sweep: Sweep) -> list[RunTask]:
    """Every (point, engine) run in order, identical runs once (see the module docstring)."""
    name = sweep.scene_name
    runs: list[RunTask] = []
    seen: set[str] = set()
    for point in sweep_points(sweep):
        dts = _resolve(sweep, point, "point")
        for engine in sweep.engines:
            params = {k: v for k, v in point.items() if _key_role(k) in ("dt", "scene", engine)}
            pid = point_id(name, engine, params)
            if pid in seen:
                continue
            seen.add(pid)
            runs.append(RunTask(index=len(runs), point_id=pid, scene=sweep.scene, scene_name=name, engine=engine,
                                params=tuple(params.items()), dt=dts[engine], timeout=sweep.timeout,
                                tolerances=tuple(sweep.tolerances.items())))
    return runs


# -- one run (inside a worker) -----------------------------------------------------------

_WARM: set = set()  # engine names and ("scene", scene) keys already warmed in this process
_WARM_LOCK = threading.Lock()


def _warm_up(task: RunTask) -> None:
    """Once per worker process: load the task's engine and the reference's kernels for its scene.

    Every run is a fork of the worker, so what is loaded here is loaded for all of them;
    without it each run would pay the imports and numba's cache loading (~0.6 s). The
    reference is run once on the task's own scene too: numba loads a compiled kernel the
    first time a scene's code path calls it (~10 ms for feigin-pair after a ball warm-up),
    and a forked run would otherwise pay that again every time.
    """
    with _WARM_LOCK:
        todo = [key for key in (task.engine, ("scene", task.scene)) if key not in _WARM]
        if not todo:
            return
        from .pipeline.compare import compare

        try:
            if task.engine in todo:
                compare(load_scene("bouncing-ball", {"duration": 0.6}), engines=(task.engine,), dt=1e-3)
            if ("scene", task.scene) in todo:
                compare(load_scene(task.scene, task.scene_overrides()), engines=())
        except Exception:  # a warm-up failure is only slower runs; the runs report real errors
            pass
        _WARM.update(todo)


def _compute_row(task: RunTask) -> dict[str, Any]:
    """The row of one run (runs in the isolated child)."""
    from .pipeline.compare import compare
    from .pipeline.summary import summarize

    scene = load_scene(task.scene, task.scene_overrides())
    result = compare(scene, engines=(task.engine,), dt=task.dt, overrides=task.engine_overrides(),
                     tol=make_tolerances(dict(task.tolerances)))
    return summarize(result, task.engine, dict(task.params))


@dataclass(frozen=True)
class RunResult:
    """A worker's answer: the row and what the run cost."""

    index: int
    row: dict[str, Any]
    run_time: float  # [s] wall-clock of the isolated run, fork to result


def run_task(task: RunTask) -> RunResult:
    """The function submitted to the executor: one isolated run -> its row (never raises for the run)."""
    _warm_up(task)
    outcome = run_isolated(_compute_row, task, timeout=task.timeout)
    if outcome.status == "ok":
        row = outcome.value
    else:
        message = outcome.message if len(outcome.message) <= _MESSAGE_CHARS else "..." + outcome.message[-_MESSAGE_CHARS:]
        try:
            version = engine_version(task.engine)
        except Exception:
            version = ""
        try:  # the spec was validated: the scene loads; the guard keeps a failure row whatever happens
            mu = mass_ratio(load_scene(task.scene, task.scene_overrides()))
        except Exception:
            mu = math.nan
        row = failure_row(task.scene_name, task.engine, dict(task.params), outcome.status, message, version, mu)
        row["dt"] = task.dt
    return RunResult(index=task.index, row=row, run_time=outcome.wall_time)


def _compute_batch_rows(tasks: Sequence[RunTask]) -> list[dict[str, Any]]:
    """The rows of runs of one engine, in one isolated child (MuJoCo: compatible runs in one rollout call)."""
    from .pipeline.compare import compare
    from .pipeline.summary import summarize

    scenes = [load_scene(t.scene, t.scene_overrides()) for t in tasks]
    settings = [make_settings(t.engine, t.dt, t.engine_overrides()) for t in tasks]
    trajectories = run_engine_batch(tasks[0].engine, list(zip(scenes, settings)))
    rows = []
    for task, scene, traj in zip(tasks, scenes, trajectories):
        result = compare(scene, engines=(task.engine,), dt=task.dt, overrides=task.engine_overrides(),
                         tol=make_tolerances(dict(task.tolerances)), trajectories={task.engine: traj})
        rows.append(summarize(result, task.engine, dict(task.params)))
    return rows


def run_batch_task(tasks: Sequence[RunTask]) -> list[RunResult]:
    """The function submitted for a unit of work (``work_units``): one isolated call for all -> their rows.

    The batch's limit is the sum of its runs' limits. If the batch does not come back whole
    (a run crashed, hung or raised, or a run's settings refuse the batch), every run of it
    is run again alone through ``run_task``, so the faulty run is classified by itself and
    the others get their rows. Each row's ``run_time`` is its share of the batch's time.
    """
    if len(tasks) == 1:
        return [run_task(tasks[0])]
    _warm_up(tasks[0])
    outcome = run_isolated(_compute_batch_rows, list(tasks), timeout=sum(t.timeout for t in tasks))
    if outcome.status != "ok":
        return [run_task(t) for t in tasks]
    share = outcome.wall_time / len(tasks)
    return [RunResult(index=t.index, row=row, run_time=share) for t, row in zip(tasks, outcome.value)]


MAX_BATCH = 8  # runs per unit of work by default: long enough to amortize, short enough to balance


def work_units(runs: Sequence[RunTask], batch: int | None, slots: int) -> list[tuple[RunTask, ...]]:
    """Group ``runs`` into units of work (one isolated child each), ordered by their first run.

    A unit holds runs of one engine; for an engine that batches (MuJoCo) also of one ``dt``
    and duration, and the worker rolls out together the ones whose compiled models are
    compatible. Other engines' runs in a unit run one after another in the same child,
    which saves a fork per run. Sizes: ``batch`` runs per unit, or by default guided
    self-scheduling, ``remaining // (4 slots)`` clipped to [1, MAX_BATCH], so units
    shrink towards the end of each group and no slot waits long for the last one.
    ``batch = 1``: every run alone.
    """
    groups: dict[tuple, list[RunTask]] = {}
    for r in runs:
        key = (r.engine, r.dt, dict(r.params).get("duration")) if can_batch(r.engine) else (r.engine,)
        groups.setdefault(key, []).append(r)
    first_of: dict[int, tuple[RunTask, ...]] = {}
    for g in groups.values():
        i = 0
        while i < len(g):
            size = batch if batch is not None else max(1, min(MAX_BATCH, (len(g) - i) // (4 * max(1, slots))))
            chunk = tuple(g[i:i + size])
            first_of[chunk[0].index] = chunk
            i += size
    return [first_of[r.index] for r in runs if r.index in first_of]


# -- the dataset ---------------------------------------------------------------------------

def _normalize(frame: pd.DataFrame) -> pd.DataFrame:
    for c in _FLOAT_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").astype(float)
    for c in _INT_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").fillna(0).astype("int64")
    return frame


def read_rows(out_dir: str | Path, dedupe: bool = True) -> pd.DataFrame:
    """All rows under ``OUT/rows/`` (part files in write order); ``dedupe`` keeps the first of a point_id+engine."""
    parts = sorted(Path(out_dir, "rows").glob("part-*.parquet"))
    frames = [pd.read_parquet(p) for p in parts]
    frames = [f for f in frames if len(f)]
    if not frames:
        return pd.DataFrame(columns=ROW_COLUMNS)
    frame = _normalize(pd.concat(frames, ignore_index=True))
    if dedupe:
        frame = frame.drop_duplicates(subset=["point_id", "engine"], keep="first").reset_index(drop=True)
    return frame


class _PartWriter:
    """Appends batches of rows to OUT/rows/ as atomically written part files."""

    def __init__(self, rows_dir: Path) -> None:
        self.dir = rows_dir
        self.dir.mkdir(parents=True, exist_ok=True)
        for stale in self.dir.glob(".part-*.tmp"):  # torn writes of a killed sweep
            stale.unlink(missing_ok=True)
        self.seq = 0

    def append(self, rows: list[dict[str, Any]]) -> None:
        if not rows:
            return
        self.seq += 1
        # time first, so that sorted names are write order across resumed sessions
        name = f"part-{time.time_ns():020d}-{os.getpid()}-{self.seq:06d}.parquet"
        write_frame(self.dir / name, _normalize(pd.DataFrame(rows)))


def _ordered(frame: pd.DataFrame, runs: Sequence[RunTask], sweep: Sweep) -> pd.DataFrame:
    order = {(r.point_id, r.engine): r.index for r in runs}
    frame = frame.assign(_order=[order.get(k, len(order)) for k in zip(frame["point_id"], frame["engine"])])
    frame = frame.sort_values("_order", kind="stable").drop(columns="_order").reset_index(drop=True)
    params = list(dict.fromkeys(itertools.chain(sweep.fixed, sweep.grid, *sweep.points)))
    params = [p for p in params if p in frame and p != "dt"]
    head = ["point_id", "scene", "engine"]
    rest = [c for c in ROW_COLUMNS if c not in head]
    extra = [c for c in frame.columns if c not in head + params + rest]
    return frame[head + params + [c for c in rest if c in frame] + extra]


# -- the runner ------------------------------------------------------------------------------

def _slots(executor: Any) -> int | None:
    """Parallel slots an executor offers, when it says (process pool, Dask)."""
    n = getattr(executor, "_max_workers", None)
    if isinstance(n, int):
        return n
    client = getattr(executor, "_client", None)
    if client is not None:
        try:
            return max(1, sum(client.nthreads().values()))
        except Exception:
            return None
    return None


def _progress(total: int, done: int, enabled: bool):
    from tqdm import tqdm

    on = enabled and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    return tqdm(total=total, initial=done, desc="sweep", unit="run", file=sys.stderr, disable=not on,
                dynamic_ncols=True, smoothing=0.1)


def _prepare_out(sweep: Sweep, out: Path, resume: bool) -> None:
    spec_path = out / "sweep.toml"
    has_rows = any((out / "rows").glob("part-*.parquet")) if (out / "rows").is_dir() else False
    if has_rows and resume and spec_path.exists():
        try:
            previous = load_sweep(spec_path)
        except InputError as exc:
            raise SpecError(f"{spec_path}: the sweep written there cannot be read back ({exc}); choose another --out") from None
        if previous.identity() != sweep.identity():
            diff = [k for k in sweep.identity() if sweep.identity()[k] != previous.identity()[k]]
            raise SpecError(f"{out}: holds rows of a different sweep ({', '.join(diff)} differ); "
                            "resume with the same spec or choose another --out")
    if has_rows and not resume:
        raise SpecError(f"{out}: already holds sweep rows; pass --resume to finish that sweep, or choose an empty --out")
    write_text(spec_path, sweep.to_toml())


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path,
    executor: Executor | Any | None = None,
    resume: bool = False,
    workers: int | None = None,
    progress: bool = True,
    batch: int | None = None,
) -> pd.DataFrame:
    """Run every run of ``sweep`` not yet in ``out_dir``; returns all its rows in run order.

    Parameters
    ----------
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Where runs execute; default a local ``ProcessPoolExecutor`` of ``workers`` processes
        (all cores). A Dask ``Client`` is used through ``client.get_executor()``.
    resume : bool
        Continue the sweep already in ``out_dir`` (same spec); without it ``out_dir``
        must hold no rows.
    workers : int, optional
        Local pool size; with a given executor only bounds the runs in flight.
    progress : bool
        tqdm bar on stderr (done/total, failures, ETA) when stderr is a terminal.
    batch : int, optional
        Runs per unit of work (one isolated child; MuJoCo: one ``mujoco.rollout`` call), see
        ``work_units``; default automatic, 1 runs every run alone. The rows are the same either way.

    Returns
    -------
    DataFrame
        ``rows.ROW_COLUMNS`` plus one column per parameter; ``attrs["sweep"]`` holds this
        call's ``wall_s``, ``runs`` executed, ``units`` of work submitted (``work_units``), ``run_s_sum`` (isolated runs' own wall time),
        ``engine_s_sum`` (their engine stepping time) and ``workers``.
    """
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise SpecError(f"workers = {workers!r}: must be an integer >= 1")
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise SpecError(f"batch = {batch!r}: must be an integer >= 1")
    out = Path(out_dir)
    runs = sweep_runs(sweep)
    _prepare_out(sweep, out, resume)
    writer = _PartWriter(out / "rows")
    have = read_rows(out)
    done_keys = set(zip(have["point_id"], have["engine"]))
    todo = [r for r in runs if (r.point_id, r.engine) not in done_keys]
    failures = int(have["status"].isin(FAILED).sum()) if len(have) else 0
    stats = {"wall_s": 0.0, "runs": 0, "units": 0, "run_s_sum": 0.0, "engine_s_sum": 0.0, "workers": 0}
    start = time.perf_counter()
    owned = None
    if todo:
        if executor is None:
            owned = executor = ProcessPoolExecutor(max_workers=workers or os.cpu_count() or 1, initializer=die_with_parent)
        elif hasattr(executor, "get_executor"):  # a dask.distributed Client
            executor = executor.get_executor(pure=False)
        slots = workers or _slots(executor) or os.cpu_count() or 1
        stats["workers"] = slots
        bar = _progress(len(runs), len(runs) - len(todo), progress)
        bar.set_postfix(failed=failures)
        pending: set[Future] = set()
        units = work_units(todo, batch, slots)
        stats["units"] = len(units)
        queue = iter(units)
        try:
            while True:
                # a bounded window: Ctrl-C cancels little, and memory stays flat for any sweep size
                while len(pending) < 2 * slots:
                    unit = next(queue, None)
                    if unit is None:
                        break
                    pending.add(executor.submit(run_batch_task, unit))
                if not pending:
                    break
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                results = [r for f in finished if f.exception() is None for r in f.result()]
                writer.append([r.row for r in results])
                for f in finished:  # an executor failure (a broken pool, a lost Dask worker) ends the sweep
                    if f.exception() is not None:
                        raise f.exception()
                for r in results:
                    stats["runs"] += 1
                    stats["run_s_sum"] += r.run_time
                    w = r.row.get("wall_time_s")
                    stats["engine_s_sum"] += w if isinstance(w, float) and math.isfinite(w) else 0.0
                    failures += r.row["status"] in FAILED
                bar.update(len(results))
                bar.set_postfix(failed=failures)
        except BaseException:
            for f in pending:
                f.cancel()
            # rows of runs that finished meanwhile are kept; the rest run on --resume
            done_now = [f for f in pending if f.done() and not f.cancelled() and f.exception() is None]
            writer.append([r.row for f in done_now for r in f.result()])
            raise
        finally:
            bar.close()
            if owned is not None:
                owned.shutdown(wait=True, cancel_futures=True)
    stats["wall_s"] = time.perf_counter() - start
    frame = _ordered(read_rows(out), runs, sweep)
    write_frame(out / "rows.parquet", frame)
    frame.attrs["sweep"] = stats
    return frame


# -- benchmark -------------------------------------------------------------------------------

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
