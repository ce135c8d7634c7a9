"""Atomic file output: write to a temporary file beside the target, then rename over it.

    >>> import pandas as pd
    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> from chatterbench.comparisons.pipeline.atomic import write_text, write_frame
    >>> write_text(tmp / "out" / "report.md", "# report").read_text()
    '# report'
    >>> write_frame(tmp / "out" / "episodes.csv", pd.DataFrame({"t": [0.5]})).name
    'episodes.csv'

A crash at any point leaves either the old file or the new one, never a torn file
(``os.replace`` is atomic on POSIX within one filesystem). A write that fails in any way
(a full disk, a permission, an exception of the writer, Ctrl-C) removes its temp file
``.NAME.TTTTTTTTXXXXXXXX.tmp``; an ``OSError`` is raised again naming the target path. Only a
kill (SIGKILL, power loss) can leave a temp file. Its name starts with this process's tag
``TTTTTTTT`` (``temp_tag``: 8 random characters, new in every process and forked child), so a
cleaner can prove a temp file was this tool's: ``studies/sweep/directory.py`` records a sweep's
tag in ``OUT/.lock`` and the next sweep removes only the temp files bearing it.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
from pathlib import Path
from typing import Callable

import pandas as pd

_TEMP_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"  # tempfile's, as mkstemp draws
TEMP_NAME_EXTRA = len("..TTTTTTTTXXXXXXXX.tmp")  # bytes a temp file's name adds to its target's (a 255-byte limit applies)
# a temp file's name: group "tag" is the writing process's temp_tag()
TEMP_PATTERN = re.compile(r"\..+\.(?P<tag>[a-z0-9_]{8})[a-z0-9_]{8}\.tmp")
_TRIES = 100  # names drawn before giving up (a collision is 1 in 37**8 per existing temp file)


def _draw(n: int) -> str:
    return "".join(secrets.choice(_TEMP_CHARS) for _ in range(n))


_TAG = _draw(8)


def _new_tag() -> None:
    global _TAG
    _TAG = _draw(8)


os.register_at_fork(after_in_child=_new_tag)


def temp_tag() -> str:
    """This process's tag, the first 8 characters after ``.NAME.`` of every temp file it makes."""
    return _TAG


def write_with(path: Path, writer: Callable[[Path], None]) -> Path:
    """Call ``writer(tmp_path)`` then atomically move the result to ``path``; returns ``path``.

    The temp file is created (empty, mode 0666 less the umask, as any new file) before
    ``writer`` runs; it is removed on every failure, ``BaseException`` included.
    """
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(_TRIES):
            # named before it exists, so an interrupt at any point below still finds it to remove
            tmp = path.with_name(f".{path.name}.{_TAG}{_draw(8)}.tmp")
            try:
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
                break
            except FileExistsError:  # another writer's temp file: never ours to remove
                tmp = None
        else:
            raise FileExistsError(errno.EEXIST, f"no free temporary name after {_TRIES} tries", str(path))
        writer(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):  # gone already, or the disk refuses even this: the first error counts
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
