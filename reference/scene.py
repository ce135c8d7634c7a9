"""The scene: two masses on a line with a gap, forces and restitution, in SI units.

    >>> from chatterbench.reference.scene import load_scene
    >>> scene = load_scene("feigin-pair", overrides=["restitution=0.8"])
    >>> scene.mu, scene.gap.upper
    (1.0, 0.1)

A scene is the two-mass system of Feigin (1967), section 1, written in SI units::

    m1 x1'' = F1 + F12,        m2 x2'' = F2 - F12,        y = x2 - x1 in [lower, upper]

``F12`` is the coupling force acting on body 1 (positive F12 pulls the bodies together
while y > 0); ``F1``, ``F2`` are all other forces on body 1 and body 2.  Every force is
a small declarative term that is linear in the state or a known function of time, which
is what lets the reference integrate free flight in closed form.

Sign conventions (all SI):

- ``gravity``: g [m/s^2] along x, < 0 toward -x: F = m g on body 2, and on body 1 when ``mass1``
  is finite (an infinite body 1 is kinematic); it follows the mass, a constant force does not.
- ``constant``: F = value [N] on the body (``coupling``: F12 = value), whatever the mass.
- ``harmonic``: F = amplitude * sin(omega * t + phase) [N, rad/s, rad].
- ``spring``: on body b, F = -stiffness * (x_b - rest); on ``coupling``,
  F12 = stiffness * (y - rest) [N/m, m] (a spring between the bodies whose natural
  separation is ``rest``; a rest below the wall means a preload pulling them together).
- ``damper``: on body b, F = -damping * v_b; on ``coupling``, F12 = damping * vy [N s/m].
- ``prescribed``: with ``mass1 = inf``, body 1 moves as
  x1(t) = offset + amplitude * sin(omega * t + phase) [m, rad/s, rad]; without it an
  infinite body 1 is fixed.

Promises: a ``Scene`` is frozen and validated on construction; every refusal is a
``SceneError`` naming the field, the value and what is allowed. Its parts (the force terms, the
prescribed motion, the gap, the initial state) are ``scene_parts``'s.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from .errors import check_number, check_text, did_you_mean
from .scene_parts import BODIES, FORCE_KINDS, Force, Gap, Initial, Prescribed, SceneError, finite, positive
from .tables import TooDeep, loads, printable, read_toml

# a run's duration spans at least this many float spacings at its start and end times (times resolve to 1e-9 of it)
TIME_RESOLUTION = 1e9


@dataclass(frozen=True)
class Scene:
    """A validated two-mass scene (see the module docstring for the model and signs)."""

    name: str  # shown in tables, reports and file names
    mass1: float  # [kg], > 0; math.inf: body 1 fixed or prescribed
    mass2: float  # [kg], > 0 and finite
    restitution: float  # Newton's R, 0 <= R < 1
    gap: Gap
    forces: tuple[Force, ...] = ()
    gravity: float = 0.0  # g [m/s^2] along x on every body that moves (F = m g), < 0 toward -x
    prescribed: Prescribed | None = None  # only with mass1 = inf
    initial: Initial = field(default_factory=Initial)
    duration: float = 1.0  # [s], > 0
    description: str = ""  # one line: what the scene is (the head of scenes --toml's file)
    notes: tuple[str, ...] = field(default=(), compare=False)  # how a file was read (weight.py), not compared

    def __post_init__(self) -> None:
        if isinstance(self.mass1, bool) or not isinstance(self.mass1, (int, float)):
            raise SceneError(f"mass1 = {self.mass1!r}: must be a number > 0 or \"inf\"")
        if math.isnan(self.mass1) or self.mass1 <= 0:
            raise SceneError(f"mass1 = {self.mass1!r}: must be > 0 (or \"inf\" for a fixed/prescribed body 1)")
        object.__setattr__(self, "mass1", float(self.mass1))
        object.__setattr__(self, "mass2", positive("mass2", self.mass2))
        r = finite("restitution", self.restitution)
        if not 0.0 <= r < 1.0:
            raise SceneError(f"restitution = {r!r}: must be in [0, 1)")
        object.__setattr__(self, "restitution", r)
        object.__setattr__(self, "duration", positive("duration", self.duration))
        g = check_number("gravity", self.gravity, unit=" [m/s^2] (along x, < 0 toward -x)", error=SceneError)
        if not math.isfinite(g * (m := max(self.mass2, self.mass1 if math.isfinite(self.mass1) else 0.0))):
            raise SceneError(f"gravity = {g!r}: the weight of the {m:g} kg body overflows; keep |gravity| below {1e308 / m:.3g} m/s^2")
        object.__setattr__(self, "gravity", g)
        object.__setattr__(self, "notes", tuple(map(str, self.notes)))
        t_end = self.initial.t + self.duration  # times are floats: the run's span must resolve at its start
        if not self.duration >= TIME_RESOLUTION * math.ulp(max(abs(self.initial.t), abs(t_end))):
            raise SceneError(f"initial.t = {self.initial.t!r}: too far from 0 for a run of duration {self.duration:g} s "
                             f"(times near it are spaced {math.ulp(abs(self.initial.t)):.3g} s apart); keep |initial.t| "
                             f"below {self.duration / TIME_RESOLUTION / 2.2e-16:.3g} s")
        object.__setattr__(self, "forces", tuple(self.forces))
        for f in self.forces:
            if not isinstance(f, Force):
                raise SceneError(f"forces: {f!r} is not a Force")
        if self.prescribed is not None and math.isfinite(self.mass1):
            raise SceneError("prescribed: needs mass1 = \"inf\" (a prescribed body has no finite mass)")
        if not math.isfinite(self.mass1):
            for f in self.forces:
                if f.on == "body1":
                    raise SceneError(
                        f"forces: a {f.kind} force on body1 has no effect when mass1 = inf; "
                        "move it to body2/coupling or give body 1 a finite mass"
                    )
            x1, v1 = self.body1_motion(self.initial.t)
            if abs(self.initial.x1 - x1) > 1e-9 * max(1.0, abs(x1)) or abs(self.initial.v1 - v1) > 1e-9 * max(1.0, abs(v1)):
                raise SceneError(
                    f"initial.x1 = {self.initial.x1!r}, initial.v1 = {self.initial.v1!r}: body 1 is "
                    f"{'prescribed' if self.prescribed else 'fixed'}, so they must be x1 = {x1!r}, v1 = {v1!r} at t = {self.initial.t!r}"
                )
        lo, hi = self.gap.lower, self.gap.upper
        y0 = self.initial.y
        if y0 < lo or (hi is not None and y0 > hi):
            allowed = f"[{lo!r}, {hi!r}]" if hi is not None else f">= {lo!r}"
            raise SceneError(f"initial.y = {y0!r}: must lie in the gap, {allowed}")

    # -- derived quantities -------------------------------------------------------
    @property
    def mu(self) -> float:
        """Mass ratio mu = m2 / m1 (0 when body 1 is infinite)."""
        return self.mass2 / self.mass1

    @property
    def body1_infinite(self) -> bool:
        """True when body 1 is fixed or prescribed (mass1 = inf)."""
        return not math.isfinite(self.mass1)

    def body1_motion(self, t: float) -> tuple[float, float]:
        """(x1, v1) of an infinite body 1 at time t [m, m/s]; only for mass1 = inf."""
        if self.prescribed is None:
            return self.initial.x1, 0.0
        return self.prescribed.position(t), self.prescribed.velocity(t)

    @property
    def forcing_omegas(self) -> tuple[float, ...]:
        """Distinct angular frequencies of the time forcing [rad/s], sorted."""
        om = {f.omega for f in self.forces if f.kind == "harmonic"}
        if self.prescribed is not None:
            om.add(self.prescribed.omega)
        return tuple(sorted(om))

    @property
    def time_scale(self) -> float:
        """A characteristic time [s]: the longest forcing period, else the duration."""
        om = self.forcing_omegas
        return 2.0 * math.pi / min(om) if om else self.duration

    @property
    def t_end(self) -> float:
        """End time of the run [s]."""
        return self.initial.t + self.duration

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (the TOML layout); ``mass1 = inf`` becomes the string ``"inf"``."""
        d = dataclasses.asdict(self)
        del d["notes"]
        if not math.isfinite(self.mass1):
            d["mass1"] = "inf"
        if self.gap.upper is None:
            del d["gap"]["upper"]
        if self.prescribed is None:
            del d["prescribed"]
        d["forces"] = [{k: f[k] for k in ("kind", "on", *Force._PARAMS[f["kind"]])} for f in d["forces"]]
        return d


# -- building scenes from plain data (TOML, catalogue, --set) ---------------------

_TOP_KEYS = ("name", "mass1", "mass2", "restitution", "gap", "forces", "gravity", "prescribed", "initial", "duration", "description")
_SECTION_KEYS = {
    "gap": tuple(f.name for f in dataclasses.fields(Gap)),
    "initial": tuple(f.name for f in dataclasses.fields(Initial)),
    "prescribed": tuple(f.name for f in dataclasses.fields(Prescribed)),
}


def _mass1(value: Any) -> float:
    if isinstance(value, str):
        if value.strip().lower() in ("inf", "infinity"):
            return math.inf
        raise SceneError(f"mass1 = {value!r}: must be a number > 0 or \"inf\"")
    return value


def _section(name: str, cls: type, data: Any) -> Any:
    if not isinstance(data, Mapping):
        raise SceneError(f"{name} = {data!r}: must be a table with keys {', '.join(_SECTION_KEYS[name])}")
    for k in data:
        if k not in _SECTION_KEYS[name]:
            raise SceneError(
                f"{name}.{printable(k)}: unknown key; allowed: {', '.join(_SECTION_KEYS[name])}"
                + did_you_mean(str(k), _SECTION_KEYS[name])
            )
    try:
        return cls(**data)
    except TypeError as exc:  # pragma: no cover - keys are checked above
        raise SceneError(f"{name}: {exc}") from None


def _force(i: int, data: Any) -> Force:
    where = f"forces[{i}]"
    if not isinstance(data, Mapping):
        raise SceneError(f"{where} = {data!r}: must be a table with 'kind', 'on' and its parameters")
    kind = data.get("kind")
    if kind not in FORCE_KINDS:
        raise SceneError(
            f"{where}.kind = {kind!r}: must be one of {', '.join(FORCE_KINDS)}" + did_you_mean(str(kind), FORCE_KINDS)
        )
    allowed = ("kind", "on", *Force._PARAMS[kind])
    for k in data:
        if k not in allowed:
            raise SceneError(
                f"{where}.{printable(k)}: unknown key for a {kind} force; allowed: {', '.join(allowed)}" + did_you_mean(str(k), allowed)
            )
    if "on" not in data:
        raise SceneError(f"{where}.on: missing; must be one of {', '.join(BODIES)}")
    try:
        return Force(**data)
    except SceneError as exc:
        raise SceneError(f"{where}: {exc}") from None


def scene_from_dict(data: Mapping[str, Any]) -> Scene:
    """Build and validate a Scene from plain data (the TOML layout).

    Raises
    ------
    SceneError
        For unknown keys, missing fields, wrong types and out-of-range values.
    """
    if not isinstance(data, Mapping):
        raise SceneError(f"scene must be a table, got {type(data).__name__}")
    for k in data:
        if k not in _TOP_KEYS:
            raise SceneError(f"{printable(k)}: unknown key; allowed: {', '.join(_TOP_KEYS)}" + did_you_mean(str(k), _TOP_KEYS))
    for k in ("mass1", "mass2", "restitution", "gap"):
        if k not in data:
            raise SceneError(f"{k}: missing (required fields: mass1, mass2, restitution, gap)")
    forces = data.get("forces", [])
    if not isinstance(forces, (list, tuple)):
        raise SceneError(f"forces = {forces!r}: must be an array of tables")
    prescribed = data.get("prescribed")
    return Scene(
        name=check_text("name", data.get("name", "scene"), SceneError),
        mass1=_mass1(data["mass1"]),
        mass2=data["mass2"],
        restitution=data["restitution"],
        gap=_section("gap", Gap, data["gap"]),
        forces=tuple(_force(i, f) for i, f in enumerate(forces)),
        gravity=data.get("gravity", 0.0),
        prescribed=None if prescribed is None else _section("prescribed", Prescribed, prescribed),
        initial=_section("initial", Initial, data.get("initial", {})),
        duration=data.get("duration", 1.0),
        description=check_text("description", data.get("description", ""), SceneError),  # [1, 2] is no description
    )


def parse_value(text: str) -> Any:
    """Parse the right-hand side of ``--set key=value`` as a TOML value (bare words stay strings)."""
    text = text.strip()
    try:
        table = loads(f"v = {text}")
    except TooDeep:  # not a bare word: split_assignment names the key
        raise
    except (tomllib.TOMLDecodeError, ValueError):  # ValueError: an integer past Python's 4300 digits
        return text
    return table["v"] if len(table) == 1 else text


def split_assignment(item: str) -> tuple[str, Any]:
    """Split ``"a.b=value"`` into ``("a.b", parsed value)``; raises SceneError when malformed."""
    if "=" not in item:
        raise SceneError(f"--set {item!r}: expected KEY=VALUE, e.g. restitution=0.8")
    if any(c in item for c in "\n\r\v\f\x00"):
        raise SceneError(f"--set {item!r}: one KEY=VALUE per --set, on one line (a line break or NUL is in it)")
    key, _, value = item.partition("=")
    key = key.strip()
    if not key:
        raise SceneError(f"--set {item!r}: empty key")
    try:
        return key, parse_value(value)
    except TooDeep as exc:
        raise SceneError(f"--set {key}: {exc}") from None


def apply_overrides(data: Mapping[str, Any], overrides: Sequence[str] | Mapping[str, Any]) -> dict[str, Any]:
    """Return a deep copy of scene data with dotted-key overrides applied.

    ``overrides`` is a sequence of ``"key=value"`` strings or a mapping of dotted keys.
    Keys address tables (``initial.vy``, ``gap.upper``) and forces by index
    (``forces.0.amplitude``). Unknown keys are refused with the nearest valid name.
    """
    import copy

    out = copy.deepcopy(dict(data))
    items = overrides.items() if isinstance(overrides, Mapping) else (split_assignment(s) for s in overrides)
    for key, value in items:
        parts = key.split(".")
        if parts[0] not in _TOP_KEYS or parts[0] == "name":
            raise SceneError(f"--set {key}: unknown scene key; allowed: {', '.join(_TOP_KEYS[1:])}" + did_you_mean(parts[0], _TOP_KEYS))
        if len(parts) == 1:
            if parts[0] in ("gap", "initial", "prescribed", "forces"):
                raise SceneError(f"--set {key}: {parts[0]} is a table; set one of its keys, e.g. {parts[0]}.{(_SECTION_KEYS.get(parts[0]) or ('0.amplitude',))[0]}")
            out[parts[0]] = value
        elif parts[0] == "forces":
            forces = out.get("forces", [])
            if len(parts) != 3 or not (parts[1].isascii() and parts[1].isdigit()) or int(parts[1]) >= len(forces):
                raise SceneError(f"--set {key}: forces are addressed as forces.N.param with N in 0..{len(forces) - 1}")
            forces[int(parts[1])] = {**forces[int(parts[1])], parts[2]: value}
        elif parts[0] in _SECTION_KEYS and len(parts) == 2:
            if parts[1] not in _SECTION_KEYS[parts[0]]:
                raise SceneError(
                    f"--set {key}: unknown key; allowed: "
                    + ", ".join(f"{parts[0]}.{k}" for k in _SECTION_KEYS[parts[0]])
                    + did_you_mean(parts[1], _SECTION_KEYS[parts[0]])
                )
            section = dict(out.get(parts[0]) or {})
            section[parts[1]] = value
            out[parts[0]] = section
        else:
            raise SceneError(f"--set {key}: unknown scene key")
    return out


def load_scene(source: str | Path | Mapping[str, Any], overrides: Sequence[str] | Mapping[str, Any] = ()) -> Scene:
    """Load a scene by catalogue name, from a TOML file, or from plain data, then apply overrides.

    A TOML file's constant force that is a body's weight m g (g = +-9.81, +-9.80665 m/s^2) is read as
    ``gravity`` before the overrides, and ``notes`` says so (``weight.weights_as_gravity``).

    Raises
    ------
    SceneError
        Unknown scene name, unreadable or malformed TOML, or any invalid field.
    """
    from .catalogue import CATALOGUE
    from .weight import weights_as_gravity

    notes: tuple[str, ...] = ()  # how a file's weights were read
    if isinstance(source, Mapping):
        data = dict(source)
    elif str(source) in CATALOGUE:
        data = CATALOGUE[str(source)]
    else:
        path = Path(source)
        if not path.suffix == ".toml" and not path.exists():
            raise SceneError(
                f"scene {str(source)!r}: not a built-in scene ({', '.join(CATALOGUE)}) nor a TOML file"
                + did_you_mean(str(source), list(CATALOGUE))
            )
        data = read_toml(path, f"scene file {str(path)!r}", SceneError)
        data.setdefault("name", path.stem)
        data, notes = weights_as_gravity(data, scene_from_dict)
    data = apply_overrides(data, overrides)
    scene = scene_from_dict(data)
    return dataclasses.replace(scene, notes=notes) if notes else scene
