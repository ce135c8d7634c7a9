"""Atomic file output: write to a temporary file beside the target, then rename over it.

    >>> write_text(tmp / "out" / "report.md", "# report").read_text()
    '# report'
    >>> write_frame(tmp / "out" / "episodes.csv", pd.DataFrame({"t": [0.5]})).name
    'episodes.csv'

A crash at any point leaves either the old file or the new one, never a torn file
(``os.replace`` is atomic on POSIX within one filesystem). A write that fails (a full disk,
a permission) removes its temp file and raises an ``OSError`` naming the target path.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Callable

import pandas as pd


def write_with(path: Path, writer: Callable[[Path], None]) -> Path:
    """Call ``writer(tmp_path)`` then atomically move the result to ``path``; returns ``path``."""
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        os.close(fd)
        writer(Path(tmp))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600: give the file the usual permissions
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, BrokenPipeError):  # name the file the user asked for
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
        raise
    return path


def write_text(path: Path, text: str) -> Path:
    """Atomically write ``text`` (UTF-8) to ``path``."""
    return write_with(path, lambda p: p.write_text(text, encoding="utf-8"))


def write_bytes(path: Path, data: bytes) -> Path:
    """Atomically write ``data`` to ``path``."""
    return write_with(path, lambda p: p.write_bytes(data))


def write_frame(path: Path, frame: pd.DataFrame) -> Path:
    """Atomically write a DataFrame as CSV (``.csv``) or Parquet (``.parquet``)."""
    path = Path(path)
    if path.suffix == ".parquet":
        return write_with(path, lambda p: frame.to_parquet(p, index=False))
    return write_with(path, lambda p: frame.to_csv(p, index=False, float_format="%.17g"))
