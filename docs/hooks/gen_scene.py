"""The scene file's fields, from the scene's dataclasses and the commented TOML ``chatterbench scenes --toml`` writes.

    >>> from gen_scene import scene_markdown
    >>> text = scene_markdown()
    >>> "<code>restitution</code>" in text and "<code>initial.vy</code>" in text
    True

One table per TOML table of a scene file (the top level, ``[gap]``, ``[initial]``, ``[prescribed]``,
``[[forces]]``): each key as the file spells it, its type and default from the dataclass
(``reference/scene.py``, ``reference/scene_parts.py``), its unit and meaning from ``reference/scene_toml.FIELDS`` (the comments
``scenes --toml`` writes), else from the comment on the dataclass field. A key the reader accepts
with no unit or meaning anywhere stops the build (``DocsError``), as does a dataclass field that
the file cannot set.
"""

from __future__ import annotations

import dataclasses
import inspect
import re

from gen_markup import cell, code, table

from chatterbench.reference import scene as scene_module
from chatterbench.reference.scene import BODIES, FORCE_KINDS, Force, Gap, Initial, Prescribed, Scene
from chatterbench.reference.scene_toml import FIELDS, PRESCRIBED_AMPLITUDE


class DocsError(Exception):
    """The code and its reference page disagree (the build stops, naming what to fix)."""


def _comments(cls: type) -> dict[str, str]:
    """``{field: the comment on its line}`` of a dataclass's source (``mass2: float  # [kg], > 0``)."""
    found = {}
    for line in inspect.getsource(cls).splitlines():
        match = re.match(r"\s+(\w+): [^#]+#\s*(.+)$", line)
        if match:
            found[match[1]] = match[2].strip()
    return found


def _type(f: dataclasses.Field) -> str:
    """The field's type as a file spells it: a table for a dataclass, an array of tables for the forces."""
    text = str(f.type).replace("tuple[Force, ...]", "array of tables").replace(" | None", " or absent")
    for name in ("Gap", "Initial", "Prescribed"):
        text = text.replace(name, "table")
    return text


# the top-level keys that are tables of their own, described in the table of their name
TABLES = {"gap": "[gap]", "initial": "[initial]", "prescribed": "[prescribed]", "forces": "[[forces]]"}


# the smallest file the reader takes: its defaults are what a file that leaves a key out gets
SMALLEST = {"mass1": 1.0, "mass2": 1.0, "restitution": 0.5, "gap": {}}


def file_defaults() -> tuple[dict[str, object], tuple[str, ...]]:
    """What the scene reader gives a top-level key a file leaves out, and the keys it requires (found by leaving each
    of ``SMALLEST``'s out: the reader's own answer, not a list kept here)."""
    scene = scene_module.scene_from_dict(SMALLEST)
    required = []
    for key in SMALLEST:
        try:
            scene_module.scene_from_dict({k: v for k, v in SMALLEST.items() if k != key})
        except scene_module.SceneError:
            required.append(key)
    return {f.name: getattr(scene, f.name) for f in dataclasses.fields(Scene)}, tuple(required)


def _default(f: dataclasses.Field, top: tuple[dict[str, object], tuple[str, ...]] | None = None) -> str:
    """The default a file gets: the reader's (``file_defaults``) for a top-level key, the dataclass's in a table."""
    if top is not None:
        defaults, required = top
        if f.name in required:
            return "required"
        value = defaults[f.name]
        if f.name in TABLES:
            return "absent" if value is None or value == () else "every key at its default"
        return code(repr(value)) if isinstance(value, str) else code(value)
    if f.default is not dataclasses.MISSING:
        return code(f.default) if f.default is not None else "absent"
    if f.default_factory is not dataclasses.MISSING:
        return "every key at its default"
    return "required"


def _meaning(cls: type, name: str, fields: dict) -> str:
    """Unit and meaning: ``FIELDS`` (``scenes --toml``'s comments) first, the dataclass comment else."""
    if cls is Scene and name in TABLES:
        return f"the table {code(TABLES[name])} below" + (f": {cell(c)}" if (c := _comments(cls).get(name)) else "")
    if cls is Prescribed and name == "amplitude":
        unit, text = PRESCRIBED_AMPLITUDE
    elif name in fields:
        unit, text = fields[name]
    else:
        comment = _comments(cls).get(name)
        if not comment:
            raise DocsError(f"{cls.__name__}.{name}: no unit or meaning in scene_toml.FIELDS, no comment on the field")
        return cell(comment)
    return cell(f"[{unit}] {text}")


def _rows(cls: type, keys: tuple[str, ...], prefix: str = "", top=None) -> list[list[str]]:
    """One row per TOML key of ``cls``; every key must be a field (``top``: the reader's defaults, top level only)."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    missing = [k for k in keys if k not in fields]
    if missing:
        raise DocsError(f"{cls.__name__}: the scene reader accepts {missing}, which are not its fields")
    return [[code(prefix + k), cell(_type(fields[k])), _default(fields[k], top), _meaning(cls, k, FIELDS)]
            for k in keys]


def scene_markdown() -> str:
    """The scene file's keys, table by table (module docstring)."""
    top = scene_module._TOP_KEYS  # what scene_from_dict reads: the file's top-level keys
    section = scene_module._SECTION_KEYS
    unread = {f.name for f in dataclasses.fields(Scene)} - set(top) - {"notes"}  # notes: how a file was read, no key
    if unread:
        raise DocsError(f"Scene fields no scene file can set: {sorted(unread)}")
    head = ["key", "type", "default", "unit and meaning"]
    parts = ["### The top level", "", table(head, _rows(Scene, top, top=file_defaults()))]
    for name, cls in (("gap", Gap), ("initial", Initial), ("prescribed", Prescribed)):
        parts += ["", f"### `[{name}]`", "", table(head, _rows(cls, section[name], name + "."))]
    kinds = [[code(kind), ", ".join(code(p) for p in Force._PARAMS[kind])] for kind in FORCE_KINDS]
    parts += ["", "### `[[forces]]`", "",
              cell(f"Each force is a table with kind (one of {', '.join(FORCE_KINDS)}), on (one of "
                   f"{', '.join(BODIES)}) and its kind's parameters; a parameter of another kind is refused."), "",
              table(["kind", "its parameters"], kinds), "",
              table(head, _rows(Force, tuple(f.name for f in dataclasses.fields(Force))))]
    return "\n".join(parts)
