"""Accuracy gates for CI: the gate file, its checks and their limits, validated in full before anything runs.

    >>> from chatterbench.comparisons.ci.gate import load_gate, parse_limit
    >>> gate = load_gate("gates/default.toml")
    >>> len(gate.checks), str(gate.checks[0].limits[0])
    (7, 'verdict == match')
    >>> parse_limit("exit_error_max <= 2e-3").holds(1e-3)
    True

``checks.py`` runs a gate, ``decision.py`` decides it once (limits, baseline, failed runs), and
``junit.py`` and ``job_outputs.py`` render that decision.

Gate file format (TOML)::

    description = "what these checks promise"      # optional

    [defaults]                                       # optional: every check inherits these keys
    dt = 1e-4                                        # unless it sets them itself

    [[check]]
    name = "feigin-pair/mujoco"                      # optional, default "SCENE/ENGINE"; unique in the file
    scene = "feigin-pair"                            # built-in scene, or a scene TOML path (relative to this file)
    engine = "mujoco"                                # any engine of the table (registry.ENGINE_NAMES)
    dt = 1e-4                                        # engine timestep [s]; default: the engine's default
    settings = { w0_dt = 0.03 }                      # engine settings by the engine's own names (no prefix)
    scene_overrides = { duration = 20.0, "initial.vy" = 0.0 }   # scene fields by dotted key
    tolerances = { stick = 0.05, exit = 0.02 }       # verdict tolerances (pipeline.tolerances.Tolerances):
                                                     # fractions of each episode's chatter / sliding duration
    limits = [                                       # "METRIC OP VALUE", all must hold
        "verdict == match",
        "exit_error_max <= 2e-3",                    # [s]
        "n_match >= 13",
    ]

Keys of a check: ``name``, ``scene`` (required), ``engine`` (required), ``dt``,
``settings``, ``scene_overrides``, ``tolerances``, ``limits`` (required, at least one).
Nested tables in ``scene_overrides`` are dotted keys too (``initial = { vy = 0.0 }``).

Metrics are the engine's summary row over the scene's episodes (``pipeline.summary``, the
same names ``compare``, ``report``, ``tune`` and sweeps print):

==========================  ======  =====================================================
metric                      kind    operators
==========================  ======  =====================================================
verdict, status             text    ``==``, ``!=``, ``in`` (``verdict in [match, late]``)
exit_error_max [s]          number  ``<=``, ``<``, ``>=``, ``>``, ``==``, ``!=``
stick_error_max [s]         number  (against the Zeno point)
stick_error_plate_max [s]   number  (against Feigin's plate entry)
first_impact_error_max [s]  number
exit_error_rel_max          number  exit error / sliding duration (the exit tolerance's measure)
stick_error_rel_max         number  sticking error / chatter duration (the stick tolerance's measure)
restitution_error_max       number  |effective R / R - 1| of the worst resolved impact
penetration_max [m]         number  deepest penetration of a wall
open_fraction_max           number  the largest share of a rest after a stick the contact is open
onset_rate_max [1/s]        number  the most contact onsets per second after a stick (persistence)
cost_per_sim_s              number  wall-clock s per simulated s (machine-dependent)
n_match, n_episodes         number  integers
stick_error_worst [s]       number  the report's columns: the worst error with its sign
stick_error_rel_worst       number  (engine minus reference; negative: early, or an impact
exit_error_worst [s]        number  that keeps less than R of its speed), |X_worst| = X_max;
exit_error_rel_worst        number  bound them both ways (``stick_error_worst >= -0.01``,
first_impact_error_worst    number  ``stick_error_worst <= 0.01``); the pytest fixture takes
restitution_error_worst     number  them with an operator only (``("<=", 0.01)``)
==========================  ======  =====================================================

The verdicts (``pipeline/vocabulary.py``; ``docs/verdicts.md``) combine into the run's
verdict by severity: the worst episode names it. A failure never passes by omission: when
the run's verdict is a failure class (``crashed``, ``timeout``, ``error``, ``diverged``),
a verdict or status limit holds only if it names that class explicitly (``verdict in
[match, error]``), and a check without such a limit fails. A number limit on a metric that
was not measured (NaN: e.g. no episode exits) fails: nothing measured is not evidence that
the limit holds.

Promises: a gate file is validated in full (keys, types, scenes, engine settings,
tolerances, metrics, operators, values) before any engine runs, and every problem is
reported at once, each naming the file, the check, the key, the value and what is allowed
(``GateError``, exit code 2 in the CLI). Checks that ask for the same run share it.
"""

from __future__ import annotations

import dataclasses
import json
import math
import operator
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS, SIGNED_COLUMNS
from chatterbench.comparisons.pipeline.tolerances import Tolerances, make_tolerances
from chatterbench.comparisons.pipeline.vocabulary import FAILURES, NAMES
from chatterbench.engines.registry import ENGINE_NAMES, make_settings
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.errors import (InputError, check_choice, check_fields, check_number, check_table, check_text,
                                          did_you_mean, is_number, unknown_keys)
from chatterbench.reference.scene import Scene, load_scene
from chatterbench.reference.tables import flatten, parse_toml, printable, read_text

from .gate_lines import check_lines

TEXT_METRICS = {"verdict": NAMES, "status": ("ok", *FAILURES)}
NUMBER_METRICS = (*METRIC_COLUMNS, *SIGNED_COLUMNS, "cost_per_sim_s", "n_match", "n_episodes")
METRICS = tuple(TEXT_METRICS) + NUMBER_METRICS
TEXT_OPS = ("==", "!=", "in")
NUMBER_OPS = ("<=", "<", ">=", ">", "==", "!=")
# the operator a bare value means (pytest fixture keywords): an error or a cost is a ceiling,
# matches a floor, the episode count and the texts exact
DEFAULT_OPS = {"verdict": "==", "status": "==", "n_match": ">=", "n_episodes": "==",
               **{m: "<=" for m in NUMBER_METRICS if m not in ("n_match", "n_episodes", *SIGNED_COLUMNS)}}
_OPS: dict[str, Callable[[Any, Any], bool]] = {
    "<=": operator.le, "<": operator.lt, ">=": operator.ge, ">": operator.gt, "==": operator.eq, "!=": operator.ne,
    "in": lambda a, b: a in b,
}
_LIMIT_RE = re.compile(r"^\s*([A-Za-z_][\w.]*)\s*(<=|>=|==|!=|<|>|\bin\b)\s*(.+?)\s*$")


class GateError(InputError):
    """A gate file or a check that cannot run as written; the message lists every problem (exit code 2)."""

    multiline = True  # one problem per line, by design (keys are quoted with repr, so a line is a problem)


@dataclass(frozen=True)
class Limit:
    """One ``METRIC OP VALUE`` limit."""

    metric: str  # one of METRICS
    op: str  # one of TEXT_OPS or NUMBER_OPS
    value: float | str | tuple[str, ...]  # number [metric's unit], text, or texts for ``in``

    def holds(self, measured: Any) -> bool:
        """Whether ``measured`` satisfies the limit; a NaN number never does, nor a failure class the limit
        does not name (``verdict != late`` does not pass an ``error`` run)."""
        if self.metric in NUMBER_METRICS:
            if measured is None or (isinstance(measured, float) and math.isnan(measured)):
                return False
            return bool(_OPS[self.op](float(measured), float(self.value)))
        if str(measured) in FAILURES and not self.names(str(measured)):
            return False
        return bool(_OPS[self.op](str(measured), self.value))

    def names(self, word: str) -> bool:
        """Does this text limit name ``word`` explicitly?"""
        return word in self.value if isinstance(self.value, tuple) else word == self.value

    def __str__(self) -> str:
        if isinstance(self.value, tuple):
            shown = "[" + ", ".join(self.value) + "]"
        elif isinstance(self.value, float):
            shown = f"{self.value:g}"
        else:
            shown = str(self.value)
        return f"{self.metric} {self.op} {shown}"


@dataclass(frozen=True)
class Check:
    """One validated check: which run, and the limits its summary row must meet."""

    name: str
    scene: Scene
    engine: str  # an engine's registry name (``registry.ENGINE_NAMES``)
    dt: float | None  # [s]; None: the engine's default
    settings: Mapping[str, Any]  # engine settings by the engine's own names
    scene_overrides: Mapping[str, Any]  # dotted scene keys -> values (already applied to ``scene``)
    tolerances: Tolerances
    limits: tuple[Limit, ...]
    source: str = ""  # "FILE, check N" for messages
    line: int = 0  # the line of its [[check]] header in the gate file (from 1; 0: not read from a file)
    limit_lines: tuple[int, ...] = ()  # the line each of ``limits`` is written on (0 where unknown)
    scene_source: str = ""  # the scene as the gate names it: a built-in name or a TOML path (resolved against the file)
    engine_settings: Any = None  # the engine's settings object of ``dt`` and ``settings``, made once by ``make_check``

    def run_key(self) -> str:
        """Identity of the run this check needs (checks with equal keys share one run)."""
        return json.dumps({"scene": self.scene.to_dict(), "engine": self.engine, "dt": self.dt,
                           "settings": dict(self.settings), "tol": self.tolerances.as_dict()}, sort_keys=True, default=repr)


@dataclass(frozen=True)
class Gate:
    """A validated gate file."""

    path: str
    checks: tuple[Check, ...]
    description: str = ""


def parse_limit(text: Any) -> Limit:
    """``"exit_error_max <= 2e-3"`` -> Limit; raises GateError (message without location)."""
    if not isinstance(text, str):
        raise GateError(f"{text!r} is not a string; write limits as \"METRIC OP VALUE\", e.g. \"exit_error_max <= 2e-3\"")
    m = _LIMIT_RE.match(text)
    if not m:
        raise GateError(f"{text!r}: expected \"METRIC OP VALUE\" with OP one of {', '.join(NUMBER_OPS + ('in',))}, "
                        "e.g. \"exit_error_max <= 2e-3\" or \"verdict == match\"")
    metric, op, raw = m.groups()
    return make_limit(metric, op, raw, text=text)


def make_limit(metric: str, op: str, value: Any, text: str | None = None) -> Limit:
    """Validate one limit; ``value`` may be text to parse (from a gate file) or a Python value."""
    where = repr(text) if text is not None else f"{metric} {op} {value!r}"
    if metric not in METRICS:
        raise GateError(f"{where}: unknown metric {metric!r}{did_you_mean(metric, METRICS)}; allowed: {', '.join(METRICS)}")
    if metric in TEXT_METRICS:
        if op not in TEXT_OPS:
            raise GateError(f"{where}: operator {op!r} does not apply to the text metric {metric}; allowed: {', '.join(TEXT_OPS)}")
        allowed = TEXT_METRICS[metric]
        if isinstance(value, str):
            listed = value.strip()
            if op == "in" and not (listed.startswith("[") and listed.endswith("]")):
                raise GateError(f"{where}: '{metric} in' takes a bracketed list, e.g. [{', '.join(allowed[:2])}]")
            if op != "in" and any(c in listed for c in "[],"):
                raise GateError(f"{where}: '{metric} {op}' takes one name; for several write '{metric} in [a, b]'")
            words = [w.strip().strip("'\"") for w in listed[1:-1].split(",")] if op == "in" else [listed.strip("'\"")]
        elif isinstance(value, (list, tuple)) and op == "in":
            words = [str(w) for w in value]
        else:
            raise GateError(f"{where}: {metric} takes a name" + (" list" if op == "in" else "") + f"; allowed: {', '.join(allowed)}")
        words = [w for w in words if w]
        if not words:
            raise GateError(f"{where}: no {metric} given; allowed: {', '.join(allowed)}")
        for w in words:
            if w not in allowed:
                raise GateError(f"{where}: unknown {metric} {w!r}{did_you_mean(w, allowed)}; allowed: {', '.join(allowed)}")
        return Limit(metric, op, tuple(words) if op == "in" else words[0])
    if op not in NUMBER_OPS:
        raise GateError(f"{where}: operator {op!r} does not apply to the number metric {metric}; allowed: {', '.join(NUMBER_OPS)}")
    if isinstance(value, str):
        try:
            number = float(value)
        except ValueError:
            raise GateError(f"{where}: {value!r} is not a number; {metric} takes a number") from None
    elif is_number(value):
        number = float(value)
    else:
        raise GateError(f"{where}: {value!r} is not a number; {metric} takes a number")
    if not math.isfinite(number):
        raise GateError(f"{where}: the limit must be a finite number")
    return Limit(metric, op, number)


def limits_from_keywords(**limits: Any) -> tuple[Limit, ...]:
    """Limits from keywords (the pytest fixture's form): ``exit_error_max=2e-3`` means ``<=``
    (see ``DEFAULT_OPS``), ``verdict="match"`` means ``==``, ``verdict=["match", "late"]``
    means ``in``, and ``n_match=(">=", 12)`` names the operator."""
    out = []
    for metric, value in limits.items():
        if metric not in METRICS:
            raise GateError(f"limit {metric}={value!r}: unknown metric{did_you_mean(metric, METRICS)}; allowed: {', '.join(METRICS)}")
        if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str) and value[0] in _OPS:
            op, v = value
        elif metric in SIGNED_COLUMNS:  # a bare ceiling on a signed error would pass any early one
            raise GateError(f"limit {metric}={value!r}: {metric} is signed (negative: early); name the operator, e.g. "
                            f"{metric}=('>=', -0.01), or limit its magnitude: {metric.replace('_worst', '_max')}={value!r}")
        elif isinstance(value, (list, tuple)) and metric in TEXT_METRICS:
            op, v = "in", list(value)
        else:
            op, v = DEFAULT_OPS[metric], value
        if isinstance(v, str) and metric in NUMBER_METRICS:
            raise GateError(f"limit {metric}={value!r}: {metric} takes a number")
        out.append(make_limit(metric, op, v))
    return tuple(out)


def _scene_source(scene: str, base_dir: Path | None) -> str:
    if scene in CATALOGUE or base_dir is None or not (scene.endswith(".toml") or "/" in scene):
        return scene  # a name: load_scene suggests the nearest built-in one
    path = Path(scene)
    return str(path if path.is_absolute() else base_dir / path)


def _scene_field(where: str, value: Any) -> str | Scene:
    if isinstance(value, Scene):
        return value
    if not isinstance(value, str) or not value:
        raise GateError(f"{where} = {value!r}: must be a built-in scene name ({', '.join(CATALOGUE)}) "
                        "or a scene TOML path")
    return value


def _limits_field(where: str, value: Any) -> tuple[Limit, ...]:
    """Limits, each a ``Limit`` or its text ``"METRIC OP VALUE"``; at least one. Every bad one is a line of the error."""
    if not isinstance(value, (list, tuple)):
        raise GateError(f"{where} = {value!r}: must be a list of \"METRIC OP VALUE\" strings")
    limits, problems = [], []
    for j, item in enumerate(value):
        try:
            limits.append(item if isinstance(item, Limit) else parse_limit(item))
        except GateError as exc:
            problems.append(f"{where}[{j}] {exc}")
    if problems:
        raise GateError("\n".join(problems))
    if not limits:
        raise GateError(f"{where}: at least one limit is needed, e.g. \"verdict == match\"")
    return tuple(limits)


# A check's keys and the check each value goes through (the gate file's [[check]] keys and make_check's arguments).
# What needs two keys at once (the scene with its overrides, the settings with the engine and dt) is checked after.
CHECK_FIELDS: dict[str, Callable[[str, Any], Any]] = {
    "name": lambda where, v: check_text(where, v, GateError),
    "scene": _scene_field,
    "engine": lambda where, v: check_choice(where, v, ENGINE_NAMES, GateError),
    "dt": lambda where, v: check_number(where, v, lo=0.0, lo_open=True, unit=" [s]", error=GateError),
    "settings": lambda where, v: check_table(where, v, GateError),
    "scene_overrides": lambda where, v: check_table(where, v, GateError),
    "tolerances": lambda where, v: v if isinstance(v, Tolerances) else check_table(where, v, GateError),
    "limits": _limits_field,
}
CHECK_KEYS = tuple(CHECK_FIELDS)
REQUIRED_KEYS = ("scene", "engine", "limits")
DEFAULT_KEYS = tuple(k for k in CHECK_KEYS if k not in ("name", "limits"))  # what [defaults] may set


def _check_scene(scene: str | Scene, overrides: Mapping[str, Any], base_dir: Path | None) -> Scene:
    """The check's scene with its overrides applied; the error names which of the two is wrong."""
    try:
        if isinstance(scene, Scene):
            return load_scene(scene.to_dict(), overrides) if overrides else scene
        return load_scene(_scene_source(scene, base_dir), overrides)
    except InputError as exc:
        key = "scene_overrides" if overrides and (isinstance(scene, Scene) or scene in CATALOGUE) else "scene"
        raise GateError(f"{key}: {printable(str(exc))}") from None  # one problem: its quoted key on its line


def _engine_settings(engine: str, dt: float | None, settings: Mapping[str, Any]) -> Any:
    """The engine's settings object of ``dt`` and ``settings`` (by the engine's own names), built once: the TOML edge."""
    if "dt" in settings:
        raise GateError(f"settings.dt = {settings['dt']!r}: set the timestep with the check's own dt key")
    try:
        return make_settings(engine, dt, {f"{engine}.{k}": v for k, v in settings.items()})
    except InputError as exc:  # SettingsError: names the key and what is allowed
        raise GateError(f"settings: {str(exc).removeprefix('--set ')}") from None


def make_check(
    scene: str | Scene,
    engine: str,
    limits: Sequence[Limit | str],
    dt: float | None = None,
    settings: Mapping[str, Any] | None = None,
    scene_overrides: Mapping[str, Any] | None = None,
    tolerances: Mapping[str, Any] | Tolerances | None = None,
    name: str | None = None,
    base_dir: Path | None = None,
    source: str = "",
    base_tolerances: Tolerances | None = None,
) -> Check:
    """Validate one check's parts (scene loads, settings build, tolerances hold) without running it.

    Each part goes through its entry of ``CHECK_FIELDS``; ``limits`` are ``Limit`` objects or
    their text. ``tolerances`` are applied over ``base_tolerances`` (default: ``Tolerances()``;
    the command line's ``--tolerance``). Raises GateError listing every problem; ``source``
    ("FILE, check N") prefixes each.
    """
    given = {"name": name, "scene": scene, "engine": engine, "dt": dt, "settings": settings,
             "scene_overrides": scene_overrides, "tolerances": tolerances, "limits": limits}
    present = {k: v for k, v in given.items() if v is not None or k in REQUIRED_KEYS}  # None: the default
    problems: list[str] = []
    ok = check_fields(present, CHECK_FIELDS, problems=problems)
    refused = set(present) - set(ok)
    overrides = flatten(ok.get("scene_overrides", {}))
    settings = dict(ok.get("settings", {}))
    made: dict[str, Any] = {}
    steps = {  # the parts that need two keys: run when those keys passed their own checks
        "scene": (("scene", "scene_overrides"), lambda: _check_scene(ok["scene"], overrides, base_dir)),
        "engine_settings": (("engine", "dt", "settings"),
                            lambda: _engine_settings(ok["engine"], ok.get("dt"), settings)),
        "tolerances": (("tolerances",), lambda: ok["tolerances"] if isinstance(ok.get("tolerances"), Tolerances)
                       else make_tolerances(ok.get("tolerances"), base=base_tolerances)),
    }
    for part, (needs, make) in steps.items():
        if not refused & set(needs):
            try:
                made[part] = make()
            except InputError as exc:  # GateError, and ToleranceError: each names the key and what is allowed
                # another reader's refusal is one problem: a line break in the key it quotes stays on its line
                problems.append(str(exc) if isinstance(exc, GateError) else printable(str(exc)))
    if problems:
        pre = f"{source}: " if source else ""
        raise GateError("\n".join(pre + p for p in problems))
    return Check(name=name or f"{made['scene'].name}/{engine}", scene=made["scene"], engine=engine,
                 dt=None if dt is None else float(dt), settings=settings, scene_overrides=overrides,
                 tolerances=made["tolerances"], limits=ok["limits"], source=source,
                 scene_source=_scene_source(scene, base_dir) if isinstance(scene, str) else "",
                 engine_settings=made["engine_settings"])


def _check_tables(where: str, value: Any) -> list[Mapping[str, Any]]:
    if not isinstance(value, list) or not all(isinstance(c, Mapping) for c in value):
        raise GateError(f"{where} must be an array of tables, each written [[check]]")
    return value


# The gate file's top-level keys and their checks; each [[check]] table is read by make_check (CHECK_FIELDS).
TOP_FIELDS: dict[str, Callable[[str, Any], Any]] = {
    "description": lambda where, v: check_text(where, v, GateError),
    "defaults": lambda where, v: check_table(where, v, GateError),
    "check": _check_tables,
}
TOP_KEYS = tuple(TOP_FIELDS)


def _read_check(i: int, raw: Mapping[str, Any], defaults: Mapping[str, Any], path: str, base_dir: Path | None,
                base_tolerances: Tolerances | None) -> Check:
    """Check ``i`` (from 1) of the file: its own keys over ``[defaults]``; GateError with every problem."""
    label = f"{path}, check {i}" + (f" ({raw['name']!r})" if isinstance(raw.get("name"), str) else "")
    entry = {**{k: v for k, v in defaults.items() if k in DEFAULT_KEYS}, **raw}
    problems = [f"{label}: {m}" for m in unknown_keys(raw, CHECK_KEYS)]
    problems += [f"{label}: {key} is required" for key in REQUIRED_KEYS if key not in entry]
    if problems:
        raise GateError("\n".join(problems))
    return make_check(**entry, base_dir=base_dir, source=label, base_tolerances=base_tolerances)


def parse_gate(data: Mapping[str, Any], path: str = "<gate>", base_dir: Path | None = None,
               base_tolerances: Tolerances | None = None, text: str | None = None) -> Gate:
    """Validate gate data (the TOML layout of the module docstring); raises GateError with every problem.

    ``base_tolerances`` (the command line's ``--tolerance``) are what a check's own
    ``tolerances`` table, and the file's ``[defaults]``, are applied over. ``text``: the file's
    text, whose lines each check and limit keeps (``gate_lines``: where annotations point)."""
    problems = [f"{path}: {m} (each check is a [[check]] table)" for m in unknown_keys(data, TOP_KEYS, "top-level key")]
    found: list[str] = []
    top = check_fields({k: v for k, v in data.items() if k in TOP_FIELDS}, TOP_FIELDS, problems=found)
    problems += [f"{path}: {m}" for m in found]
    defaults = top.get("defaults", {})
    problems += [f"{path}, [defaults]: {m}" for m in unknown_keys(defaults, DEFAULT_KEYS)]
    if not top.get("check") and not problems:
        problems.append(f"{path}: no checks; add at least one [[check]] table with scene, engine and limits")
    checks, names = [], {}
    raws = top.get("check", [])
    lines = check_lines(text, [[t for t in raw.get("limits", []) if isinstance(t, str)]
                               if isinstance(raw.get("limits"), list) else [] for raw in raws]) if text else []
    for i, raw in enumerate(raws, 1):
        try:
            check = _read_check(i, raw, defaults, path, base_dir, base_tolerances)
        except GateError as exc:
            problems.extend(str(exc).splitlines())
            continue
        if lines:
            check = dataclasses.replace(check, line=lines[i - 1][0], limit_lines=lines[i - 1][1])
        if check.name in names:
            problems.append(f"{check.source}: name {check.name!r} is already used by check {names[check.name]}; "
                            "give each check a unique name (JUnit reports them by name)")
            continue
        names[check.name] = i
        checks.append(check)
    if problems:
        raise GateError(f"{len(problems)} problem{'s' if len(problems) > 1 else ''} in the gate file:\n  " + "\n  ".join(problems))
    return Gate(path=path, checks=tuple(checks), description=top.get("description", ""))


def load_gate(path: str | Path, base_tolerances: Tolerances | None = None) -> Gate:
    """Read and validate a gate file; raises GateError (unreadable, not TOML, or any invalid check)."""
    path = Path(path)
    what = f"gate file {str(path)!r}"
    text = read_text(path, what, GateError)
    return parse_gate(parse_toml(text, what, GateError), str(path), path.parent, base_tolerances, text)
