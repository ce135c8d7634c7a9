"""A scene as a commented TOML file to start from: every field, its unit and its sign convention.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.reference.scene_toml import scene_toml
    >>> text = scene_toml(load_scene("bouncing-ball"))
    >>> print(text.splitlines()[0])
    # bouncing-ball: 1 kg ball dropped from 1 m on a fixed floor under gravity; Zeno point t1 (1+R)/(1-R) (edit and run: chatterbench run FILE)
    >>> import tomllib
    >>> from chatterbench.reference.scene import scene_from_dict
    >>> scene_from_dict(tomllib.loads(text)) == load_scene("bouncing-ball")
    True

Numbers are written with ``repr``, so reading the file back gives the same floats bit for
bit, and a run of the file gives the same event log as a run of the scene it came from
(tested for every built-in scene). The layout is the one ``scene.py`` reads.
"""

from __future__ import annotations

import math
from typing import Any

from .scene import Scene
from .scene_parts import Force

# key -> (unit, what it means); units in SI
FIELDS = {
    "mass1": ("kg", "body 1; \"inf\" for a fixed or prescribed body"),
    "mass2": ("kg", "body 2, finite"),
    "restitution": ("1", "Newton's R at every impact, 0 <= R < 1"),
    "duration": ("s", "simulated time from initial.t"),
    "gravity": ("m/s^2", "acceleration along x of every body that moves (force m g); < 0 toward -x, 0: none"),
    "lower": ("m", "the wall y = x2 - x1 >= lower"),
    "upper": ("m", "the wall y <= upper; leave out for a one-sided gap"),
    "t": ("s", "start time (the forcing phase is omega * t + phase)"),
    "x1": ("m", "body 1 position"),
    "v1": ("m/s", "body 1 velocity"),
    "y": ("m", "gap y = x2 - x1, inside [lower, upper]"),
    "vy": ("m/s", "relative velocity y'"),
    "value": ("N", "constant force on the body (coupling: F12, positive pulls the bodies together)"),
    "amplitude": ("N", "F = amplitude * sin(omega * t + phase)"),
    "omega": ("rad/s", "angular frequency"),
    "phase": ("rad", "phase at t = 0"),
    "stiffness": ("N/m", "body: F = -stiffness * (x - rest); coupling: F12 = stiffness * (y - rest)"),
    "rest": ("m", "natural position (coupling: natural separation)"),
    "damping": ("N s/m", "body: F = -damping * v; coupling: F12 = damping * vy"),
    "offset": ("m", "x1 = offset + amplitude * sin(omega * t + phase)"),
}
PRESCRIBED_AMPLITUDE = ("m", "x1 = offset + amplitude * sin(omega * t + phase)")


def _value(v: Any) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else repr(v)


def _line(key: str, value: Any, field: tuple[str, str] | None = None) -> str:
    unit, meaning = field or FIELDS[key]
    return f"{key} = {_value(value)}".ljust(27) + f" # [{unit}] {meaning}"


def scene_toml(scene: Scene, description: str = "") -> str:
    """The scene as commented TOML (module docstring); ``description`` heads the file."""
    d = scene.to_dict()
    head = description or d.get("description") or "a two-mass scene"
    out = [f"# {scene.name}: {head} (edit and run: chatterbench run FILE)",
           "# Feigin's two-mass model: m1 x1'' = F1 + F12, m2 x2'' = F2 - F12, y = x2 - x1 in [lower, upper].",
           "# SI units throughout; every key is documented in chatterbench.reference.scene.", "",
           f"name = {_value(scene.name)}"]
    if d.get("description"):
        out.append(f"description = {_value(d['description'])}")
    out += [_line("mass1", d["mass1"]), _line("mass2", d["mass2"]), _line("restitution", d["restitution"]),
            _line("duration", d["duration"]), _line("gravity", d["gravity"]), "", "[gap]",
            _line("lower", d["gap"]["lower"])]
    if "upper" in d["gap"]:
        out.append(_line("upper", d["gap"]["upper"]))
    out += ["", "[initial]"] + [_line(k, d["initial"][k]) for k in ("t", "x1", "v1", "y", "vy")]
    if "prescribed" in d:
        out += ["", "[prescribed]  # the motion of the infinite body 1"]
        out += [_line(k, d["prescribed"][k], PRESCRIBED_AMPLITUDE if k == "amplitude" else None)
                for k in ("amplitude", "omega", "phase", "offset")]
    for f in d["forces"]:
        out += ["", f"[[forces]]  # kinds: {', '.join(Force._PARAMS)}; on: body1, body2, coupling",
                f"kind = {_value(f['kind'])}", f"on = {_value(f['on'])}"]
        out += [_line(k, f[k]) for k in Force._PARAMS[f["kind"]]]
    return "\n".join(out) + "\n"
