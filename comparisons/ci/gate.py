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
cost_per_sim_s              number  wall-clock s per simulated s (machine-dependent)
n_match, n_episodes         number  integers
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

import json
import math
import operator
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS
from chatterbench.comparisons.pipeline.tolerances import Tolerances, make_tolerances
from chatterbench.comparisons.pipeline.vocabulary import FAILURES, NAMES
from chatterbench.engines.registry import ENGINE_NAMES, make_settings
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.errors import InputError, did_you_mean, is_number
from chatterbench.reference.scene import Scene, load_scene
from chatterbench.reference.tables import flatten, read_toml

TEXT_METRICS = {"verdict": NAMES, "status": ("ok", *FAILURES)}
NUMBER_METRICS = (*METRIC_COLUMNS, "cost_per_sim_s", "n_match", "n_episodes")
METRICS = tuple(TEXT_METRICS) + NUMBER_METRICS
TEXT_OPS = ("==", "!=", "in")
NUMBER_OPS = ("<=", "<", ">=", ">", "==", "!=")
# the operator a bare value means (pytest fixture keywords): an error or a cost is a ceiling,
# matches a floor, the episode count and the texts exact
DEFAULT_OPS = {"verdict": "==", "status": "==", "n_match": ">=", "n_episodes": "==",
               **{m: "<=" for m in NUMBER_METRICS if m not in ("n_match", "n_episodes")}}
CHECK_KEYS = ("name", "scene", "engine", "dt", "settings", "scene_overrides", "tolerances", "limits")
TOP_KEYS = ("description", "defaults", "check")
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
    scene_source: str = ""  # the scene as the gate names it: a built-in name or a TOML path (resolved against the file)

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


def make_check(
    scene: str | Scene,
    engine: str,
    limits: Sequence[Limit],
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

    ``tolerances`` are applied over ``base_tolerances`` (default: ``Tolerances()``; the
    command line's ``--tolerance``). Raises GateError listing every problem; ``source``
    ("FILE, check N") prefixes each.
    """
    problems: list[str] = []
    pre = f"{source}: " if source else ""
    scene_obj = None
    overrides = flatten(scene_overrides or {})
    if isinstance(scene, Scene):
        scene_obj = scene if not overrides else None
        if overrides:
            try:
                scene_obj = load_scene(scene.to_dict(), overrides)
            except InputError as exc:
                problems.append(f"{pre}scene_overrides: {exc}")
    elif not isinstance(scene, str) or not scene:
        problems.append(f"{pre}scene = {scene!r}: must be a built-in scene name ({', '.join(CATALOGUE)}) or a scene TOML path")
    else:
        try:
            scene_obj = load_scene(_scene_source(scene, base_dir), overrides)
        except InputError as exc:
            problems.append(f"{pre}{'scene_overrides' if overrides and scene in CATALOGUE else 'scene'}: {exc}")
    if not isinstance(engine, str) or engine not in ENGINE_NAMES:
        problems.append(f"{pre}engine = {engine!r}: must be one of {', '.join(ENGINE_NAMES)}"
                        + (did_you_mean(engine, ENGINE_NAMES) if isinstance(engine, str) else ""))
    if dt is not None and (not is_number(dt) or not math.isfinite(dt) or dt <= 0):
        problems.append(f"{pre}dt = {dt!r}: must be a finite number > 0 [s]")
    settings = dict(settings or {})
    if "dt" in settings:
        problems.append(f"{pre}settings.dt = {settings['dt']!r}: set the timestep with the check's own dt key")
    elif engine in ENGINE_NAMES and (dt is None or (is_number(dt) and dt > 0)):
        try:
            make_settings(engine, dt, {f"{engine}.{k}": v for k, v in settings.items()})
        except InputError as exc:  # SettingsError: names the key and what is allowed
            problems.append(f"{pre}settings: {str(exc).removeprefix('--set ')}")
    tol = None
    if isinstance(tolerances, Tolerances):
        tol = tolerances
    else:
        try:
            tol = make_tolerances(tolerances, base=base_tolerances)
        except InputError as exc:  # ToleranceError: names the key and what is allowed
            problems.append(f"{pre}{exc}")
    if not limits:
        problems.append(f"{pre}limits: at least one limit is needed, e.g. \"verdict == match\"")
    if problems:
        raise GateError("\n".join(problems))
    return Check(name=name or f"{scene_obj.name}/{engine}", scene=scene_obj, engine=engine,
                 dt=None if dt is None else float(dt), settings=settings, scene_overrides=overrides,
                 tolerances=tol, limits=tuple(limits), source=source,
                 scene_source=_scene_source(scene, base_dir) if isinstance(scene, str) else "")


def parse_gate(data: Mapping[str, Any], path: str = "<gate>", base_dir: Path | None = None,
               base_tolerances: Tolerances | None = None) -> Gate:
    """Validate gate data (the TOML layout of the module docstring); raises GateError with every problem.

    ``base_tolerances`` (the command line's ``--tolerance``) are what a check's own
    ``tolerances`` table, and the file's ``[defaults]``, are applied over."""
    problems: list[str] = []
    for key in data:
        if key not in TOP_KEYS:
            problems.append(f"{path}: unknown top-level key {key!r}{did_you_mean(key, TOP_KEYS)}; allowed: {', '.join(TOP_KEYS)}"
                            " (each check is a [[check]] table)")
    description = data.get("description", "")
    if not isinstance(description, str):
        problems.append(f"{path}: description = {description!r}: must be a string")
    defaults = data.get("defaults", {})
    if not isinstance(defaults, Mapping):
        problems.append(f"{path}: defaults must be a table ([defaults]), got {defaults!r}")
        defaults = {}
    for key in defaults:
        if key not in CHECK_KEYS or key in ("name", "limits"):
            allowed = [k for k in CHECK_KEYS if k not in ("name", "limits")]
            problems.append(f"{path}, [defaults]: unknown key {key!r}{did_you_mean(key, allowed)}; allowed: {', '.join(allowed)}")
    checks_data = data.get("check", [])
    if not isinstance(checks_data, list) or not all(isinstance(c, Mapping) for c in checks_data):
        problems.append(f"{path}: check must be an array of tables, each written [[check]]")
        checks_data = []
    if not checks_data and not problems:
        problems.append(f"{path}: no checks; add at least one [[check]] table with scene, engine and limits")
    checks, names = [], {}
    for i, raw in enumerate(checks_data, 1):
        label = f"{path}, check {i}" + (f" ({raw['name']!r})" if isinstance(raw.get("name"), str) else "")
        entry = {**{k: v for k, v in defaults.items() if k in CHECK_KEYS}, **raw}
        bad = False
        for key in raw:
            if key not in CHECK_KEYS:
                problems.append(f"{label}: unknown key {key!r}{did_you_mean(key, CHECK_KEYS)}; allowed: {', '.join(CHECK_KEYS)}")
                bad = True
        for key in ("scene", "engine", "limits"):
            if key not in entry:
                problems.append(f"{label}: {key} is required")
                bad = True
        for key in ("settings", "scene_overrides", "tolerances"):
            if key in entry and not isinstance(entry[key], Mapping):
                problems.append(f"{label}: {key} = {entry[key]!r}: must be a table, e.g. {key} = {{ key = value }}")
                bad = True
        for key in ("name", "scene", "engine"):
            if key in entry and not isinstance(entry[key], str):
                problems.append(f"{label}: {key} = {entry[key]!r}: must be a string")
                bad = True
        if "dt" in entry and not is_number(entry["dt"]):
            problems.append(f"{label}: dt = {entry['dt']!r}: must be a number [s]")
            bad = True
        limits = []
        raw_limits = entry.get("limits", [])
        if not isinstance(raw_limits, list):
            problems.append(f"{label}: limits = {raw_limits!r}: must be a list of \"METRIC OP VALUE\" strings")
            bad = True
        else:
            for j, text in enumerate(raw_limits):
                try:
                    limits.append(parse_limit(text))
                except GateError as exc:
                    problems.append(f"{label}: limits[{j}] {exc}")
                    bad = True
        if bad:
            continue
        try:
            check = make_check(entry["scene"], entry["engine"], limits, dt=entry.get("dt"), settings=entry.get("settings"),
                               scene_overrides=entry.get("scene_overrides"), tolerances=entry.get("tolerances"),
                               name=entry.get("name"), base_dir=base_dir, source=label, base_tolerances=base_tolerances)
        except GateError as exc:
            problems.extend(str(exc).splitlines())
            continue
        if check.name in names:
            problems.append(f"{label}: name {check.name!r} is already used by check {names[check.name]}; "
                            "give each check a unique name (JUnit reports them by name)")
            continue
        names[check.name] = i
        checks.append(check)
    if problems:
        raise GateError(f"{len(problems)} problem{'s' if len(problems) > 1 else ''} in the gate file:\n  " + "\n  ".join(problems))
    return Gate(path=path, checks=tuple(checks), description=description)


def load_gate(path: str | Path, base_tolerances: Tolerances | None = None) -> Gate:
    """Read and validate a gate file; raises GateError (unreadable, not TOML, or any invalid check)."""
    path = Path(path)
    data = read_toml(path, f"gate file {str(path)!r}", GateError)
    return parse_gate(data, str(path), path.parent, base_tolerances)
