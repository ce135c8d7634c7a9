"""A sweep's dataset: one row per run (``pipeline.summary.ROW_COLUMNS`` + parameters), in Parquet parts.

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

Rows reach ``OUT/rows/part-*.parquet`` as runs finish, each part written atomically; the
finished sweep writes ``OUT/rows.parquet`` (all rows in run order). Columns have fixed
dtypes whatever the order runs finish in (``normalize``).
"""

from __future__ import annotations

import itertools
import os
import time
from pathlib import Path
from typing import Any, Sequence

import pandas as pd

from chatterbench.comparisons.outputs.atomic import write_frame
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS, ROW_COLUMNS
from chatterbench.reference.errors import InputError

from .spec import RunTask, Sweep


class DatasetError(InputError):
    """A dataset that cannot be read as a sweep's rows; the message says which file and why."""


_FLOAT_COLUMNS = ("dt", "mass_ratio", *METRIC_COLUMNS, "cost_per_sim_s", "reference_cost_per_sim_s", "wall_time_s")
_INT_COLUMNS = ("n_episodes", "n_match")


def normalize(frame: pd.DataFrame) -> pd.DataFrame:
    for c in _FLOAT_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").astype(float)
    for c in _INT_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").fillna(0).astype("int64")
    return frame


def read_rows(out_dir: str | Path, dedupe: bool = True) -> pd.DataFrame:
    """All rows under ``OUT/rows/`` (part files in write order); ``dedupe`` keeps the first of a point_id+engine."""
    parts = sorted(Path(out_dir, "rows").glob("part-*.parquet"))
    frames = [pd.read_parquet(p) for p in parts]
    frames = [f for f in frames if len(f)]
    if not frames:
        return pd.DataFrame(columns=ROW_COLUMNS)
    frame = normalize(pd.concat(frames, ignore_index=True))
    if dedupe:
        frame = frame.drop_duplicates(subset=["point_id", "engine"], keep="first").reset_index(drop=True)
    return frame


class PartWriter:
    """Appends batches of rows to OUT/rows/ as atomically written part files."""

    def __init__(self, rows_dir: Path) -> None:
        self.dir = rows_dir
        self.dir.mkdir(parents=True, exist_ok=True)
        for stale in self.dir.glob(".part-*.tmp"):  # torn writes of a killed sweep
            stale.unlink(missing_ok=True)
        self.seq = 0

    def append(self, rows: list[dict[str, Any]]) -> None:
        if not rows:
            return
        self.seq += 1
        # time first, so that sorted names are write order across resumed sessions
        name = f"part-{time.time_ns():020d}-{os.getpid()}-{self.seq:06d}.parquet"
        write_frame(self.dir / name, normalize(pd.DataFrame(rows)))


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
        if not (path / "rows.parquet").is_file():
            hint = (" (the sweep has not finished: finish it with `chatterbench sweep SPEC --out DIR --resume`)"
                    if (path / "rows").is_dir() else " (give a sweep output directory, a .parquet or a .csv file)")
            raise DatasetError(f"{path}: no rows.parquet in this directory{hint}")
        path = path / "rows.parquet"
    elif not path.exists():
        raise DatasetError(f"{path}: no such file or directory")
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
    return rows
