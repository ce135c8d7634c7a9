"""Output destinations, checked before any work: a bad ``--out`` costs nothing, not a whole report.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from chatterbench.comparisons.cli.paths import check_dir, check_file, writing
    >>> tmp = Path(tempfile.mkdtemp())
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
    >>> with writing("--out", tmp / "out"):         # a disk that fills while writing
    ...     raise OSError(28, "No space left on device", str(tmp / "out" / "report.html"))
    Traceback (most recent call last):
    ...
    chatterbench.comparisons.cli.common.UsageError: --out .../out: cannot write report.html: No space left on device

A directory option must name a directory or a place where one can be made (its nearest
existing ancestor a directory this user may write); a file option must not name a directory,
a device or a pipe, and its directory must be one or be creatable. Every subcommand checks
all its output options first, so a refusal costs nothing. Writing can still fail later (a
full disk): ``writing`` turns that ``OSError`` into one line naming the option and the file,
and ``pipeline/atomic.py`` leaves no temp file.
"""

from __future__ import annotations

import os
from contextlib import contextmanager, nullcontext, suppress
from pathlib import Path
from typing import Sequence

from chatterbench.comparisons.pipeline.atomic import TEMP_NAME_EXTRA, confined, staged, standard_stream

from .common import UsageError

_NOT_FILE = "is not a regular file (a device, pipe or socket); give a file path"


def _why_not_writable(directory: Path) -> str:
    if hasattr(os, "ST_RDONLY") and os.statvfs(directory).f_flag & os.ST_RDONLY:
        return "a read-only filesystem"
    return "permission denied"


def _creatable(option: str, shown: Path, path: Path) -> Path:
    """``path`` (a directory to be) exists as a directory or can be made under its nearest existing ancestor (returned).

    Paths are walked as given (relative ones end at ``.``), so messages quote what the user typed.
    """
    probe = path
    while not probe.exists() and not probe.is_symlink() and probe.parent != probe:
        probe = probe.parent
    if probe.is_symlink() and not probe.exists():
        raise UsageError(f"{option} {shown}: {probe} is a broken link (-> {os.readlink(probe)})")
    if not probe.is_dir():
        raise UsageError(f"{option} {shown}: {probe} is not a directory, so nothing can be made under it")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {shown}: cannot write in {probe} ({_why_not_writable(probe)})")
    return probe


@contextmanager
def _checking(option: str, path: Path):
    """Refusals of the path itself: a NUL character, a name the filesystem cannot hold (too long, ...)."""
    if "\0" in str(path):
        raise UsageError(f"{option} {str(path)!r}: contains a NUL character")
    try:
        yield
    except OSError as exc:
        raise UsageError(f"{option} {path}: {exc.strerror or exc}") from None


def check_dir(option: str, path: str | Path | None) -> None:
    """Refuse (``UsageError``) a directory option that cannot be a directory to write in."""
    if path is None:
        return
    path = Path(path)
    with _checking(option, path):
        if path.exists() and not path.is_dir():
            raise UsageError(f"{option} {path}: exists and is not a directory")
        _creatable(option, path, path)


def check_file(option: str, path: str | Path | None) -> None:
    """Refuse (``UsageError``) a file option that names a directory or a place no file can be written.

    The file is written beside itself and renamed over (``pipeline/atomic.py``): a device, a
    pipe or a link would be replaced, not written to, so only a regular file or a new name will
    do, or this process's stdout or stderr (``/dev/stdout``), which is written through.
    """
    if path is None:
        return
    path = Path(path)
    with _checking(option, path):
        if standard_stream(path) is not None:  # /dev/stdout, /dev/stderr: written through (atomic.write_with)
            return
        if path.is_symlink():  # a rename would replace the link itself (issue 45: /dev/stdout, run as root)
            target = os.readlink(path)
            if not path.exists():
                raise UsageError(f"{option} {path}: a symbolic link to nothing (-> {target}); give a file path")
            if path.is_file():
                raise UsageError(f"{option} {path}: a symbolic link (-> {target}), which the write would replace; give "
                                 "the file itself")
            raise UsageError(f"{option} {path}: a symbolic link (-> {target}) to what is not a regular file (a device, "
                             "pipe or socket); give a file path")
        if path.is_dir():
            raise UsageError(f"{option} {path}: is a directory; give a file path")
        if path.exists() and not path.is_file():
            raise UsageError(f"{option} {path}: {_NOT_FILE}")
        if path.exists() and not os.access(path, os.W_OK):
            raise UsageError(f"{option} {path}: cannot be overwritten (permission denied)")
        limit = os.pathconf(_creatable(option, path, path.parent), "PC_NAME_MAX")
        if len(os.fsencode(path.name)) + TEMP_NAME_EXTRA > limit:
            raise UsageError(f"{option} {path}: file name too long, at most {limit - TEMP_NAME_EXTRA} bytes here "
                             "(it is first written beside itself under a longer temporary name)")


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name one file: the same file when both exist (links, ``..``, hard links followed), else the
    same place once their folders' links are resolved."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return os.path.realpath(a) == os.path.realpath(b)


def check_distinct(outputs: dict[str, str | Path | None], inputs: dict[str, str | Path | None],
                   may_replace: set[tuple[str, str]] = frozenset()) -> None:
    """Refuse (``UsageError``), before any work, two output options naming one file, or an output naming an input
    (the gate file, a baseline): one would silently replace the other. ``may_replace``: (output, input) pairs that
    may (``--save-baseline`` over the ``--baseline`` it read)."""
    def shown(option: str, path) -> str:  # "--out o/events.csv" names a file of a folder option: said as it is
        return option if " " in option else f"{option} {path}"

    given = [(o, p) for o, p in outputs.items() if p is not None]
    for i, (option, path) in enumerate(given):
        for other, there in given[i + 1:]:
            if same_file(path, there):
                raise UsageError(f"{shown(option, path)} and {shown(other, there)} name one file; give each output its own")
        for name, source in inputs.items():
            if source is not None and (option, name) not in may_replace and same_file(path, source):
                raise UsageError(f"{shown(option, path)} is the {name} file ({source}), which this command reads or "
                                 "appends to: writing it would replace it; name another file")


def check_links(option: str, folder: str | Path | None, names: tuple[str, ...]) -> None:
    """Refuse (``UsageError``) an output folder where a name the command writes (a file, an engine's folder) is a
    symbolic link: it would be written through (``atomic.confined`` refuses it again at the write)."""
    if folder is None:
        return
    for name in names:
        path = Path(folder, name)
        if path.is_symlink():
            raise UsageError(f"{option} {folder}: {path} is a symbolic link (-> {os.readlink(path)}); nothing is "
                             f"written through a link in {option}: remove it or choose another {option}")


def check_shapes(option: str, folder: str | Path | None, files: Sequence[str] = (), folders: Sequence[str] = ()) -> None:
    """Refuse (``UsageError``) an output folder where a file the command writes (``files``) is a directory, or a
    folder it writes into (``folders``) is something else: found before the work, not at its last write."""
    if folder is None:
        return
    for name in files:
        path = Path(folder, name)
        if path.is_dir() and not path.is_symlink():
            raise UsageError(f"{option} {folder}: {path} is a directory where the command writes the file {name}; "
                             f"remove it or choose another {option}")
    for name in folders:
        path = Path(folder, name)
        if (path.exists() or path.is_symlink()) and not path.is_dir():
            raise UsageError(f"{option} {folder}: {path} is a file where the command writes the folder {name}/; "
                             f"remove it or choose another {option}")


def write_error(exc: OSError, under: str | Path | None = None) -> str:
    """One line for an OSError met while writing (a full disk, a permission taken away).

    The file is named relative to ``under`` (the option's path) when it lies there.
    """
    name = exc.filename
    if name is not None and under is not None:
        with suppress(ValueError):
            name = Path(name).relative_to(under)
            name = None if name == Path(".") else name
    return f"cannot write{f' {name}' if name else ''}: {exc.strerror or exc}"


@contextmanager
def writing(option: str, path: str | Path, folder: bool | None = None, together: bool | Sequence[str] = False):
    """Turn an ``OSError`` met while writing what ``option`` names into a ``UsageError`` (one line, exit 2); yields
    where to write.

    ``folder`` (default: ``option`` is ``--out``): ``path`` is an output folder, every write under it
    follows no link (``atomic.confined``): a link planted there is refused, nothing written through it.
    ``together``: the block's files appear in ``path`` together when it ends (``atomic.staged``; a
    sequence: these files last), written where this yields; an interrupted or failed block
    leaves ``path`` as it was. Otherwise it yields ``path``.
    """
    path = Path(path)
    confining = confined(path) if (option == "--out" if folder is None else folder) else nullcontext()
    try:
        with confining:
            if together:
                with staged(path, last=() if together is True else tuple(together)) as stage:
                    yield stage
            else:
                yield path
    except BrokenPipeError:  # the reader of stdout left (``| head``): ``main`` says nothing more
        raise
    except OSError as exc:
        raise UsageError(f"{option} {path}: {write_error(exc, path)}") from None
