"""A sweep spec: one scene, some engines, a grid of scene fields and engine settings, validated in full.

    >>> from chatterbench.comparisons.studies.sweep.spec import load_sweep, sweep_runs
    >>> sweep = load_sweep("examples/sweeps/bouncing-ball-dt.toml")
    >>> sweep.scene_name, len(sweep_runs(sweep))
    ('bouncing-ball', 18)

Spec file (TOML)::

    scene = "feigin-pair"              # built-in scene, or a scene TOML path (relative to this file)
    engines = ["mujoco", "pybullet"]   # default: both
    timeout = 120                      # [s] wall-clock limit of one run (one engine at one point), <= 86400
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

    [refine]                           # optional: an adaptive map over two grid keys (refine.py)
    axes = ["dt", "restitution"]       # two [grid] keys of numbers: the coarse map
    depth = 2                          # 1..6 levels of splitting the cells whose corners' verdicts differ
    boundary = "verdict"               # or "passing", a verdict name, or a metric with threshold = VALUE

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
- ``Sweep.to_toml`` writes any Unicode as itself (an emoji in a description, a string value
  or the scene path), so ``OUT/sweep.toml`` always reads back to an equal Sweep; a string
  that is not valid Unicode (a lone surrogate) is refused. ``timeout`` is at most one day.
- Rows reach ``OUT/rows/part-*.parquet`` as runs finish, each part written atomically. A
  sweep killed at any moment and resumed (``resume=True``) ends with exactly the rows of an
  uninterrupted one: finished rows are never re-run, unfinished runs are run once.
- A sweep with ``[refine]`` runs the grid (level 0), then level by level only the points
  of the cells whose corners differ (``refine.py``), each row with its ``refine_level``;
  killed mid-level and resumed, it ends with the rows of an uninterrupted one too.

Layout of OUT: ``sweep.toml`` (the resolved spec, written first), ``rows/`` (the Parquet
dataset, one part per batch of finished runs), ``rows.parquet`` (all rows in run order,
written at the end).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

from chatterbench.comparisons.pipeline.budget import Budget, check_engine_run
from chatterbench.comparisons.pipeline.summary import point_id
from chatterbench.comparisons.pipeline.tolerances import make_tolerances
from chatterbench.engines.registry import DEFAULT_ENGINES, ENGINE_NAMES, make_settings
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.errors import (InputError, check_choice, check_fields, check_number, check_table, check_text,
                                          did_you_mean, is_number)
from chatterbench.reference.scene import load_scene
from chatterbench.reference.tables import flatten, printable, read_toml, toml_literal

from .refine import Refine, make_refine

DEFAULT_TIMEOUT = 120.0  # [s] per run
MAX_RUNS = 100_000  # (points x engines) a sweep: about 14 h at 0.5 s a run on two cores
MAX_TIMEOUT = 86400.0  # [s] one day: beyond it a limit is no limit (and past ~1e9 s the OS refuses it)
FAILED = ("crashed", "timeout", "error")  # run statuses counted as failures by the progress bar (a sweep's isolation)
class SpecError(InputError):
    """A sweep spec is malformed or names something not allowed; the message says where."""


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
    engines: tuple[str, ...] = DEFAULT_ENGINES
    fixed: Mapping[str, Any] = field(default_factory=dict)  # [set]: dotted key -> value
    grid: Mapping[str, tuple] = field(default_factory=dict)  # [grid]: dotted key -> values
    points: tuple[Mapping[str, Any], ...] = ()  # [[points]]
    timeout: float = DEFAULT_TIMEOUT  # [s] per run, > 0
    tolerances: Mapping[str, Any] = field(default_factory=dict)  # pipeline.tolerances.Tolerances fields
    description: str = ""
    refine: Refine | Mapping[str, Any] | None = None  # [refine]: an adaptive map (refine.py); a table becomes a Refine
    source: str = ""  # the spec file, for messages ("" when built in Python)
    budget: Budget = field(default_factory=Budget, compare=False)  # each run's steps and memory (not in the rows)

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
        lines = [f"scene = {toml_literal(self.scene)}", f"engines = {toml_literal(list(self.engines))}",
                 f"timeout = {toml_literal(self.timeout)}"]
        if self.description:
            lines.append(f"description = {toml_literal(self.description)}")
        for name, table in (("set", self.fixed), ("grid", {k: list(v) for k, v in self.grid.items()}),
                            ("tolerances", self.tolerances)):
            if table:
                lines += ["", f"[{name}]"] + [f"{toml_literal(k)} = {toml_literal(v)}" for k, v in table.items()]
        for p in self.points:
            lines += ["", "[[points]]"] + [f"{toml_literal(k)} = {toml_literal(v)}" for k, v in p.items()]
        if self.refine is not None:
            lines += ["", "[refine]"] + [f"{toml_literal(k)} = {toml_literal(v)}" for k, v in self.refine.to_table().items()]
        return "\n".join(lines) + "\n"

    def fingerprint(self) -> str:
        """16 hex digits of ``identity``: equal for specs that give the same rows (1 and 1.0 alike)."""
        def floats(v: Any) -> Any:
            if isinstance(v, dict):
                return {k: floats(x) for k, x in v.items()}
            if isinstance(v, list):
                return [floats(x) for x in v]
            return float(v) if isinstance(v, int) and not isinstance(v, bool) else v

        blob = json.dumps(floats(self.identity()), sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def identity(self) -> dict[str, Any]:
        """What decides the rows (everything but timeout, description and source; ``refine`` only when given)."""
        out = {"scene": self.scene, "engines": list(self.engines), "set": dict(self.fixed),
               "grid": {k: list(v) for k, v in self.grid.items()}, "points": [dict(p) for p in self.points],
               "tolerances": dict(self.tolerances)}
        if self.refine is not None:
            out["refine"] = self.refine.to_table()
        return out


def _unicode(where: str, text: str) -> str:
    """``text`` if it is valid Unicode (what TOML and UTF-8 files can hold), else a SpecError."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:  # a lone surrogate, e.g. an undecodable byte of a file name
        raise SpecError(f"{where} = {text!r}: not valid Unicode ({exc.reason} at character {exc.start})") from None
    return text


def _scalar(where: str, value: Any) -> Any:
    if _kind(value) is None:
        raise SpecError(f"{where} = {value!r}: must be a number, a string or a boolean")
    return _unicode(where, value) if isinstance(value, str) else value


def _values(where: str, values: Any) -> tuple:
    key = where.removeprefix("grid.")
    if not isinstance(values, (list, tuple)):
        raise SpecError(f"{where} = {values!r}: must be an array of values, e.g. {key} = [{toml_literal(values) if _kind(values) else '0.5'}]")
    if not values:
        raise SpecError(f"{where} = []: empty grid; give at least one value")
    kinds = {_kind(_scalar(f"{where}[{i}]", v)) for i, v in enumerate(values)}
    if len(kinds) > 1:
        raise SpecError(f"{where} = {list(values)!r}: mixes {', '.join(sorted(kinds))}; give values of one kind")
    if kinds == {"number"} and any(isinstance(v, float) for v in values):
        values = [float(v) for v in values]  # one column type, and one point id per value
    return tuple(values)


def _scene(where: str, value: Any) -> str:
    """A built-in scene's name, or a scene file's path made absolute (the same file from any directory)."""
    if not isinstance(value, str) or not value:
        raise SpecError(f"{where} = {value!r}: must be a built-in scene ({', '.join(CATALOGUE)}) or a scene TOML path")
    _unicode(where, value)
    return str(Path(value).resolve()) if value not in CATALOGUE and Path(value).exists() else value


def _engines(where: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, (list, tuple)) or not value:
        raise SpecError(f"{where} = {value!r}: must be a non-empty array of {', '.join(repr(e) for e in ENGINE_NAMES)}")
    names = tuple(check_choice(f"{where}[{i}]", e, ENGINE_NAMES, SpecError) for i, e in enumerate(value))
    if len(set(names)) != len(names):
        raise SpecError(f"{where} = {list(names)!r}: lists an engine twice")
    return names


def _timeout(where: str, value: Any) -> float:
    """[s] per run; past ~1e9 s the OS refuses the wait (a traceback from the first run), so one day at most."""
    check_number(where, value, lo=0.0, lo_open=True, unit=" [s]", error=SpecError)
    return check_number(where, value, lo=0.0, hi=MAX_TIMEOUT, lo_open=True, unit=" seconds (one day at most)", error=SpecError)


def _flat(where: str, value: Any, check: Callable[[str, Any], Any]) -> dict[str, Any]:
    """A table's dotted keys, each value through ``check``."""
    return {k: check(f"{where}.{k}", v) for k, v in flatten(check_table(where, value, SpecError)).items()}


def _points(where: str, value: Any) -> tuple[dict[str, Any], ...]:
    if isinstance(value, Mapping) or not isinstance(value, (list, tuple)):
        raise SpecError(f"{where} = {value!r}: must be an array of tables ([[points]])")
    points = []
    for i, p in enumerate(value):
        if not isinstance(p, Mapping):
            raise SpecError(f"{where}[{i}] = {p!r}: must be a table of KEY = value")
        points.append(_flat(f"{where}[{i}]", p, _scalar))
        if not points[-1]:
            raise SpecError(f"{where}[{i}]: empty; give at least one KEY = value")
    return tuple(points)


def _tolerances(where: str, value: Any) -> dict[str, Any]:
    table = flatten(check_table(where, value, SpecError))
    make_tolerances(table)  # ToleranceError: names the key and what is allowed
    return table


# The spec's keys: the Sweep field each sets, and the check that turns the file's value into the field's.
# [refine] is checked after them: it names keys of [grid].
FIELDS: dict[str, tuple[str, Callable[[str, Any], Any]]] = {
    "scene": ("scene", _scene),
    "engines": ("engines", _engines),
    "timeout": ("timeout", _timeout),
    "description": ("description", lambda where, v: _unicode(where, check_text(where, v, SpecError))),
    "set": ("fixed", lambda where, v: _flat(where, v, _scalar)),
    "grid": ("grid", lambda where, v: _flat(where, v, _values)),
    "points": ("points", _points),
    "tolerances": ("tolerances", _tolerances),
}
SPEC_KEYS = (*FIELDS, "refine")


def _check_size(sweep: Sweep) -> None:
    """Refuse a sweep with no points or more than ``MAX_RUNS`` runs (counted, never enumerated)."""
    grid, points = sweep.grid, sweep.points
    if not grid and not points:
        raise sweep.fail("no points: give a [grid] of KEY = [values] or [[points]] tables")
    n_grid = math.prod(len(v) for v in grid.values()) if grid else 0
    runs = (n_grid + len(points)) * len(sweep.engines)
    if runs > MAX_RUNS:
        sizes = " x ".join(f"{k} ({len(v)})" for k, v in grid.items())
        raise sweep.fail(f"grid: {sizes} = {n_grid:.3g} points{f' + {len(points)} [[points]]' if points else ''}, x "
                         f"{len(sweep.engines)} engines = {runs:.3g} runs, more than {MAX_RUNS} a sweep; use fewer "
                         "values, or split the sweep into several specs")


def _check_keys(sweep: Sweep) -> None:
    """An engine's setting needs its engine in the sweep; a key is either fixed or varied."""
    tables = [("set", sweep.fixed), ("grid", sweep.grid)] + [(f"points[{i}]", p) for i, p in enumerate(sweep.points)]
    for where, keys in tables:
        for k in keys:
            role = _key_role(k)
            if role in ENGINE_NAMES and role not in sweep.engines:
                raise sweep.fail(f"{where}.{k}: {k!r} is a {role} setting but {role} is not in engines = {list(sweep.engines)!r}")
            if where != "set" and k in sweep.fixed:
                raise sweep.fail(f"{where}.{k}: also in [set]; a key is either fixed or varied")


def _check_points(sweep: Sweep) -> None:
    """Every point's scene and settings, one key at a time first so that the message names the key."""
    fixed, grid = sweep.fixed, sweep.grid
    _resolve(sweep, fixed, "[set]")
    for k, values in grid.items():
        for v in values:
            _resolve(sweep, {**fixed, k: v}, f"grid.{k} = {toml_literal(v)}")
    for i, p in enumerate(sweep.points):
        _resolve(sweep, {**fixed, **p}, f"points[{i}]")
    if len(grid) > 1:  # combinations by axis: each numeric axis's extremes (the limits are monotone in each value)
        for p in _grid_product(_extremes(grid)):
            _resolve(sweep, {**fixed, **p}, "grid point " + ", ".join(f"{k} = {toml_literal(v)}" for k, v in p.items()))


def _validate(sweep: Sweep) -> None:
    """Normalize the fields in place (frozen: through object.__setattr__) and check every point."""
    raw = {key: getattr(sweep, attr) for key, (attr, _) in FIELDS.items()}
    try:
        checked = check_fields(raw, {key: check for key, (_, check) in FIELDS.items()}, error=SpecError)
    except InputError as exc:  # SpecError, and ToleranceError: each names the key and what is allowed
        raise sweep.fail(str(exc)) from None
    for key, (attr, _) in FIELDS.items():
        object.__setattr__(sweep, attr, checked[key])
    _check_size(sweep)
    _check_keys(sweep)
    if sweep.refine is not None:  # its axes' values become floats: a split value is one, and one column type
        refine = make_refine(sweep.refine, sweep.grid, sweep.fail)
        object.__setattr__(sweep, "refine", refine)
        object.__setattr__(sweep, "grid", {**sweep.grid, **{a: tuple(float(v) for v in sweep.grid[a]) for a in refine.axes}})
    _check_points(sweep)


def _extremes(grid: Mapping[str, tuple]) -> dict[str, tuple]:
    """Each axis's smallest and largest value when it holds numbers, else all its values (2 per axis, not 300)."""
    return {k: tuple(dict.fromkeys((min(v), max(v)))) if all(is_number(x) for x in v) else v for k, v in grid.items()}


def _resolve(sweep: Sweep, params: Mapping[str, Any], where: str) -> dict[str, float]:
    """Build the point's scene and each engine's settings; returns each engine's dt [s]."""
    scene_over = {k: v for k, v in params.items() if _key_role(k) == "scene"}
    try:
        scene = load_scene(sweep.scene, scene_over)
        dts = {e: make_settings(e, params.get("dt"), {k: v for k, v in params.items() if _key_role(k) == e}).dt
               for e in sweep.engines}
        for e, dt in dts.items():  # a run too big for a worker is refused before the first one starts
            check_engine_run(scene, e, dt, sweep.budget)
        return dts
    except InputError as exc:  # SettingsError and BudgetError too
        raise sweep.fail(f"{where}: {exc}") from None


def _grid_product(grid: Mapping[str, tuple]) -> Iterable[dict[str, Any]]:
    keys = list(grid)
    for combo in itertools.product(*(grid[k] for k in keys)):
        yield dict(zip(keys, combo))


def load_sweep(path: str | Path, budget: Budget | None = None) -> Sweep:
    """Read and fully validate a sweep spec file (format in the module docstring).

    A scene given as a path is resolved relative to the spec file. Every run is checked
    against ``budget`` (default ``Budget()``: one worker's steps and memory). Raises ``SpecError``.
    """
    path = Path(path)
    where = f"sweep spec {str(path)!r}"
    data = read_toml(path, where, SpecError)
    for k in data:
        if k not in SPEC_KEYS:
            raise SpecError(f"{where}: {printable(k)}: unknown key; allowed: {', '.join(SPEC_KEYS)}" + did_you_mean(k, SPEC_KEYS))
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
        scene=scene, engines=data.get("engines", DEFAULT_ENGINES), fixed=data.get("set", {}), grid=data.get("grid", {}),
        points=points if not isinstance(points, list) else tuple(points), timeout=data.get("timeout", DEFAULT_TIMEOUT),
        tolerances=data.get("tolerances", {}), description=data.get("description", ""), refine=data.get("refine"),
        source=str(path),
        budget=budget or Budget(),
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


def seen_by(key: str, engine: str) -> bool:
    """Whether ``engine``'s runs see the dotted ``key``: dt, scene fields and its own settings, not another engine's."""
    return _key_role(key) in ("dt", "scene", engine)


def run_params(point: Mapping[str, Any], engine: str) -> dict[str, Any]:
    """A run's parameters: the point's keys minus the other engines' settings."""
    return {k: v for k, v in point.items() if seen_by(k, engine)}


def sweep_runs(sweep: Sweep, points: Iterable[Mapping[str, Any]] | None = None, engines: Iterable[str] | None = None,
               start: int = 0, seen: set[str] | None = None) -> list[RunTask]:
    """Every (point, engine) run in order, identical runs once (see the module docstring).

    ``points`` (default ``sweep_points``) and ``engines`` (default the sweep's) choose the
    runs; indices start at ``start``; point ids in ``seen`` are skipped (and the new ones added).
    """
    name = sweep.scene_name
    runs: list[RunTask] = []
    seen = set() if seen is None else seen
    for point in sweep_points(sweep) if points is None else points:
        dts = _resolve(sweep, point, "point")
        for engine in sweep.engines if engines is None else engines:
            params = run_params(point, engine)
            pid = point_id(name, engine, params)
            if pid in seen:
                continue
            seen.add(pid)
            runs.append(RunTask(index=start + len(runs), point_id=pid, scene=sweep.scene, scene_name=name, engine=engine,
                                params=tuple(params.items()), dt=dts[engine], timeout=sweep.timeout,
                                tolerances=tuple(sweep.tolerances.items())))
    return runs
