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

Inside an output folder (``confined(OUT)``, which the command line's ``--out`` sets), every
write is checked without following links: a directory on the way from OUT to the file, or the
file itself, that is a symbolic link is refused (``LinkRefused``, an ``OSError`` naming it), as is a
path that leads out of OUT (``..``, an absolute name),
and missing directories are made one at a time, so nothing is written outside OUT through a
link planted in it. ``staged(OUT)`` makes a set of files appear together: written into a
hidden folder under OUT, moved into place when the block ends (the files named ``last`` after
the rest, their old copies removed first), removed if it fails (Ctrl-C included). Only a kill can
leave that folder; it is named with its process's id (``.staged.PID.TTTTTTTTXXXXXXXX``), and the
next ``staged`` in the same folder removes those whose process is gone (one whose process still
runs, or a name of another pattern, is kept).

    >>> from chatterbench.comparisons.pipeline.atomic import confined, staged
    >>> with confined(tmp / "out"), staged(tmp / "out", last=["done.json"]) as stage:
    ...     _ = write_text(stage / "sub" / "a.txt", "a"), write_text(stage / "done.json", "{}")
    >>> sorted(str(p.relative_to(tmp / "out")) for p in (tmp / "out").rglob("*") if p.is_file())
    ['done.json', 'episodes.csv', 'report.md', 'sub/a.txt']
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import signal
import stat
import threading
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Sequence

if TYPE_CHECKING:
    import pandas as pd

_TEMP_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"  # tempfile's, as mkstemp draws
TEMP_NAME_EXTRA = len("..TTTTTTTTXXXXXXXX.tmp")  # bytes a temp file's name adds to its target's (a 255-byte limit applies)
# a temp file's name: group "tag" is the writing process's temp_tag()
TEMP_PATTERN = re.compile(r"\..+\.(?P<tag>[a-z0-9_]{8})[a-z0-9_]{8}\.tmp")
_TRIES = 100  # names drawn before giving up (a collision is 1 in 37**8 per existing temp file)
# a staged set's hidden folder: group "pid" is the process that made it (``staged``)
STAGE_PATTERN = re.compile(r"\.staged\.(?P<pid>[0-9]+)\.[a-z0-9_]{16}")
_ROOTS: ContextVar[tuple[str, ...]] = ContextVar("output_folders", default=())  # ``confined``'s folders, absolute


class LinkRefused(OSError):
    """A write inside an output folder that would go through a symbolic link (``confined``)."""


class NotRenamedOver(OSError):
    """A target that is a symbolic link, a named pipe, a device or a socket: a rename would replace it (issue 45: a
    ``--summary /dev/stdout`` run as root replaced the machine's ``/dev/stdout`` link with a regular file)."""


def standard_stream(path: str | Path) -> int | None:
    """1 or 2 when ``path`` (links followed) is the file, pipe or terminal this process's stdout or stderr writes to
    (``/dev/stdout``, ``/proc/self/fd/2``, the file stdout was redirected to), else None."""
    try:
        target = os.stat(path)
    except (OSError, ValueError):
        return None
    for fd in (1, 2):
        try:
            mine = os.fstat(fd)
        except OSError:
            continue
        if (mine.st_dev, mine.st_ino) == (target.st_dev, target.st_ino):
            return fd
    return None


def _write_to_stream(fd: int, writer: Callable[[Path], None]) -> None:
    """``writer``'s file, written through stdout (1) or stderr (2) after what Python holds for it."""
    import sys
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        made = Path(folder) / "out"
        writer(made)
        data = made.read_bytes()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # closed, or not a file: nothing held
            stream.flush()
    while data:
        data = data[os.write(fd, data):]


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


@contextlib.contextmanager
def confined(folder: str | Path) -> Iterator[None]:
    """Within the block, a write under ``folder`` follows no link on its way from ``folder`` (module docstring)."""
    token = _ROOTS.set((*_ROOTS.get(), os.path.abspath(folder)))
    try:
        yield
    finally:
        _ROOTS.reset(token)


def _no_links(path: Path) -> None:
    """Make ``path``'s directories below its output folder without following a link; ``LinkRefused`` at a link, or
    for a path that leaves the folder (``..``, an absolute name: a label that became a path)."""
    target, roots = os.path.abspath(path), _ROOTS.get()
    if not roots:
        return
    root = next((r for r in reversed(roots) if target.startswith(r.rstrip(os.sep) + os.sep)), None)
    if root is None:
        raise LinkRefused(errno.EPERM, f"{target} is outside the output folder {roots[-1]}; nothing is written there",
                          str(path))
    os.makedirs(root, exist_ok=True)  # the folder itself is the user's to name, a link included
    parts = os.path.relpath(target, root).split(os.sep)
    here = root
    for i, part in enumerate(parts):
        here = os.path.join(here, part)
        try:
            mode = os.lstat(here).st_mode
        except FileNotFoundError:
            if i < len(parts) - 1:
                with contextlib.suppress(FileExistsError):  # made meanwhile: looked at again below
                    os.mkdir(here)
                mode = os.lstat(here).st_mode
            else:
                return
        if stat.S_ISLNK(mode):
            shown = os.path.relpath(here, os.path.dirname(root))
            raise LinkRefused(errno.ELOOP, f"{shown} is a symbolic link (-> {os.readlink(here)}); nothing is written "
                                           "through a link in an output folder: remove it or choose another folder", here)


@contextlib.contextmanager
def interrupts_held() -> Iterator[None]:
    """In the main thread, a SIGINT during the block is held and delivered (its handler called) when it ends."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[tuple[int, object]] = []
    before = signal.signal(signal.SIGINT, lambda signum, frame: caught.append((signum, frame)))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)
        if caught and callable(before):
            before(*caught[0])
        elif caught and before == signal.SIG_DFL:
            raise KeyboardInterrupt


@contextlib.contextmanager
def staged(folder: str | Path, last: Sequence[str] = ()) -> Iterator[Path]:
    """A hidden folder under ``folder`` to write a set of files in; they replace ``folder``'s when the block ends.

    The files named in ``last`` (relative paths) are removed from ``folder`` first and moved in
    after all the others, so their presence says the rest is this set (``tune``'s
    ``recommended.json``). On any exception, ``KeyboardInterrupt`` included, the hidden folder is
    removed and ``folder`` keeps what it held.
    """
    folder = Path(folder)
    stage = folder / f".staged.{os.getpid()}.{_TAG}{_draw(8)}"
    _no_links(stage / "x")  # OUT's folders on the way, made without following a link
    _remove_killed_stages(folder)
    stage.mkdir(parents=True, exist_ok=True)
    try:
        yield stage
        files = sorted((p.relative_to(stage) for p in stage.rglob("*") if p.is_file() and not p.is_symlink()),
                       key=lambda rel: (str(rel) in last, str(rel)))
        with interrupts_held():  # a Ctrl-C lands after the set is in place, not halfway through it
            for rel in last:
                _no_links(folder / rel)
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(folder / rel)
            for rel in files:
                _no_links(folder / rel)  # inside ``confined``: its folders made following no link
                (folder / rel).parent.mkdir(parents=True, exist_ok=True)
                os.replace(stage / rel, folder / rel)
    except OSError as exc:  # name the file the user will look for, not its staged copy
        name = Path(exc.filename) if exc.filename else None
        if name is not None and (name == stage or stage in name.parents):
            raise OSError(exc.errno, exc.strerror or str(exc), str(folder / name.relative_to(stage))) from None
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _remove_killed_stages(folder: Path) -> None:
    """Remove the hidden folders that ``staged`` sets of killed processes left in ``folder`` (``STAGE_PATTERN``, a
    process id no process has now; a folder, never a link)."""
    for entry in os.scandir(folder):
        found = STAGE_PATTERN.fullmatch(entry.name)
        if found and entry.is_dir(follow_symlinks=False) and not _alive(int(found["pid"])):
            shutil.rmtree(entry.path, ignore_errors=True)


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (another user's counts: it may be the writer)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def write_with(path: Path, writer: Callable[[Path], None]) -> Path:
    """Call ``writer(tmp_path)`` then atomically move the result to ``path``; returns ``path``.

    The temp file is created (empty, mode 0666 less the umask, as any new file) before
    ``writer`` runs; it is removed on every failure, ``BaseException`` included. Nothing is
    renamed over what is not a regular file: a ``path`` that is this process's stdout or stderr
    (``/dev/stdout``, or the file either was redirected to) is written through it
    (``standard_stream``); a symbolic link, a named pipe, a device or a socket is
    ``NotRenamedOver``, left as it was.
    """
    path = Path(path)
    tmp = None
    try:
        _no_links(path)
        stream = standard_stream(path)
        if stream is not None:
            _write_to_stream(stream, writer)
            return path
        with contextlib.suppress(FileNotFoundError):
            mode = os.lstat(path).st_mode
            if not stat.S_ISREG(mode):
                what = (f"a symbolic link (-> {os.readlink(path)})" if stat.S_ISLNK(mode) else
                        "a named pipe, a device or a socket" if not stat.S_ISDIR(mode) else "a directory")
                raise NotRenamedOver(errno.EPERM, f"{what}, not a regular file: nothing is written over it", str(path))
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
