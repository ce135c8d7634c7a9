"""A sweep's dataset: one row per run (``pipeline.summary.ROW_COLUMNS`` + parameters), in Parquet parts.

    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> import pandas as pd
    >>> from chatterbench.comparisons.studies.sweep.dataset import read_rows, load_rows
    >>> rows = read_rows(tmp)                          # every finished part under tmp/rows/, one row per run
    >>> rows.empty                                     # (no part written yet)
    True
    >>> pd.DataFrame({"engine": ["mujoco"], "dt": [1e-4], "verdict": ["late"],
    ...               "cost_per_sim_s": [0.02]}).to_csv(tmp / "rows.csv", index=False)
    >>> load_rows(tmp / "rows.csv").verdict.tolist()   # a finished sweep dir (rows.parquet), .parquet or .csv
    ['late']
    >>> load_rows(tmp / "missing")
    Traceback (most recent call last):
    ...
    chatterbench.comparisons.studies.sweep.dataset.DatasetError: .../missing: no such file or directory

Rows reach ``OUT/rows/part-*.parquet`` as runs finish, each part written atomically and
tagged with its spec's ``Sweep.fingerprint``; the finished sweep writes ``OUT/rows.parquet``
(all rows in run order). Columns have fixed dtypes whatever the order runs finish in
(``normalize``). ``load_rows`` (``chart``, ``report --sweep``) reads a regular file only (a
pipe, a device or a directory is refused, never waited on) of at most ``MAX_DATASET_BYTES``,
a Parquet file's uncompressed columns included, and ``MAX_DATASET_ROWS`` rows (its footer
says), checked before it is read.

A resumed sweep reads only parts that belong to its spec (``check_parts``) and moves every
other one to ``OUT/rows/set-aside/``, saying why, so rows of two sweeps are never mixed; the
lock and the temp-file cleanup of OUT are ``directory.py``'s.
"""

from __future__ import annotations

import itertools
import math
import os
import stat
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import pandas as pd

from chatterbench.comparisons.pipeline.atomic import write_frame
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS, REFINE_LEVEL, ROW_COLUMNS
from chatterbench.comparisons.pipeline.vocabulary import VERDICTS
from chatterbench.reference.errors import InputError, is_number

from .spec import RunTask, Sweep

SET_ASIDE = "set-aside"  # OUT/rows/set-aside/: parts that do not belong to the sweep resumed
# [bytes] of a dataset a command reads, on disk and, for Parquet, uncompressed: 100,000 rows (a sweep's most) take
# about 100 MiB as CSV; more would be read into several times its size in memory
MAX_DATASET_BYTES = 256 * 2**20
MAX_DATASET_ROWS = 1_000_000  # rows of a Parquet dataset: ten times a sweep's most (spec.MAX_RUNS), told by its footer
FINGERPRINT = "sweep_fingerprint"  # a part's DataFrame.attrs key (stored in its Parquet metadata)


class DatasetError(InputError):
    """A dataset that cannot be read as a sweep's rows; the message says which file and why."""


_FLOAT_COLUMNS = ("dt", "mass_ratio", *METRIC_COLUMNS, "cost_per_sim_s", "reference_cost_per_sim_s", "wall_time_s")
_INT_COLUMNS = ("n_episodes", "n_match", REFINE_LEVEL)


def normalize(frame: pd.DataFrame) -> pd.DataFrame:
    for c in _FLOAT_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").astype(float)
    for c in _INT_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").fillna(0).astype("int64")
    return frame


def part_paths(out_dir: str | Path) -> list[Path]:
    """The part files under ``OUT/rows/``, in the order they were written."""
    return sorted(Path(out_dir, "rows").glob("part-*.parquet"))  # names start with the time: write order


def _why(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _read_part(path: Path) -> pd.DataFrame:
    try:
        return pd.read_parquet(path)
    except Exception as exc:  # a torn or foreign file: pyarrow's errors are not one class
        raise DatasetError(f"{path}: cannot read this part ({_why(exc)}); "
                           "`chatterbench sweep SPEC --out DIR --resume` sets such parts aside") from None


def _frame_of(frames: list[pd.DataFrame], dedupe: bool) -> pd.DataFrame:
    frames = [f for f in frames if len(f)]
    if not frames:
        return pd.DataFrame(columns=ROW_COLUMNS)
    frame = normalize(pd.concat(frames, ignore_index=True))
    if dedupe:
        frame = frame.drop_duplicates(subset=["point_id", "engine"], keep="first").reset_index(drop=True)
    return frame


def read_rows(out_dir: str | Path, dedupe: bool = True) -> pd.DataFrame:
    """All rows under ``OUT/rows/`` (part files in write order); ``dedupe`` keeps the first of a point_id+engine.

    Raises ``DatasetError`` naming a part that cannot be read.
    """
    return _frame_of([_read_part(p) for p in part_paths(out_dir)], dedupe)


def same_value(got: Any, want: Any) -> bool:
    """A row's parameter value is its point's (a NaN of a missing column never is)."""
    try:
        return float(got) == float(want) if is_number(want) else bool(got == want)
    except (TypeError, ValueError):
        return False


def part_fingerprints(out_dir: str | Path) -> set[str | None]:
    """The spec fingerprints (``Sweep.fingerprint``) the readable parts under OUT/rows/ carry; None: a part without one."""
    found = set()
    for path in part_paths(out_dir):
        try:
            found.add(_read_part(path).attrs.get(FINGERPRINT))
        except DatasetError:
            continue
    return found


def part_problem(path: Path, runs: Mapping[tuple[str, str], Any], fingerprint: str, untagged_ok: bool,
                 lattice: Callable[[pd.DataFrame], Mapping] | None = None) -> tuple[pd.DataFrame | None, str | None]:
    """A part's rows, or why it does not belong to the sweep of ``runs`` (``(None, reason)``).

    ``runs``: the sweep's runs by (point_id, engine) (anything with their ``params``);
    ``untagged_ok``: accept a part with no fingerprint (written before parts had one) because
    OUT/sweep.toml named this very spec; ``lattice(frame)``: a refined sweep's runs among the
    part's rows (``adaptive.Levels.lattice_runs``), which no list of runs holds in advance.
    """
    if path.stat().st_size == 0:
        return None, "empty file (0 bytes)"
    try:
        frame = pd.read_parquet(path)
    except Exception as exc:  # as in _read_part
        return None, f"unreadable ({_why(exc)})"
    if frame.empty:
        return None, "holds no rows"
    tag = frame.attrs.get(FINGERPRINT)
    if tag is None and not untagged_ok:
        return None, "no spec fingerprint, and sweep.toml is missing: which sweep wrote it cannot be told"
    if tag is not None and tag != fingerprint:
        return None, f"written by another sweep spec (fingerprint {tag}, this spec's {fingerprint})"
    missing = [c for c in ROW_COLUMNS if c not in frame]
    if missing:
        return None, f"another schema: no column {', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''}"
    if lattice is not None:
        runs = {**lattice(frame), **runs}
    keys = list(zip(frame["point_id"], frame["engine"]))
    foreign = sum(k not in runs for k in keys)
    if foreign:
        return None, f"rows of points not in this sweep ({foreign} of {len(keys)} rows)"
    known = set(ROW_COLUMNS).union(*(dict(runs[k].params) for k in keys)) | ({REFINE_LEVEL} if lattice else set())
    extra = [c for c in frame if c not in known]
    if extra:
        return None, f"another schema: columns {', '.join(map(repr, extra[:4]))} are not this sweep's"
    for i, key in enumerate(keys):
        for name, want in runs[key].params:
            got = frame[name].iat[i] if name in frame else math.nan
            if name != "dt" and not same_value(got, want):  # dt: the engine's own, in ROW_COLUMNS
                return None, f"another schema: row {i} has {name} = {got!r}, its point has {want!r}"
    return frame, None


@dataclass(frozen=True)
class SetAside:
    """A part moved out of a sweep's rows, and why."""

    source: Path  # where it was: OUT/rows/part-*.parquet
    path: Path  # where it is: OUT/rows/set-aside/...
    reason: str


def check_parts(out_dir: str | Path, runs: Sequence[RunTask], fingerprint: str, untagged_ok: bool,
                lattice: Callable[[pd.DataFrame], Mapping] | None = None) -> tuple[pd.DataFrame, list[SetAside]]:
    """Every part under OUT/rows/ read once: (the rows of those that belong, deduplicated; those set aside).

    A part is set aside (moved to ``OUT/rows/set-aside/``) when it is empty or unreadable,
    when another spec wrote it (``Sweep.fingerprint``), when it has rows of points not in
    ``runs``, or when its columns are not those of its rows' runs (``part_problem``; a refined
    sweep's ``lattice`` finds its points of later levels).
    """
    by_key = {(r.point_id, r.engine): r for r in runs}
    frames, aside = [], []
    for path in part_paths(out_dir):
        frame, reason = part_problem(path, by_key, fingerprint, untagged_ok, lattice)
        if reason is None:
            frames.append(frame)
            continue
        folder = path.parent / SET_ASIDE
        folder.mkdir(exist_ok=True)
        target, n = folder / path.name, 0
        while target.exists():
            n += 1
            target = folder / f"{path.stem}.{n}{path.suffix}"
        os.replace(path, target)
        aside.append(SetAside(path, target, reason))
    return _frame_of(frames, dedupe=True), aside


class PartWriter:
    """Appends batches of rows to OUT/rows/ as atomically written part files tagged with ``fingerprint``."""

    def __init__(self, rows_dir: Path, fingerprint: str = "") -> None:
        self.dir = rows_dir
        self.dir.mkdir(parents=True, exist_ok=True)
        self.fingerprint = fingerprint
        self.seq = 0

    def append(self, rows: list[dict[str, Any]]) -> None:
        if not rows:
            return
        self.seq += 1
        # time first, so that sorted names are write order across resumed sessions
        name = f"part-{time.time_ns():020d}-{os.getpid()}-{self.seq:06d}.parquet"
        frame = normalize(pd.DataFrame(rows))
        if self.fingerprint:
            frame.attrs[FINGERPRINT] = self.fingerprint
        write_frame(self.dir / name, frame)


def ordered(frame: pd.DataFrame, runs: Sequence[RunTask], sweep: Sweep) -> pd.DataFrame:
    order = {(r.point_id, r.engine): r.index for r in runs}
    frame = frame.assign(_order=[order.get(k, len(order)) for k in zip(frame["point_id"], frame["engine"])])
    frame = frame.sort_values("_order", kind="stable").drop(columns="_order").reset_index(drop=True)
    params = list(dict.fromkeys(itertools.chain(sweep.fixed, sweep.grid, *sweep.points)))
    params = [p for p in params if p in frame and p != "dt"]
    head = ["point_id", "scene", "engine"]
    rest = [c for c in ROW_COLUMNS if c not in head]
    extra = [c for c in frame.columns if c not in head + params + rest]
    return frame[head + params + [c for c in rest if c in frame] + extra]


def load_rows(path: str | Path) -> pd.DataFrame:
    """The rows of a dataset: a sweep directory (``rows.parquet``), a ``.parquet`` or a ``.csv`` file."""
    path = Path(path)
    if path.is_dir():
        if (path / "rows.parquet").is_symlink():  # a sweep writes none: it could stand for any file of the machine
            raise DatasetError(f"{path}: rows.parquet is a symbolic link (-> {os.readlink(path / 'rows.parquet')}); "
                               "nothing in an input folder is read through a link: give the file itself")
        if not (path / "rows.parquet").is_file():
            hint = (" (the sweep has not finished: finish it with `chatterbench sweep SPEC --out DIR --resume`)"
                    if (path / "rows").is_dir() else " (give a sweep output directory, a .parquet or a .csv file)")
            raise DatasetError(f"{path}: no rows.parquet in this directory{hint}")
        path = path / "rows.parquet"
    elif not path.exists():
        raise DatasetError(f"{path}: no such file or directory")
    _check_size(path)
    try:
        if path.suffix == ".parquet":
            rows = pd.read_parquet(path)
        elif path.suffix == ".csv":
            # "none" is a verdict, not a missing value; an empty message is ""
            rows = pd.read_csv(path, keep_default_na=False, na_values=["", "nan", "NaN"],
                               dtype={"verdict": str, "status": str, "engine": str, "scene": str, "message": str})
        else:
            raise DatasetError(f"{path}: expected a sweep directory, a .parquet or a .csv file")
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path}: cannot read the rows ({exc})") from None
    missing = [c for c in ("engine", "dt", "verdict", "cost_per_sim_s") if c not in rows.columns]
    if missing:
        raise DatasetError(f"{path}: not a sweep dataset, missing columns {', '.join(missing)} "
                         f"(expected {', '.join(ROW_COLUMNS)} and one column per parameter)")
    if rows.empty:
        raise DatasetError(f"{path}: the dataset has no rows")
    check_values(rows, str(path))
    return rows


def _check_size(path: Path) -> None:
    """Refuse (``DatasetError``) what is not a regular file of at most ``MAX_DATASET_BYTES`` (Parquet: uncompressed too),
    before it is read; a named pipe is opened without waiting for a writer."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        raise DatasetError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        info = os.fstat(fd)
    finally:
        os.close(fd)
    if not stat.S_ISREG(info.st_mode):
        raise DatasetError(f"{path}: not a regular file (a device, pipe or socket); give a sweep directory, a .parquet "
                           "or a .csv file")
    size = info.st_size
    if path.suffix == ".parquet" and size <= MAX_DATASET_BYTES:
        try:
            import pyarrow.parquet as pq

            meta = pq.ParquetFile(path).metadata
            size = max(size, sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups)))
        except (OSError, ValueError) as exc:  # pyarrow's ArrowInvalid is a ValueError
            raise DatasetError(f"{path}: cannot read the rows ({exc})") from None
        if meta.num_rows > MAX_DATASET_ROWS:  # a few kB of repeated values can stand for gigabytes in memory
            raise DatasetError(f"{path}: {meta.num_rows:,} rows, more than the {MAX_DATASET_ROWS:,} a dataset may hold "
                               "(a sweep has at most 100,000 runs); chart a part of it")
    if size > MAX_DATASET_BYTES:
        raise DatasetError(f"{path}: {size / 2**20:.0f} MiB of rows, more than the {MAX_DATASET_BYTES / 2**20:.0f} MiB a "
                           "dataset may hold (100,000 runs take about 100 MiB); chart a part of it")


def check_values(rows: pd.DataFrame, where: str) -> None:
    """Refuse (``DatasetError``) a dataset whose verdicts are not the judge's or whose numbers are text."""
    unknown = sorted(set(rows["verdict"].astype(str)) - set(VERDICTS))
    if unknown:
        raise DatasetError(f"{where}: column verdict: unknown verdict(s) {', '.join(map(repr, unknown[:5]))}; "
                           f"allowed: {', '.join(VERDICTS)}")
    for c in (c for c in _FLOAT_COLUMNS + _INT_COLUMNS if c in rows):
        if rows[c].dtype == bool or not (pd.api.types.is_numeric_dtype(rows[c]) or rows[c].isna().all()):
            numbers = pd.to_numeric(rows[c].replace("", float("nan")), errors="coerce")
            bad = rows[c][numbers.isna() & rows[c].notna() & (rows[c].astype(str) != "")]
            if len(bad) or rows[c].dtype == bool:
                first = bad.iloc[0] if len(bad) else rows[c].iloc[0]
                raise DatasetError(f"{where}: column {c}: {first!r} (row {(bad.index[0] if len(bad) else 0)}) is not a "
                                   "number; the column holds numbers")
