"""TOML files and nested tables, read and flattened the same way for scenes, sweeps and gates.

    >>> from chatterbench.reference.tables import flatten
    >>> flatten({"initial": {"vy": 0.1}, "restitution": 0.5})
    {'initial.vy': 0.1, 'restitution': 0.5}
    >>> flatten({"forces": [{"kind": "harmonic", "omega": 1.0}]}, lists=True)
    {'forces.0.kind': 'harmonic', 'forces.0.omega': 1.0}

``read_toml`` refuses an unreadable file, one that is not UTF-8 and one that is not TOML
with one message each, naming the file (``what``) and raised as the caller's error class.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any, Mapping

from .errors import InputError


def flatten(table: Mapping[str, Any], prefix: str = "", lists: bool = False) -> dict[str, Any]:
    """Nested tables as dotted keys (``{"initial": {"vy": 0}}`` -> ``{"initial.vy": 0}``); other values kept.

    ``lists``: lists of tables too, by index, the way scene overrides name forces
    (``forces.0.omega``); otherwise a list is a value.
    """
    out: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + ".", lists))
        elif lists and isinstance(v, (list, tuple)) and v and all(isinstance(i, Mapping) for i in v):
            out.update(flatten({str(i): item for i, item in enumerate(v)}, key + ".", lists))
        else:
            out[key] = v
    return out


def read_toml(path: str | Path, what: str, error: type[InputError] = InputError) -> dict[str, Any]:
    """The TOML table of ``path``; ``error`` naming ``what`` ("scene file 'x.toml'") when it cannot be had."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise error(f"{what}: cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise error(f"{what}: not valid TOML (not UTF-8 text: {exc.reason} at byte {exc.start})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{what}: not valid TOML ({exc})") from None
    except ValueError as exc:  # an integer past Python's limit of 4300 digits
        raise error(f"{what}: a number too long to read ({str(exc).splitlines()[0]})") from None
