"""A trajectory table from a file (CSV, compressed CSV, Parquet), bounded and checked by kind before it is read.

    >>> import tempfile, pathlib
    >>> from chatterbench.comparisons.pipeline.table_file import read_table_file
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = path.write_text("t,x1\\n0,0.5\\n0.1,n/a\\n")
    >>> table = read_table_file(path)
    >>> table.frame["x1"].tolist(), table.row(1)          # "n/a" stays text: the judge names it
    (['0.5', 'n/a'], 'row 2 (line 3)')

Promises (each one a refusal, ``TableFileError``, in one line that names the file, escaped):

- only a regular file is read: a directory, a device (``/dev/zero``) or a named pipe is
  refused by its kind, never read and never waited on (the pipe is opened without blocking);
- nothing past ``MAX_TABLE_BYTES`` is read, the decompressed size of a ``.gz``, ``.bz2`` or
  ``.xz`` file included: it is decompressed as a stream and refused where it passes the limit
  (a gzip bomb stops there), and a Parquet file's footer (its row count, at most ``MAX_TABLE_ROWS``,
  and uncompressed size) is read before its data;
- a CSV is UTF-8 text: a NUL byte (a sparse file is all NULs) or a line longer than
  ``MAX_LINE_BYTES`` is refused where it is found, before pandas sees the file;
- only the empty cell and ``nan`` (any case) are missing values; any other text, "n/a" or
  "NA" included, stays text, so the judge can say which cell is not a number;
- rows are counted as a user counts them (``TableFile.row``): the first data row is row 1,
  and in a CSV it is on line 2 (the header is line 1).
"""

from __future__ import annotations

import bz2
import codecs
import gzip
import io
import lzma
import os
import stat
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from chatterbench.reference.errors import InputError
from chatterbench.reference.tables import printable

MAX_TABLE_BYTES = 256 * 2**20  # [bytes] of table data, decompressed: about 2 million samples of 7 full-precision columns
MAX_TABLE_ROWS = 2**21  # samples of a Parquet file, from its footer: as many as a CSV within MAX_TABLE_BYTES holds
MAX_LINE_BYTES = 2**20  # [bytes] of one CSV line (a real one holds a few hundred)
PARQUET = (".parquet", ".pq")
_STREAMS = {".gz": lambda f: gzip.GzipFile(fileobj=f, mode="rb"), ".bz2": lambda f: bz2.BZ2File(f, "rb"),
            ".xz": lambda f: lzma.LZMAFile(f, "rb")}  # a decompressing stream over an open file
_CHUNK = 4 * 2**20
NAN_TEXT = ["", "nan", "NaN", "NAN", "-nan", "+nan"]  # the cells read as missing values; no other text


class TableFileError(InputError):
    """A table file that cannot be read; the message names the file and why."""


@dataclass(frozen=True)
class TableFile:
    """A table read from ``source`` (its name escaped for messages); ``csv``: rows sit on lines 2, 3, ..."""

    frame: pd.DataFrame
    source: str
    csv: bool

    def row(self, k: int) -> str:
        """Row ``k`` (0-based, as the frame holds it) as a user counts it: "row 6 (line 7)" in a CSV."""
        return f"row {k + 1} (line {k + 2})" if self.csv else f"row {k + 1}"


def _open_regular(path: Path, shown: str) -> int:
    """A descriptor of the regular file ``path``; a directory, device or pipe refused by kind (never waited on)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise TableFileError(f"trajectory {shown}: no such file") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        raise TableFileError(f"trajectory {shown}: cannot be read ({getattr(exc, 'strerror', None) or exc})") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = ("a directory" if stat.S_ISDIR(mode) else "a named pipe" if stat.S_ISFIFO(mode) else
                "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket")
        raise TableFileError(f"trajectory {shown}: is {kind}, not a regular file; give a CSV or Parquet file")
    return fd


def _too_big(shown: str, what: str = "") -> TableFileError:
    return TableFileError(f"trajectory {shown}: {what}larger than {MAX_TABLE_BYTES / 2**20:g} MiB, the most a trajectory "
                          "file may hold (about 2 million samples); write fewer samples (every k-th step)")


class _Text:
    """Checks CSV bytes a chunk at a time as they are read: UTF-8, no NUL byte, no line past ``MAX_LINE_BYTES``."""

    def __init__(self, shown: str) -> None:
        self.shown, self.read, self.line, self.since = shown, 0, 1, 0  # bytes so far, line number, bytes since its start
        self.utf8 = codecs.getincrementaldecoder("utf-8")()  # its text is thrown away: only its errors count

    def check(self, chunk: bytes, final: bool = False) -> None:
        nul = chunk.find(b"\0")
        if nul >= 0:
            raise TableFileError(f"trajectory {self.shown}: not a CSV text file (a NUL byte at byte {self.read + nul}: "
                                 "binary or sparse data)")
        ends = np.flatnonzero(np.frombuffer(chunk, dtype=np.uint8) == 10)  # the newlines
        last = int(ends[-1]) if len(ends) else -1
        longest = max(self.since + (int(ends[0]) if len(ends) else len(chunk)),
                      int(np.diff(ends).max()) - 1 if len(ends) > 1 else 0)
        if longest > MAX_LINE_BYTES:
            raise TableFileError(f"trajectory {self.shown}: a line near line {self.line} is longer than "
                                 f"{MAX_LINE_BYTES // 2**20} MiB; not a CSV table of samples")
        try:
            self.utf8.decode(chunk, final)
        except UnicodeDecodeError as exc:
            raise TableFileError(f"trajectory {self.shown}: not UTF-8 text ({exc.reason} near byte "
                                 f"{self.read + max(exc.start, 0)})") from None
        self.line += len(ends)
        self.since = len(chunk) - last - 1 if last >= 0 else self.since + len(chunk)
        self.read += len(chunk)


def _read_bounded(stream, shown: str, what: str) -> bytes:
    """All of ``stream`` as checked CSV text (``_Text``), refused where it passes ``MAX_TABLE_BYTES`` (a chunk at a
    time: a bomb stops at the limit, a sparse file at its first byte)."""
    out, text = bytearray(), _Text(shown)
    while True:
        try:
            chunk = stream.read(_CHUNK)
        except (OSError, EOFError, lzma.LZMAError, zlib.error) as exc:
            raise TableFileError(f"trajectory {shown}: cannot be decompressed ({printable(str(exc))[:120]})") from None
        if not chunk:
            text.check(b"", final=True)  # a last line without its newline, a character cut short
            return bytes(out)
        if len(out) + len(chunk) > MAX_TABLE_BYTES:
            raise _too_big(shown, what)
        text.check(chunk)
        out += chunk


def _read_parquet(fd: int, shown: str, columns: Sequence[str] | None) -> pd.DataFrame:
    """The ``columns`` present of a Parquet file, its footer checked against the limit before any data is read."""
    import pyarrow.parquet as pq

    with os.fdopen(fd, "rb") as f:
        try:
            pf = pq.ParquetFile(f)
            meta = pf.metadata
            size = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
            if meta.num_rows > MAX_TABLE_ROWS:  # the sizes a footer states can be small (a column of one value)
                raise TableFileError(f"trajectory {shown}: {meta.num_rows} rows (its footer), more than {MAX_TABLE_ROWS}, "
                                     "the most a trajectory file may hold; write fewer samples (every k-th step)")
            if size > MAX_TABLE_BYTES:
                raise _too_big(shown, f"{meta.num_rows} rows, {size / 2**20:.0f} MiB uncompressed: ")
            names = [str(n) for n in pf.schema_arrow.names]
            wanted = [c for c in names if columns is None or c in columns]
            frame = pf.read(columns=wanted).to_pandas()
        except TableFileError:
            raise
        except Exception as exc:  # pyarrow's own error, in one line
            raise TableFileError(f"trajectory {shown}: cannot be read as Parquet: {type(exc).__name__}: "
                                 f"{printable(str(exc))[:200]}") from None
    frame.attrs["columns"] = names  # the columns left out are still named in a message about a missing one
    return frame


def _read_csv(fd: int, path: Path, shown: str, columns: Sequence[str] | None) -> pd.DataFrame:
    """The ``columns`` present of a (possibly compressed) CSV file, its text checked before pandas parses it."""
    suffix = path.suffix.lower()
    with os.fdopen(fd, "rb") as raw:
        if os.fstat(raw.fileno()).st_size > MAX_TABLE_BYTES:
            raise _too_big(shown)
        opener = _STREAMS.get(suffix)
        data = _read_bounded(opener(raw) if opener else raw, shown,
                             "decompressed, " if opener else "")
    try:
        names = [str(c).strip() for c in pd.read_csv(io.BytesIO(data), nrows=0).columns]
        frame = pd.read_csv(io.BytesIO(data), usecols=lambda c: columns is None or str(c).strip() in columns,
                            keep_default_na=False, na_values=NAN_TEXT, skipinitialspace=True)
    except Exception as exc:  # a parser's own error, in one line
        raise TableFileError(f"trajectory {shown}: cannot be read as CSV: {type(exc).__name__}: "
                             f"{printable(str(exc))[:200]}") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    frame.attrs["columns"] = names
    return frame


def read_table_file(path: str | Path, columns: Sequence[str] | None = None) -> TableFile:
    """The table in ``path`` (``.parquet``/``.pq``: Parquet; else CSV, ``.gz``/``.bz2``/``.xz`` decompressed),
    bounded and checked as the module docstring promises. ``columns``: the only ones read (None: all);
    ``frame.attrs["columns"]`` names every column the file has."""
    path = Path(path)
    shown = "'" + printable(str(path)) + "'"  # escaped once: a control character shows as \x1b
    fd = _open_regular(path, shown)
    keep = set(columns) if columns is not None else None
    if path.suffix.lower() in PARQUET:
        return TableFile(_read_parquet(fd, shown, keep), shown, csv=False)
    return TableFile(_read_csv(fd, path, shown, keep), shown, csv=True)
