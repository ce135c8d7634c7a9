"""Output destinations, checked before any work: a bad ``--out`` costs nothing, not a whole report.

    >>> check_dir("--out", tmp / "new" / "deeper")          # creatable: fine (nothing is created)
    >>> (tmp / "afile").write_text("x") and None
    >>> check_dir("--out", tmp / "afile")
    Traceback (most recent call last):
    ...
    chatterbench.comparisons.cli.common.UsageError: --out .../afile: exists and is not a directory
    >>> check_file("--events", tmp)
    Traceback (most recent call last):
    ...
    chatterbench.comparisons.cli.common.UsageError: --events ...: is a directory; give a file path

A directory option must name a directory or a place where one can be made (its nearest
existing ancestor a directory this user may write); a file option must not name a directory
and its directory must be one or be creatable. Writing can still fail later (a full disk):
``main`` turns that ``OSError`` into one line, and ``outputs/atomic.py`` leaves no temp file.
"""

from __future__ import annotations

import os
from pathlib import Path

from .common import UsageError


def _creatable(option: str, shown: Path, path: Path) -> None:
    """``path`` (a directory to be) exists as a directory or can be made under its nearest existing ancestor.

    Paths are walked as given (relative ones end at ``.``), so messages quote what the user typed.
    """
    probe = path
    while not probe.exists() and not probe.is_symlink() and probe.parent != probe:
        probe = probe.parent
    if probe != path and not probe.is_dir():
        raise UsageError(f"{option} {shown}: {probe} is not a directory, so nothing can be made under it")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {shown}: cannot write in {probe} (permission denied)")


def check_dir(option: str, path: str | Path | None) -> None:
    """Refuse (``UsageError``) a directory option that cannot be a directory to write in."""
    if path is None:
        return
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{option} {path}: exists and is not a directory")
    _creatable(option, path, path)


def check_file(option: str, path: str | Path | None) -> None:
    """Refuse (``UsageError``) a file option that names a directory or a place no file can be written."""
    if path is None:
        return
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a directory; give a file path")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{option} {path}: cannot be overwritten (permission denied)")
    _creatable(option, path, path.parent)


def write_error(exc: OSError) -> str:
    """One line for an OSError met while writing (a full disk, a permission taken away)."""
    where = f" {exc.filename}" if exc.filename else ""
    return f"cannot write{where}: {exc.strerror or exc}"
