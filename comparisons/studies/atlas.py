"""The atlas: the band-robust frontier of every engine on every scene, one ``tune`` per case, resumable after a kill.

    >>> from chatterbench.comparisons.studies.atlas import AtlasSpec
    >>> spec = AtlasSpec(scenes=("bouncing-ball",), engines=("mujoco", "pybullet"), tolerance=0.05)
    >>> [f"{scene}/{engine}" for scene, engine in spec.cases()]
    ['bouncing-ball/mujoco', 'bouncing-ball/pybullet']

A *case* is one (scene, engine): ``studies.tune.tune`` at the atlas's tolerances (a bare number
sets the sticking, exit and first-impact tolerances at once, as ``tune --tolerance T``), its
ladder of timing x restitution levels, the band-robust rule (every dt of [0.8, 1.25] x dt at 4
impact phases and the knob neighbours), the contact's persistence after each stick, no transfer
recheck (``tune`` itself does that, for the one answer a user writes). A case's outcome is
``recommended.json`` as ``tune --out`` writes it (``tune.answer.recommended``) with the case's
wall time [s], its runs, the engine's version, the code that ran it and the machine (a resumed atlas may hold
cases of several commits and machines: the report names them); a case that cannot run (the engine refuses
the scene, or crashes outside a run) is kept as a ``failed`` case with the message, and the
atlas goes on.

The folder (``DIR``)::

    atlas.json                          the spec and its provenance (versions, date, machine, command, wall time)
    cases/SCENE/ENGINE/case.json        the case's outcome (above), written last: its presence says the case is done
    cases/SCENE/ENGINE/candidates.parquet  every run of the case's search (``tune``'s table)

A killed atlas resumes: the cases with a ``case.json`` are kept, the others run (a case's files
are written together, ``atomic.staged``: a kill leaves a case whole or absent). A folder written
with another spec is refused (the scenes and engines may grow: the cases already done stay).
The tables built from the cases are ``atlas_tables`` (``outputs.atlas_files`` writes them).
"""

from __future__ import annotations

import json
import math
import platform
import re
import time
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ContextManager, Iterator, Mapping

from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.errors import InputError

from ..pipeline.atomic import staged, write_frame
from ..pipeline.tolerances import Tolerances
from .limits import MAX_RUNS, ROBUST_FRACTION
from .side_by_side import side_by_side

SPEC_FILE = "atlas.json"
CASE_FILE = "case.json"
CANDIDATES_FILE = "candidates.parquet"
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")  # a scene name that can name a case's folder
MAX_CASE_BYTES = 4 * 2**20  # [bytes] of a case.json: a case writes tens of KiB


class AtlasError(InputError):
    """An atlas that cannot run as asked: names the option or the file."""


@dataclass(frozen=True)
class AtlasSpec:
    """What an atlas runs: its cases (``scenes`` x ``engines``) and the tune of each.

    ``tolerance``: a number [-] (the sticking, exit and first-impact tolerances, fractions of each episode's chatter or
    sliding duration) or ``Tolerances``; ``max_runs``: each case's budget (``tune``'s, runs of up to 100,000 steps);
    ``robust_fraction``: the share of a band that must pass, in (0, 1]; ``fixed``: ``engine.knob`` -> value, knobs held
    at one value (``tune --set``); ``max_cost``: steps per simulated second no candidate exceeds.
    """

    scenes: tuple[str, ...]
    engines: tuple[str, ...]
    tolerance: float | Tolerances = 0.05
    max_runs: int = MAX_RUNS
    robust_fraction: float = ROBUST_FRACTION
    fixed: Mapping[str, Any] = field(default_factory=dict)
    max_cost: float = math.inf

    def cases(self) -> list[tuple[str, str]]:
        """Every (scene, engine), scene by scene in the order given (a scene: a built-in name or a scene file)."""
        return [(s, e) for s in self.scenes for e in self.engines]

    def tolerances(self) -> Tolerances:
        t = self.tolerance
        return t if isinstance(t, Tolerances) else Tolerances(stick=t, exit=t, first_impact=t)

    def search_key(self) -> dict[str, Any]:
        """What a case's answer depends on (a resumed atlas must have the same): the tolerances, budget, rule and caps."""
        return {"tolerances": self.tolerances().as_dict(), "max_runs": self.max_runs,
                "robust_fraction": self.robust_fraction, "fixed": {k: self.fixed[k] for k in sorted(self.fixed)},
                "max_cost": None if math.isinf(self.max_cost) else self.max_cost}


def default_scenes() -> tuple[str, ...]:
    """The built-in scenes (``chatterbench scenes``)."""
    return tuple(CATALOGUE)


def case_dir(out: Path, scene: str, engine: str) -> Path:
    return out / "cases" / scene / engine


def done_cases(out: Path) -> dict[tuple[str, str], dict[str, Any]]:
    """The finished cases under ``out``: (scene, engine) -> case.json. A link anywhere under ``cases/`` is refused by
    name (an atlas folder holds its own files; a read never follows one out of it)."""
    found = {}
    root = out / "cases"
    _no_link(root)
    if not root.is_dir():
        return found
    for scene_dir in sorted(root.iterdir()):
        _no_link(scene_dir)
        if not scene_dir.is_dir():
            continue
        for engine_dir in sorted(scene_dir.iterdir()):
            _no_link(engine_dir)
            path = engine_dir / CASE_FILE
            _no_link(path)
            if engine_dir.is_dir() and path.is_file():
                found[(scene_dir.name, engine_dir.name)] = read_case(path)
    return found


def _no_link(path: Path) -> None:
    if path.is_symlink():
        raise AtlasError(f"{path}: a link; an atlas folder holds its own files, and no read follows a link out of it")


def read_case(path: Path) -> dict[str, Any]:
    """A case.json, bounded (``MAX_CASE_BYTES``); refused by name when it is not one."""
    if path.stat().st_size > MAX_CASE_BYTES:
        raise AtlasError(f"{path}: {path.stat().st_size:,} bytes, more than a case writes ({MAX_CASE_BYTES:,}); "
                         "not an atlas case")
    try:
        case = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AtlasError(f"{path}: not an atlas case ({exc})") from None
    if not isinstance(case, dict) or not {"scene", "engine", "status"} <= set(case):
        raise AtlasError(f"{path}: not an atlas case (needs scene, engine and status)")
    return case


def provenance(spec: AtlasSpec, command: str) -> dict[str, Any]:
    """The atlas's spec and where it was made: each engine's version, numpy's and Python's, the machine, the date."""
    import numpy as np

    from chatterbench.engines.registry import engine_version

    return {"scenes": list(spec.scenes), "engines": list(spec.engines), "search": spec.search_key(),
            "versions": {e: engine_version(e) for e in spec.engines} | {"numpy": np.__version__,
                                                                         "python": platform.python_version()},
            "machine": machine_name(), "command": command, "code": code_version(),
            "started": time.strftime("%Y-%m-%d %H:%M:%S %Z")}


def machine_name() -> str:
    """The machine a case runs on, in words: "x86_64, AMD EPYC, 2 cores" (its architecture, CPU and cores)."""
    return f"{platform.machine()}, {_cpu_name()}, {_cores()} cores"


def code_version(source: Path | None = None) -> str:
    """The code that ran: the git commit of the checkout chatterbench runs from (``+changes`` when it has
    uncommitted ones), else the installed package's version. A checkout is one that tracks ``source`` (this file by
    default): a package installed into a folder that is itself in a git repository (a pyenv, a venv in the user's
    own project) names the package's version, not that repository's commit."""
    import subprocess
    from importlib.metadata import version

    source = Path(__file__).resolve() if source is None else source

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(source.parent), *args], capture_output=True, text=True, timeout=10)

    try:
        if git("ls-files", "--error-unmatch", "--", source.name).returncode == 0:
            head = git("rev-parse", "--short=12", "HEAD")
            dirty = git("status", "--porcelain", "--untracked-files=no")
            if head.returncode == 0:
                return f"git {head.stdout.strip()}" + ("+changes" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        pass
    return f"chatterbench {version('chatterbench')}"


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def _cores() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def open_atlas(out: Path, spec: AtlasSpec, command: str) -> dict[str, Any]:
    """``out``'s provenance: a new atlas's written, a resumed one's read and checked against ``spec`` (the same
    search; the scenes and engines may differ: the union is the atlas)."""
    path = out / SPEC_FILE
    if path.is_symlink():
        raise AtlasError(f"--out {out}: {SPEC_FILE} is a link; an atlas folder holds its own files")
    if path.is_file():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise AtlasError(f"--out {out}: {SPEC_FILE} is not an atlas's ({exc}); name an empty folder") from None
        if not isinstance(old, dict) or old.get("search") != json.loads(json.dumps(spec.search_key())):
            raise AtlasError(f"--out {out}: an atlas with another search is there ({json.dumps((old or {}).get('search'))}); "
                             f"this one is {json.dumps(spec.search_key())}: name another folder")
        merged = {**old, "scenes": _union(old.get("scenes", []), spec.scenes),
                  "engines": _union(old.get("engines", []), spec.engines),
                  "versions": {**old.get("versions", {}), **provenance(spec, command)["versions"]}}
        merged.setdefault("resumed", []).append(time.strftime("%Y-%m-%d %H:%M:%S %Z"))
        _write_json(out, SPEC_FILE, merged)
        return merged
    if (out / "cases").exists():
        raise AtlasError(f"--out {out}: holds cases/ but no {SPEC_FILE}; name an empty folder or an atlas's")
    made = provenance(spec, command)
    _write_json(out, SPEC_FILE, made)
    return made


def _union(old, new) -> list[str]:
    return list(dict.fromkeys([*old, *new]))


def _write_json(out: Path, name: str, value: Any) -> None:
    with staged(out) as stage:
        (stage / name).write_text(json.dumps(value, indent=1, allow_nan=False), encoding="utf-8")


def case_name(source: str) -> str:
    """The name a scene's cases go under (``cases/NAME/ENGINE``): the scene's own ``name``, refused unless it is a
    plain folder name (letters, digits, ``.``, ``_``, ``-``; no path)."""
    from chatterbench.reference.scene import load_scene

    name = load_scene(source).name
    if not NAME.fullmatch(name) or name in (".", ".."):
        raise AtlasError(f"scene {source}: its name {name!r} cannot name an atlas case; use letters, digits, '.', '_' "
                         "and '-' only (the `name` field of the scene file)")
    return name


def run_case(spec: AtlasSpec, scene_name: str, engine: str, executor=None, workers: int | None = None,
             repeats: int = 1, per_point: bool = False) -> tuple[dict[str, Any], Any]:
    """One case: ``tune`` (module docstring) -> (case.json's content, the candidates table or None). A refusal
    or a crash outside a run is the case's ``failed`` outcome, never the atlas's end. ``per_point``: the ladder
    judged one point at a time (``bench atlas``'s baseline; the same answers)."""
    from chatterbench.engines.registry import engine_version, make_settings
    from chatterbench.reference.scene import load_scene

    from .tune import tune
    from .tune.answer import recommended

    start = time.perf_counter()
    scene = load_scene(scene_name)
    base = {"scene": scene.name, "engine": engine, "engine_version": engine_version(engine), "code": code_version(),
            "machine": machine_name()}
    try:
        space = None
        own = {k: v for k, v in spec.fixed.items() if k.split(".", 1)[0] == engine}
        if own:
            from .tune.space import search_space

            space = search_space(engine, scene, spec.tolerances())
            for key, value in own.items():
                if key not in space:
                    raise AtlasError(f"--set {key}={value}: {engine} searches {', '.join(k for k in space if k != 'dt')}")
                space[key] = (getattr(make_settings(engine, None, {key: value}), key.split(".", 1)[1]),)
        result = tune(scene, engine, spec.tolerances(), space=space, executor=executor, workers=workers,
                      repeats=repeats, max_runs=spec.max_runs, max_cost=spec.max_cost,
                      robust_fraction=spec.robust_fraction, transfer=False, per_point=per_point)
    except Exception as exc:  # noqa: BLE001  (a case's failure is recorded; the atlas goes on)
        return {**base, "status": "failed", "message": f"{type(exc).__name__}: {exc}",
                "wall_s": round(time.perf_counter() - start, 2), "runs": 0}, None
    answer = recommended(result)
    status = "ok" if answer is not None else "failed"
    return {**base, "status": status, "message": "" if answer else "no candidate ran: every one was refused",
            "wall_s": round(time.perf_counter() - start, 2), "runs": int(len(result.table)),
            "recommended": answer}, result.table


def run_atlas(out: Path, spec: AtlasSpec, command: str = "", executor=None, workers: int | None = None,
              started: Callable[[str, str, int, int], None] | None = None,
              finished: Callable[[dict[str, Any]], None] | None = None,
              pool: Callable[[], ContextManager[Any]] | None = None, at_once: int = 1,
              expected: Mapping[tuple[str, str], float] | None = None
              ) -> tuple[dict[str, Any], dict[tuple[str, str], dict[str, Any]]]:
    """Run every case of ``spec`` not yet done under ``out`` (module docstring), each written as it finishes;
    returns the atlas's provenance (``open_atlas``: opened once, before any case) and every finished case under
    ``out``. ``started(scene, engine, k, n)`` as case k of the n to run begins, ``finished(case)`` as it ends.
    ``pool``: makes each case's executor (a context manager), a pool of its own per case: its workers hold one
    engine's libraries and what its runs left (Drake keeps ~0.1 MB of every diagram it builds), not every case's
    so far; else ``executor`` serves every case (a Dask cluster's), else each case's ``tune`` makes its own.
    ``at_once``: cases run side by side (``side_by_side``: each in a thread, with its own pool), written in the
    order they end; the same cases whatever it is. As each case is written, ``atlas.json`` gets the atlas's
    ``elapsed_s`` (wall time [s] from this call to the case's end, added to a resumed atlas's before) and
    ``cases_at_once`` (the most that ran side by side): the cases' own ``wall_s`` overlap when they ran together.
    ``expected``: (scene name, engine) -> the wall time [s] a case is expected to take (a kept atlas's): the cases
    run longest first (``longest_first``), so that side by side no long case runs alone at the end."""
    out.mkdir(parents=True, exist_ok=True)
    made = open_atlas(out, spec, command)
    done = done_cases(out)
    names = {source: case_name(source) for source in spec.scenes}
    todo = [(source, engine) for source, engine in spec.cases() if (names[source], engine) not in done]
    if expected:
        todo = longest_first(todo, names, expected)
    number = {item: k for k, item in enumerate(todo, 1)}
    begun, before = time.perf_counter(), made.get("elapsed_s") or 0.0

    def one(item: tuple[str, str]) -> tuple[dict[str, Any], Any]:
        with pool() if pool is not None else nullcontext(executor) as case_executor:
            return run_case(spec, item[0], item[1], executor=case_executor, workers=workers)

    def begin(item: tuple[str, str]) -> None:
        if started is not None:
            started(names[item[0]], item[1], number[item], len(todo))

    def end(item: tuple[str, str], outcome: tuple[dict[str, Any], Any]) -> None:
        case, table = outcome
        write_case(out, case, table)
        done[(names[item[0]], item[1])] = case
        made.update(elapsed_s=round(before + time.perf_counter() - begun, 1),
                    cases_at_once=max(at_once, made.get("cases_at_once") or 1))
        _write_json(out, SPEC_FILE, made)  # the atlas's own wall time so far, kept by a kill as its cases are
        if finished is not None:
            finished(case)

    side_by_side(todo, at_once, one, started=begin, finished=end)
    return made, done


def longest_first(todo: list[tuple[str, str]], names: Mapping[str, str],
                  expected: Mapping[tuple[str, str], float]) -> list[tuple[str, str]]:
    """``todo``'s (scene source, engine) cases, the longest expected first (equal guesses in their order): a case's
    ``expected`` wall time [s] under its (scene name, engine) (``names``: source -> name), else the median of its
    engine's, else of every one's.

        >>> from chatterbench.comparisons.studies.atlas import longest_first
        >>> longest_first([("a", "x"), ("b", "x"), ("c", "y")], {"a": "a", "b": "b", "c": "c"},
        ...               {("a", "x"): 10.0, ("b", "x"): 300.0, ("z", "y"): 50.0})
        [('b', 'x'), ('c', 'y'), ('a', 'x')]
    """
    import statistics

    known = {k: float(v) for k, v in expected.items() if isinstance(v, (int, float)) and math.isfinite(v)}
    if not known:
        return list(todo)
    every = statistics.median(known.values())
    by_engine: dict[str, list[float]] = {}
    for (_, engine), wall in known.items():
        by_engine.setdefault(engine, []).append(wall)

    def guess(item: tuple[str, str]) -> float:
        key = (names[item[0]], item[1])
        if key in known:
            return known[key]
        return statistics.median(by_engine[key[1]]) if key[1] in by_engine else every

    return sorted(todo, key=lambda item: -guess(item))  # stable: equal guesses keep their order


def write_case(out: Path, case: dict[str, Any], table) -> None:
    """A case's files, together (``atomic.staged``): the candidates first, case.json last."""
    folder = case_dir(out, case["scene"], case["engine"])
    folder.mkdir(parents=True, exist_ok=True)
    with staged(folder, last=(CASE_FILE,)) as stage:
        if table is not None:
            write_frame(stage / CANDIDATES_FILE, _flat(table))
        (stage / CASE_FILE).write_text(json.dumps(_json_safe(case), indent=1, allow_nan=False), encoding="utf-8")


def _flat(table):
    """``tune``'s table with its tuple and dict cells as JSON text (Parquet columns of one type)."""
    table = table.copy()
    for c in table.columns:
        if table[c].dtype == object and any(isinstance(v, (tuple, list, dict)) for v in table[c]):
            table[c] = [json.dumps(_json_safe(v)) for v in table[c]]
        elif table[c].dtype == object:
            table[c] = [None if v is None or (isinstance(v, float) and math.isnan(v)) else str(v) for v in table[c]]
    return table


def _json_safe(v: Any) -> Any:
    """``v`` with NaN and infinities as None, tuples as lists, numpy scalars as Python's (JSON without NaN)."""
    if isinstance(v, dict):
        return {str(k): _json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    if hasattr(v, "item") and not isinstance(v, (str, bytes)):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def iter_frontier(case: dict[str, Any]) -> Iterator[dict[str, Any]]:
    """A finished case's frontier points, cheapest first (none for a failed case)."""
    rec = case.get("recommended") or {}
    yield from rec.get("frontier") or []
