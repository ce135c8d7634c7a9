"""A sweep's output directory: one sweep at a time writes it, only inside it, and torn writes are cleaned.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from chatterbench.comparisons.studies.sweep.directory import OutLock, clean_temps
    >>> tmp = Path(tempfile.mkdtemp())
    >>> with OutLock(tmp / "out") as lock:              # the sweep's whole life
    ...     clean_temps(tmp / "out", lock.tags)
    []

Promises about OUT: one sweep at a time writes it (``OutLock``, an ``flock`` that dies with
its process, so a killed sweep leaves no stale lock); nothing under OUT that the sweep writes,
locks or moves files into is a symbolic link (``OutLock`` opens ``.lock`` without following
one, ``refuse_links`` checks the rest), so nothing outside OUT is written or removed; a sweep
that holds the lock removes the temp files of writes torn by a kill (``clean_temps``), and only
those it can prove a sweep of OUT made: their names bear the tag (``atomic.temp_tag``) that
the killed sweep recorded in ``.lock``.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import socket
import stat
import time
from pathlib import Path
from typing import Any

from chatterbench.comparisons.pipeline.atomic import TEMP_PATTERN, temp_tag
from chatterbench.reference.errors import InputError

LOCK_NAME = ".lock"  # in OUT; kept after the sweep (see OutLock)
WRITTEN = ("rows", "rows/set-aside", "sweep.toml", "rows.parquet")  # what a sweep writes under OUT, besides .lock
_HOLDER_WAIT = 1.0  # [s] for a lock's new holder to write its pid


class OutDirError(InputError):
    """An output directory another sweep is writing now; the message names its pid and start time."""


_HELD: set[int] = set()  # this process's lock descriptors


def _drop_held_locks() -> None:
    """In a forked child: close the child's copies of the lock descriptors.

    An flock belongs to the open file, which a fork shares; without this, a run's child that
    outlives a killed sweep by a moment would keep its directory locked.
    """
    for fd in _HELD:
        try:
            os.close(fd)
        except OSError:
            pass
    _HELD.clear()


os.register_at_fork(after_in_child=_drop_held_locks)


def _holder(fd: int) -> str:
    """Who holds the lock, as its file says: ``pid 123 on host h, started 2025-01-31 12:00:00 +0000``."""
    deadline = time.monotonic() + _HOLDER_WAIT
    while True:  # the holder writes its line just after taking the lock
        try:
            info = json.loads(os.pread(fd, 4096, 0).decode("utf-8"))
            return f"pid {info['pid']} on host {info['host']}, started {info['started']}"
        except (ValueError, KeyError, TypeError, OSError):
            if time.monotonic() > deadline:
                return "pid unknown: the lock file names none"
            time.sleep(0.05)


class OutLock:
    """``with OutLock(out):`` one sweep's exclusive hold on its output directory, or ``OutDirError``.

    ``flock`` on ``OUT/.lock``, which then names the holder's pid, host and start time. The
    lock ends when the holder closes it or dies (``kill -9`` included), never later; forked
    children do not keep it (``_drop_held_locks``). The file is left in place: deleting a
    lock file lets two sweeps lock two files of one name.
    """

    def __init__(self, out: str | Path) -> None:
        self.path = Path(out) / LOCK_NAME
        self.fd: int | None = None
        self.tags: set[str] = set()  # temp-file tags of this holder and the one before (see clean_temps)

    def _open(self) -> int:
        """``.lock`` opened without following a link, never blocking on a pipe; a regular file or ``OutDirError``."""
        where = f"--out {self.path.parent}: {self.path}"
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise OutDirError(f"{where} is a symbolic link (-> {os.readlink(self.path)}); a sweep writes only "
                                  "inside --out: remove the link or choose another --out") from None
            raise OutDirError(f"{where}: cannot be opened to lock ({exc.strerror or exc})") from None
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            raise OutDirError(f"{where} is not a regular file; remove it or choose another --out")
        return fd

    def __enter__(self) -> "OutLock":
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = self._open()
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise OutDirError(f"--out {self.path.parent}: another sweep is writing there ({holder}); wait for it "
                              "to end or stop it, or choose another --out") from None
        except OSError as exc:
            os.close(fd)
            raise OutDirError(f"--out {self.path.parent}: cannot lock {self.path} ({exc.strerror or exc})") from None
        self.tags = {temp_tag(), *_recorded_tag(fd)}
        info = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.strftime("%Y-%m-%d %H:%M:%S %z"),
                "temps": temp_tag()}
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(info) + "\n").encode("utf-8"), 0)
        _HELD.add(fd)
        self.fd = fd
        return self

    def __exit__(self, *exc_info: Any) -> None:
        if self.fd is not None:
            _HELD.discard(self.fd)
            os.close(self.fd)  # releases the lock
            self.fd = None


def _recorded_tag(fd: int) -> list[str]:
    """The temp-file tag the lock's previous holder recorded, if its file names one."""
    try:
        tag = json.loads(os.pread(fd, 4096, 0).decode("utf-8")).get("temps")
    except (ValueError, AttributeError, OSError):
        return []
    return [tag] if isinstance(tag, str) and TEMP_PATTERN.fullmatch(f".x.{tag}{'0' * 8}.tmp") else []


def refuse_links(out: str | Path) -> None:
    """``OutDirError`` when a path the sweep writes under OUT (``WRITTEN``) is a symbolic link."""
    for name in WRITTEN:
        path = Path(out, name)
        if path.is_symlink():
            raise OutDirError(f"--out {out}: {path} is a symbolic link (-> {os.readlink(path)}); a sweep writes only "
                              "inside --out: remove the link or choose another --out")


def clean_temps(out: str | Path, tags: set[str]) -> list[Path]:
    """Remove the temp files of atomic writes torn by a kill in OUT and OUT/rows; returns them.

    Only ``atomic.write_with``'s own pattern bearing one of ``tags`` (``OutLock.tags``: the
    killed holder's, recorded in ``.lock``, and this process's), only while holding ``OutLock``
    (then no write of this directory is under way), and only after ``refuse_links``.
    """
    removed = []
    for folder in (Path(out), Path(out, "rows")):
        if folder.is_dir() and not folder.is_symlink():
            for path in sorted(folder.iterdir()):
                match = TEMP_PATTERN.fullmatch(path.name)
                if match and match["tag"] in tags and path.is_file() and not path.is_symlink():
                    path.unlink(missing_ok=True)
                    removed.append(path)
    return removed
