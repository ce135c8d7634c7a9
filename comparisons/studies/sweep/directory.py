"""A sweep's output directory: one sweep at a time writes it, and torn writes are cleaned.

    >>> with OutLock(tmp / "out"):                      # the sweep's whole life
    ...     clean_temps(tmp / "out")
    []

Promises about OUT: one sweep at a time writes it (``OutLock``, an ``flock`` that dies with
its process, so a killed sweep leaves no stale lock); a sweep that holds the lock removes the
temp files of writes torn by a kill (``clean_temps``).
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import socket
import time
from pathlib import Path
from typing import Any

from chatterbench.reference.errors import InputError

LOCK_NAME = ".lock"  # in OUT; kept after the sweep (see OutLock)
# atomic.write_with's temp files: .NAME.XXXXXXXX.tmp, 8 random characters of [a-z0-9_]
_TEMP = re.compile(r"\..+\.[a-z0-9_]{8}\.tmp")
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

    def __enter__(self) -> "OutLock":
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
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
        info = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.strftime("%Y-%m-%d %H:%M:%S %z")}
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


def clean_temps(out: str | Path) -> list[Path]:
    """Remove the temp files of atomic writes torn by a kill in OUT and OUT/rows; returns them.

    Only ``atomic.write_with``'s own pattern (``.NAME.XXXXXXXX.tmp``), and only while holding
    ``OutLock``: then no write of this directory is under way.
    """
    removed = []
    for folder in (Path(out), Path(out, "rows")):
        if folder.is_dir():
            for path in sorted(folder.iterdir()):
                if _TEMP.fullmatch(path.name) and path.is_file() and not path.is_symlink():
                    path.unlink(missing_ok=True)
                    removed.append(path)
    return removed
