"""TOML files and nested tables, read and flattened the same way for scenes, sweeps and gates.

    >>> from chatterbench.reference.tables import flatten
    >>> flatten({"initial": {"vy": 0.1}, "restitution": 0.5})
    {'initial.vy': 0.1, 'restitution': 0.5}
    >>> flatten({"forces": [{"kind": "harmonic", "omega": 1.0}]}, lists=True)
    {'forces.0.kind': 'harmonic', 'forces.0.omega': 1.0}

``read_toml`` refuses an unreadable file, one that is not UTF-8 and one that is not TOML
with one message each, naming the file (``what``) and raised as the caller's error class.

Bounds, the same for every reader (scene files, ``--set`` values, sweep specs, gate files,
baselines): ``read_text`` reads only a regular file of at most ``MAX_FILE_BYTES`` (10 MiB),
checked before reading (a device, a named pipe or a directory is refused, never read or
waited on); ``loads`` and ``check_depth`` refuse nesting past ``MAX_DEPTH`` levels (arrays,
tables, dotted keys) with ``TooDeep``, so no reader raises ``RecursionError`` and no deep
key costs tomllib's quadratic time.
"""

from __future__ import annotations

import errno
import math
import os
import re
import stat
import tomllib
from pathlib import Path
from typing import Any, Mapping

from .errors import InputError

MAX_FILE_BYTES = 10 * 2**20  # [bytes] of any input file: scene, sweep spec, gate file, baseline
MAX_DEPTH = 32  # levels of nesting (arrays, tables, dotted keys) in any input; real ones use 4
# MAX_DEPTH + 1 key parts joined by dots (bare or quoted), found before tomllib spends O(n^2) on them; a chain is
# tried from its first part only and every quantifier is possessive, so a 10 MiB file is scanned in under 0.5 s
_PART = r"""(?:[A-Za-z0-9_-]++|"[^"\n]*+"|'[^'\n]*+')"""
_DEEP_KEY = re.compile(r"""(?<![A-Za-z0-9_"'.\-])(?<!\.[ \t])""" + _PART + r"(?:[ \t]*+\.[ \t]*+" + _PART + "){%d}" % MAX_DEPTH)


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def printable(text: str) -> str:
    """``text`` with control characters escaped (``\\n``, ``\\x1b``): a key read from a file, fit for a one-line message."""
    return _CONTROL.sub(lambda m: repr(m[0])[1:-1], str(text))


class TooDeep(ValueError):
    """Input nested past ``MAX_DEPTH`` levels."""

    def __init__(self) -> None:
        super().__init__(f"nested more than {MAX_DEPTH} levels deep (arrays, tables or dotted keys); "
                         f"at most {MAX_DEPTH} are read")


def check_depth(value: Any, limit: int = MAX_DEPTH) -> Any:
    """``value`` itself when its lists and mappings nest at most ``limit`` deep; ``TooDeep`` otherwise (no recursion)."""
    stack = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, Mapping):
            children = item.values()
        elif isinstance(item, (list, tuple)):
            children = item
        else:
            continue
        if depth >= limit:
            raise TooDeep()
        stack.extend((c, depth + 1) for c in children)
    return value


def loads(text: str) -> dict[str, Any]:
    """``tomllib.loads`` with nesting bounded (``TooDeep``, a ``ValueError``), never ``RecursionError``."""
    if _DEEP_KEY.search(text):
        raise TooDeep()
    try:
        return check_depth(tomllib.loads(text))
    except RecursionError:
        raise TooDeep() from None


def open_in(folder: str | Path, path: str | Path, what: str, error: type[InputError] = InputError) -> int:
    """A read-only descriptor of ``path``, a file under the input folder ``folder``, opened one name at a time from
    ``folder`` without following a link (``O_NOFOLLOW`` at each step, so no link can be swapped in between): a link
    on the way or at the end is ``error`` naming it and where it points. ``folder`` itself is the user's to name, a
    link included; ``path`` that leaves it (``..``, an absolute name) is refused too. ``OSError`` otherwise."""
    rel = os.path.relpath(os.path.abspath(path), os.path.abspath(folder))
    parts = rel.split(os.sep)
    if rel == os.curdir or rel.startswith(os.pardir) or os.pardir in parts:
        raise error(f"{what}: not inside {folder}; nothing outside an input folder is read")
    here = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | (os.O_NONBLOCK if last else os.O_DIRECTORY)
            try:
                fd = os.open(part, flags, dir_fd=here)
            except OSError as exc:
                if exc.errno not in (errno.ELOOP, errno.ENOTDIR, errno.EMLINK) or not _is_link(part, here):
                    raise
                where = "" if last else f"{printable(os.path.join(*parts[:i + 1]))} is "  # a folder on the way: named
                raise error(f"{what}: {where}a symbolic link (-> {printable(os.readlink(part, dir_fd=here))}); nothing "
                            "in an input folder is read through a link (it could show any file of this machine): put the "
                            "file itself there") from None
            os.close(here)
            here = fd
        return here
    except BaseException:
        os.close(here)
        raise


def _is_link(name: str, dir_fd: int) -> bool:
    try:
        return stat.S_ISLNK(os.lstat(name, dir_fd=dir_fd).st_mode)
    except OSError:
        return False


def read_text(path: str | Path, what: str, error: type[InputError] = InputError, limit: int = MAX_FILE_BYTES,
              kind: str = "TOML", folder: str | Path | None = None) -> str:
    """The UTF-8 text of the regular file ``path`` of at most ``limit`` bytes, or ``error`` naming ``what``.

    Type and size are checked on the open file before reading: a device (``/dev/zero``), a
    named pipe (opened without waiting for a writer) or a directory is refused, never read.
    ``folder``: ``path`` is a file of this input folder (``report --tune DIR``) and is reached
    without following a link (``open_in``): a link in it, to a file or a subfolder, is refused by name.
    """
    try:
        fd = (open_in(folder, path, what, error) if folder is not None else
              os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC))
    except InputError:  # a link in the folder (open_in), said as it is
        raise
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        raise error(f"{what}: cannot be read ({getattr(exc, 'strerror', None) or exc})") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise error(f"{what}: cannot be read (is a directory)" if stat.S_ISDIR(mode) else
                    f"{what}: not a regular file (a device, pipe or socket); give a file")
    with os.fdopen(fd, "rb") as f:
        data = f.read(limit + 1)  # st_size can lie (a growing file, /proc): read one byte past the limit
    if len(data) > limit:
        raise error(f"{what}: larger than {limit / 2**20:g} MiB, the most an input file may hold")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{what}: not valid {kind} (not UTF-8 text: {exc.reason} at byte {exc.start})") from None


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
    return parse_toml(read_text(path, what, error), what, error)


def parse_toml(text: str, what: str, error: type[InputError] = InputError) -> dict[str, Any]:
    """The TOML table of ``text`` (read by ``read_text``), bounded as ``read_toml``'s; ``error`` naming ``what``."""
    try:
        return loads(text)
    except TooDeep as exc:
        raise error(f"{what}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{what}: not valid TOML ({exc})") from None
    except ValueError as exc:  # an integer past Python's limit of 4300 digits
        raise error(f"{what}: a number too long to read ({str(exc).splitlines()[0]})") from None


def toml_literal(value: Any) -> str:
    """A TOML literal for a scalar, a string key or an array of scalars (sweep specs, gate commands).

    >>> from chatterbench.reference.tables import toml_literal
    >>> toml_literal(["ball \N{TENNIS RACQUET AND BALL}", 1e-4, float("inf"), True])
    '["ball \N{TENNIS RACQUET AND BALL}", 0.0001, inf, true]'
    """
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
        return _toml_string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    raise TypeError(f"no TOML form for {value!r}")


# TOML basic-string escapes; every other character but the controls is written as itself
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_string(text: str) -> str:
    """A TOML basic string holding ``text`` exactly, any Unicode (an emoji is written as itself).

    JSON's ``\\ud83c\\udfbe`` surrogate pairs are not TOML: TOML escapes name Unicode scalar
    values, so a non-BMP character written that way could not be read back.
    """
    out = []
    for ch in text:
        code = ord(ch)
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif code < 0x20 or code == 0x7F:  # control characters must be escaped
            out.append(f"\\u{code:04x}")
        elif 0xD800 <= code <= 0xDFFF:  # a sweep spec refuses these before writing
            raise ValueError(f"{text!r}: a lone surrogate has no TOML form")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'
