"""Running a sweep: every run of the spec on a local process pool or a Dask cluster, resumable, with progress.

    >>> from chatterbench.comparisons.studies.sweep import Sweep
    >>> sweep = Sweep(scene="bouncing-ball", engines=("pybullet",), fixed={"duration": 0.6, "dt": 1e-3},
    ...               grid={"restitution": (0.3, 0.5)})
    >>> rows = run_sweep(sweep, tmp / "sweep", workers=1, progress=False)
    >>> rows[["engine", "restitution", "status"]].values.tolist()
    [['pybullet', 0.3, 'ok'], ['pybullet', 0.5, 'ok']]

Promises: the whole spec is checked before any engine starts; rows reach ``OUT/rows/`` as
runs finish; a sweep killed at any moment and resumed (``resume=True``) ends with exactly
the rows of an uninterrupted one: finished rows are never re-run, unfinished runs are run once.
Layout of OUT: ``sweep.toml`` (the resolved spec, written first), ``rows/`` (the Parquet
dataset, one part per batch of finished runs), ``rows.parquet`` (all rows in run order).
"""

from __future__ import annotations

import math
import os
import sys
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

import pandas as pd

from chatterbench.comparisons.outputs.atomic import write_frame, write_text
from chatterbench.comparisons.studies.isolate import die_with_parent
from chatterbench.reference.errors import InputError

from .dataset import PartWriter, ordered, read_rows
from .spec import FAILED, SpecError, Sweep, load_sweep, sweep_runs
from .worker import run_batch_task, work_units

def _slots(executor: Any) -> int | None:
    """Parallel slots an executor offers, when it says (process pool, Dask)."""
    n = getattr(executor, "_max_workers", None)
    if isinstance(n, int):
        return n
    client = getattr(executor, "_client", None)
    if client is not None:
        try:
            return max(1, sum(client.nthreads().values()))
        except Exception:
            return None
    return None


def _progress(total: int, done: int, enabled: bool):
    from tqdm import tqdm

    on = enabled and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    return tqdm(total=total, initial=done, desc="sweep", unit="run", file=sys.stderr, disable=not on,
                dynamic_ncols=True, smoothing=0.1)


def _prepare_out(sweep: Sweep, out: Path, resume: bool) -> None:
    spec_path = out / "sweep.toml"
    has_rows = any((out / "rows").glob("part-*.parquet")) if (out / "rows").is_dir() else False
    if has_rows and resume and spec_path.exists():
        try:
            previous = load_sweep(spec_path)
        except InputError as exc:
            raise SpecError(f"{spec_path}: the sweep written there cannot be read back ({exc}); choose another --out") from None
        if previous.identity() != sweep.identity():
            diff = [k for k in sweep.identity() if sweep.identity()[k] != previous.identity()[k]]
            raise SpecError(f"{out}: holds rows of a different sweep ({', '.join(diff)} differ); "
                            "resume with the same spec or choose another --out")
    if has_rows and not resume:
        raise SpecError(f"{out}: already holds sweep rows; pass --resume to finish that sweep, or choose an empty --out")
    write_text(spec_path, sweep.to_toml())


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path,
    executor: Executor | Any | None = None,
    resume: bool = False,
    workers: int | None = None,
    progress: bool = True,
    batch: int | None = None,
) -> pd.DataFrame:
    """Run every run of ``sweep`` not yet in ``out_dir``; returns all its rows in run order.

    Parameters
    ----------
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Where runs execute; default a local ``ProcessPoolExecutor`` of ``workers`` processes
        (all cores). A Dask ``Client`` is used through ``client.get_executor()``.
    resume : bool
        Continue the sweep already in ``out_dir`` (same spec); without it ``out_dir``
        must hold no rows.
    workers : int, optional
        Local pool size; with a given executor only bounds the runs in flight.
    progress : bool
        tqdm bar on stderr (done/total, failures, ETA) when stderr is a terminal.
    batch : int, optional
        Runs per unit of work (one isolated child; MuJoCo: one ``mujoco.rollout`` call), see
        ``work_units``; default automatic, 1 runs every run alone. The rows are the same either way.

    Returns
    -------
    DataFrame
        ``rows.ROW_COLUMNS`` plus one column per parameter; ``attrs["sweep"]`` holds this
        call's ``wall_s``, ``runs`` executed, ``units`` of work submitted (``work_units``), ``run_s_sum`` (isolated runs' own wall time),
        ``engine_s_sum`` (their engine stepping time) and ``workers``.
    """
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise SpecError(f"workers = {workers!r}: must be an integer >= 1")
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise SpecError(f"batch = {batch!r}: must be an integer >= 1")
    out = Path(out_dir)
    runs = sweep_runs(sweep)
    _prepare_out(sweep, out, resume)
    writer = PartWriter(out / "rows")
    have = read_rows(out)
    done_keys = set(zip(have["point_id"], have["engine"]))
    todo = [r for r in runs if (r.point_id, r.engine) not in done_keys]
    failures = int(have["status"].isin(FAILED).sum()) if len(have) else 0
    stats = {"wall_s": 0.0, "runs": 0, "units": 0, "run_s_sum": 0.0, "engine_s_sum": 0.0, "workers": 0}
    start = time.perf_counter()
    owned = None
    if todo:
        if executor is None:
            owned = executor = ProcessPoolExecutor(max_workers=workers or os.cpu_count() or 1, initializer=die_with_parent)
        elif hasattr(executor, "get_executor"):  # a dask.distributed Client
            executor = executor.get_executor(pure=False)
        slots = workers or _slots(executor) or os.cpu_count() or 1
        stats["workers"] = slots
        bar = _progress(len(runs), len(runs) - len(todo), progress)
        bar.set_postfix(failed=failures)
        pending: set[Future] = set()
        units = work_units(todo, batch, slots)
        stats["units"] = len(units)
        queue = iter(units)
        try:
            while True:
                # a bounded window: Ctrl-C cancels little, and memory stays flat for any sweep size
                while len(pending) < 2 * slots:
                    unit = next(queue, None)
                    if unit is None:
                        break
                    pending.add(executor.submit(run_batch_task, unit))
                if not pending:
                    break
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                results = [r for f in finished if f.exception() is None for r in f.result()]
                writer.append([r.row for r in results])
                for f in finished:  # an executor failure (a broken pool, a lost Dask worker) ends the sweep
                    if f.exception() is not None:
                        raise f.exception()
                for r in results:
                    stats["runs"] += 1
                    stats["run_s_sum"] += r.run_time
                    w = r.row.get("wall_time_s")
                    stats["engine_s_sum"] += w if isinstance(w, float) and math.isfinite(w) else 0.0
                    failures += r.row["status"] in FAILED
                bar.update(len(results))
                bar.set_postfix(failed=failures)
        except BaseException:
            for f in pending:
                f.cancel()
            # rows of runs that finished meanwhile are kept; the rest run on --resume
            done_now = [f for f in pending if f.done() and not f.cancelled() and f.exception() is None]
            writer.append([r.row for f in done_now for r in f.result()])
            raise
        finally:
            bar.close()
            if owned is not None:
                owned.shutdown(wait=True, cancel_futures=True)
    stats["wall_s"] = time.perf_counter() - start
    frame = ordered(read_rows(out), runs, sweep)
    write_frame(out / "rows.parquet", frame)
    frame.attrs["sweep"] = stats
    return frame
