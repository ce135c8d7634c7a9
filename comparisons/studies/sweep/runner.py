"""Running a sweep: every run of the spec on a local process pool or a Dask cluster, resumable, with progress.

    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> from chatterbench.comparisons.studies.sweep.runner import run_sweep
    >>> from chatterbench.comparisons.studies.sweep import Sweep
    >>> sweep = Sweep(scene="bouncing-ball", engines=("pybullet",), fixed={"duration": 0.6, "dt": 1e-3},
    ...               grid={"restitution": (0.3, 0.5)})
    >>> rows = run_sweep(sweep, tmp / "sweep", workers=1, progress=False)
    >>> rows[["engine", "restitution", "status"]].values.tolist()
    [['pybullet', 0.3, 'ok'], ['pybullet', 0.5, 'ok']]

Promises: the whole spec is checked before any engine starts; rows reach ``OUT/rows/`` as
runs finish; a sweep killed at any moment and resumed (``resume=True``) ends with exactly
the rows of an uninterrupted one: finished rows are never re-run, unfinished runs are run once.
One sweep at a time holds OUT (a second is refused, naming the holder); a resumed sweep sets
aside, with a note on stderr, every part that is not its own (``dataset.check_parts``). On
Dask, a cluster left with no worker for ``no_worker_wait`` seconds is said on stderr, then
waited for or stopped (``no_workers``), the finished rows kept. A sweep with ``[refine]``
runs level by level (``adaptive.Levels``): the grid, then the points of the cells whose
corners differ, each level's rows (with their ``refine_level``) written before the next is
planned from them; resumed mid-level, it plans the same levels and runs what is missing.
Layout of OUT: ``sweep.toml`` (the resolved spec, written first), ``rows/`` (the Parquet
dataset, one part per batch of finished runs), ``rows.parquet`` (all rows in run order),
``.lock`` (``directory.OutLock``).
"""

from __future__ import annotations

import math
import os
import signal
import sys
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any, Callable

import pandas as pd

from chatterbench.comparisons.pipeline.atomic import interrupts_held, write_frame, write_text
from chatterbench.comparisons.pipeline.summary import REFINE_LEVEL
from chatterbench.engines.isolate import die_with_parent
from chatterbench.reference.errors import InputError, check_choice, check_integer, check_number

from .adaptive import Levels
from .dataset import PartWriter, SetAside, check_parts, ordered, part_fingerprints, read_rows
from .directory import OutLock, clean_temps, refuse_links
from .spec import FAILED, MAX_TIMEOUT, SpecError, Sweep, load_sweep, sweep_runs
from .worker import run_batch_task, work_units
from ..limits import NO_WORKER_WAIT, NO_WORKERS  # shown by `sweep --help` without loading this module
from ..pools import stop_pool
from ..waits import POLL_S

_SHOWN_ASIDE = 3  # set-aside parts named per reason; more are counted


class NoWorkersError(InputError):
    """A Dask cluster had no worker for longer than allowed (``no_workers="stop"``): exit 2, as an unreachable scheduler."""


def _worker_start(sweep: int) -> None:
    """A local pool worker's start: it dies with the sweep (process ``sweep``) and leaves Ctrl-C to it (``pools.stop_pool``
    ends it); a sweep gone before the worker could ask for that is not outlived."""
    die_with_parent(sweep)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the runs it forks inherit this
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _local_pool(workers: int | None, started: list) -> ProcessPoolExecutor:
    """A process pool whose workers are all started now, with Ctrl-C held back while they fork; appended to
    ``started`` before any worker exists, so that the caller stops it (``pools.stop_pool``) whatever ends the sweep, a
    Ctrl-C while the pool starts or before its caller holds it included (an unstopped pool, whose workers ignore
    Ctrl-C, kept the interrupted sweep from exiting: seen under load).

    A Ctrl-C that reaches a child in the middle of ``fork`` prints "Exception ignored in ...
    _releaseLock ... KeyboardInterrupt"; held back (blocked), it reaches the sweep once they exist. Held at
    Python's level too (``atomic.interrupts_held``): one that another thread received is raised only then, never
    between a worker's fork and the pool's record of it (a worker the pool did not know outlived the sweep, holding
    its output pipes: 1 of 25 Ctrl-Cs under load, seen).
    """
    pool = ProcessPoolExecutor(max_workers=workers or os.cpu_count() or 1, initializer=_worker_start,
                               initargs=(os.getpid(),))
    started.append(pool)
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        with interrupts_held():
            pool.submit(int).result()  # a fork-context pool starts every worker at its first submit
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    return pool


def _note(text: str) -> None:
    print(f"chatterbench: note: {text}", file=sys.stderr)


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


def _progress(total: int, done: int, enabled: bool | Callable[[int, int, str], Any], desc: str = "sweep"):
    if callable(enabled):  # the caller's bar (the command line's: a tqdm bar, or plain lines in a log)
        return enabled(total, done, desc)
    from tqdm import tqdm

    on = enabled and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    return tqdm(total=total, initial=done, desc=desc, unit="run", file=sys.stderr, disable=not on,
                dynamic_ncols=True, smoothing=0.1)


def _n_workers(client: Any) -> int:
    try:
        return len(client.nthreads())
    except Exception:  # a scheduler that cannot answer has no worker to offer
        return 0


class _WorkerWatch:
    """Watches a Dask cluster while a sweep waits on it: no worker for ``patience`` s is said, then waited or stopped."""

    def __init__(self, client: Any, patience: float, policy: str, total: int) -> None:
        self.client, self.patience, self.policy, self.total = client, patience, policy, total
        self.since: float | None = None  # when the cluster was first seen without a worker
        self.said = False
        # wait() returns at this interval [s] to look at the cluster; locally at POLL_S, so that a Ctrl-C that another
        # thread received is acted on (waits.py)
        self.interval = POLL_S if client is None else min(1.0, patience / 4)

    def idle(self, done: int) -> None:
        """Nothing finished for ``interval`` s: look for workers."""
        if self.client is None:
            return
        n, now = _n_workers(self.client), time.monotonic()
        if n:
            if self.said:
                _note(f"Dask: {n} worker(s) back; the sweep goes on")
            self.since, self.said = None, False
            return
        self.since = now if self.since is None else self.since
        if now - self.since < self.patience:
            return
        where = getattr(self.client, "scheduler", None)
        where = f" at {where.address}" if getattr(where, "address", None) else ""
        if self.policy == "stop":
            raise NoWorkersError(f"Dask scheduler{where}: no worker for {self.patience:g} s (--dask-wait); stopped "
                                 f"(--dask-no-workers stop) with {done} of {self.total} runs finished, their rows kept; "
                                 "finish with --resume")
        if not self.said:
            _note(f"Dask scheduler{where}: no worker for {self.patience:g} s (--dask-wait); waiting for one "
                  f"(--dask-no-workers wait), {done} of {self.total} runs finished; Ctrl-C stops, keeping their rows")
            self.said = True

    def progressed(self) -> None:
        self.since = None


def _note_set_aside(aside: list[SetAside]) -> None:
    """One stderr line per reason: how many parts, where they went, the first few names."""
    by_reason: dict[str, list[SetAside]] = {}
    for a in aside:
        by_reason.setdefault(a.reason, []).append(a)
    for reason, parts in by_reason.items():
        names = ", ".join(a.source.name for a in parts[:_SHOWN_ASIDE])
        more = f" and {len(parts) - _SHOWN_ASIDE} more" if len(parts) > _SHOWN_ASIDE else ""
        _note(f"set aside {len(parts)} part file(s) of {parts[0].source.parent} in {parts[0].path.parent} "
              f"({names}{more}): {reason}")


def _prepare_out(sweep: Sweep, out: Path, resume: bool) -> bool:
    """Check OUT against the spec and write sweep.toml; True when OUT's sweep.toml was this very spec's."""
    spec_path = out / "sweep.toml"
    has_rows = any((out / "rows").glob("part-*.parquet")) if (out / "rows").is_dir() else False
    same = False
    previous = None
    if has_rows and resume and (spec_path.exists() or spec_path.is_symlink()):
        try:
            previous = load_sweep(spec_path, sweep.budget)
        except InputError as exc:  # damaged: the rows say which spec wrote them (their fingerprint)
            if sweep.fingerprint() not in part_fingerprints(out):
                raise SpecError(f"{spec_path}: the sweep written there cannot be read back ({exc}), and no rows under "
                                f"{out / 'rows'} were written by {sweep.source}; resume with the spec that wrote them, "
                                "or choose another --out") from None
            _note(f"{spec_path}: cannot be read back ({exc}); resuming from the rows of {sweep.source} (their spec "
                  "fingerprint), and writing it again")
    if previous is not None:
        if previous.identity() != sweep.identity():
            diff = [k for k in sweep.identity() if sweep.identity()[k] != previous.identity()[k]]
            raise SpecError(f"{out}: holds rows of a different sweep ({', '.join(diff)} differ); "
                            "resume with the same spec or choose another --out")
        same = True
    if has_rows and not resume:
        raise SpecError(f"{out}: already holds sweep rows; pass --resume to finish that sweep, or choose an empty --out")
    write_text(spec_path, sweep.to_toml())
    return same


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path,
    executor: Executor | Any | None = None,
    resume: bool = False,
    workers: int | None = None,
    progress: bool | Callable[[int, int, str], Any] = True,
    batch: int | None = None,
    no_worker_wait: float = NO_WORKER_WAIT,
    no_workers: str = "wait",
) -> pd.DataFrame:
    """Run every run of ``sweep`` not yet in ``out_dir``; returns all its rows in run order.

    Parameters
    ----------
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Where runs execute; default a local ``ProcessPoolExecutor`` of ``workers`` processes
        (all cores). A Dask ``Client`` is used through ``client.get_executor()``.
    resume : bool
        Continue the sweep already in ``out_dir`` (same spec); without it ``out_dir``
        must hold no rows. Parts that are not this sweep's are moved to
        ``OUT/rows/set-aside/`` with a note on stderr (``dataset.check_parts``).
    workers : int, optional
        Local pool size; with a given executor only bounds the runs in flight.
    progress : bool or callable
        tqdm bar on stderr (done/total, failures, ETA) when stderr is a terminal; or
        ``progress(total, done, desc)`` making the bar (``update(n)``, ``set_postfix(failed=n)``, ``close()``).
    batch : int, optional
        Runs per unit of work (one isolated child; MuJoCo: one ``mujoco.rollout`` call), see
        ``work_units``; default automatic, 1 runs every run alone. The rows are the same either way.
    no_worker_wait : float
        [s] in (0, 86400]: a Dask cluster with no worker this long is said on stderr, then ...
    no_workers : {"wait", "stop"}
        ... waited for, or stopped with ``NoWorkersError`` (the finished rows kept).

    Raises ``OutDirError`` when another sweep holds ``out_dir`` (``directory.OutLock``).

    Returns
    -------
    DataFrame
        ``rows.ROW_COLUMNS`` plus one column per parameter; ``attrs["sweep"]`` holds this
        call's ``wall_s``, ``runs`` executed, ``units`` of work submitted (``work_units``), ``run_s_sum`` (isolated runs' own wall time),
        ``engine_s_sum`` (their engine stepping time), ``workers`` and ``set_aside`` (parts set aside);
        with ``[refine]`` also ``levels``: the runs of each level, finished before or now.
    """
    if workers is not None:
        check_integer("workers", workers, lo=1, error=SpecError)
    if batch is not None:
        check_integer("batch", batch, lo=1, error=SpecError)
    check_number("no_worker_wait", no_worker_wait, lo=0.0, hi=MAX_TIMEOUT, lo_open=True, unit=" [s]", error=SpecError)
    check_choice("no_workers", no_workers, NO_WORKERS, error=SpecError)
    out = Path(out_dir)
    levels = Levels(sweep) if sweep.refine is not None else None
    runs = levels.runs(0, None) if levels else sweep_runs(sweep)
    options = (workers, progress, batch, no_worker_wait, no_workers)
    refuse_links(out)  # before the lock, so a refusal leaves nothing behind; again once held (a link made meanwhile)
    with OutLock(out) as lock:  # from here on this process alone writes OUT
        refuse_links(out)
        clean_temps(out, lock.tags)
        same_spec = _prepare_out(sweep, out, resume)
        have, aside = check_parts(out, runs, sweep.fingerprint(), untagged_ok=same_spec,
                                  lattice=levels.lattice_runs if levels else None)
        _note_set_aside(aside)
        if levels is None:
            stats = _run(sweep, out, runs, have, executor, *options)
        else:
            stats, runs = _run_levels(sweep, levels, out, runs, have, executor, options)
        stats["set_aside"] = len(aside)
        frame = ordered(read_rows(out), runs, sweep)
        write_frame(out / "rows.parquet", frame)
    frame.attrs["sweep"] = stats
    return frame


def _run_levels(sweep: Sweep, levels: Levels, out: Path, runs: list, have: pd.DataFrame, executor: Any,
                options: tuple) -> tuple[dict[str, Any], list]:
    """Level 0 (``runs``), then each level's runs from the rows so far; returns the stats and every run in order."""
    owned: list = []  # the pool this sweep starts, once it exists
    total: dict[str, Any] = {"levels": []}
    every, seen = list(runs), {r.point_id for r in runs}
    interrupted = True
    try:
        if executor is None:  # one pool for every level: its workers stay warm
            executor = _local_pool(options[0], owned)
        for level in range(sweep.refine.depth + 1):
            if level:
                have = read_rows(out)  # the rows of the levels before, this session's and earlier ones
                runs = levels.runs(level, have, start=len(every), seen=seen)
                every += runs
            stats = _run(sweep, out, runs, have, executor, *options, level=level)
            for k, v in stats.items():
                total[k] = max(total.get(k, 0), v) if k == "workers" else total.get(k, 0) + v
            total["levels"].append(len(runs))
        interrupted = False
    finally:
        for pool in owned:
            stop_pool(pool, interrupted)
    return total, every


def _executor(executor: Any, workers: int | None, started: list) -> tuple[Any, Any]:
    """(where to submit, the Dask client to watch or None); a local pool it starts goes to ``started``."""
    if executor is None:
        return _local_pool(workers, started), None
    if hasattr(executor, "get_executor"):  # a dask.distributed Client
        return executor.get_executor(pure=False), executor
    return executor, getattr(executor, "_client", None)  # a Dask ClientExecutor given as is, or any Executor


class _Tally:
    """The finished runs of one ``_run``: their rows appended to OUT/rows/, the stats and the progress bar kept."""

    def __init__(self, writer: PartWriter, stats: dict[str, Any], bar: Any, failures: int, level: int | None) -> None:
        self.writer, self.stats, self.bar, self.failures, self.level = writer, stats, bar, failures, level
        bar.set_postfix(failed=failures)

    def add(self, results: list) -> None:
        self.writer.append([_tagged(r.row, self.level) for r in results])
        for r in results:
            self.stats["runs"] += 1
            self.stats["run_s_sum"] += r.run_time
            w = r.row.get("wall_time_s")
            self.stats["engine_s_sum"] += w if isinstance(w, float) and math.isfinite(w) else 0.0
            self.failures += r.row["status"] in FAILED

    def show(self, n: int) -> None:
        self.bar.update(n)
        self.bar.set_postfix(failed=self.failures)


def _drain(executor: Any, units: list, slots: int, watch: _WorkerWatch, tally: _Tally, done_before: int) -> None:
    """Submit ``units`` (at most 2 x ``slots`` in flight) and tally each as it finishes.

    A bounded window: Ctrl-C cancels little, and memory stays flat for any sweep size. On any
    exception the pending units are cancelled, the rows of those that finished meanwhile kept
    (the rest run on --resume), and the exception raised again.
    """
    pending: set[Future] = set()
    queue = iter(units)
    try:
        while True:
            while len(pending) < 2 * slots and (unit := next(queue, None)) is not None:
                pending.add(executor.submit(run_batch_task, unit))
            if not pending:
                return
            finished, pending = wait(pending, timeout=watch.interval, return_when=FIRST_COMPLETED)
            if not finished:
                watch.idle(done_before + tally.stats["runs"])
                continue
            watch.progressed()
            results = [r for f in finished if f.exception() is None for r in f.result()]
            tally.add(results)
            for f in finished:  # an executor failure (a broken pool, a lost Dask worker) ends the sweep
                if f.exception() is not None:
                    raise f.exception()
            tally.show(len(results))
    except BaseException:
        for f in pending:
            f.cancel()
        tally.add([r for f in pending if f.done() and not f.cancelled() and f.exception() is None for r in f.result()])
        raise


def _run(sweep: Sweep, out: Path, runs: list, have: pd.DataFrame, executor: Any, workers: int | None,
         progress: bool, batch: int | None, no_worker_wait: float, no_workers: str, level: int | None = None
         ) -> dict[str, Any]:
    """Run the runs not in ``have``, appending their rows to OUT/rows/; returns run_sweep's stats.

    ``level``: a refined sweep's level, written in each row's ``refine_level``.
    """
    writer = PartWriter(out / "rows", sweep.fingerprint())  # OUT/rows/ exists from here on, with rows or not
    done_keys = set(zip(have["point_id"], have["engine"]))
    todo = [r for r in runs if (r.point_id, r.engine) not in done_keys]
    stats = {"wall_s": 0.0, "runs": 0, "units": 0, "run_s_sum": 0.0, "engine_s_sum": 0.0, "workers": 0}
    start = time.perf_counter()
    if todo:
        owned: list = []  # a pool this run starts, once it exists
        bar, interrupted = None, True
        try:
            executor, client = _executor(executor, workers, owned)
            stats["workers"] = slots = workers or _slots(executor) or os.cpu_count() or 1
            units = work_units(todo, batch, slots)
            stats["units"] = len(units)
            bar = _progress(len(runs), len(runs) - len(todo), progress, "sweep" if level is None else f"level {level}")
            failures = int(have["status"].isin(FAILED).sum()) if len(have) else 0
            tally = _Tally(writer, stats, bar, failures, level)
            _drain(executor, units, slots, _WorkerWatch(client, no_worker_wait, no_workers, len(runs)), tally,
                   len(runs) - len(todo))
            interrupted = False
        finally:
            if bar is not None:
                bar.close()
            for pool in owned:
                stop_pool(pool, interrupted)
    stats["wall_s"] = time.perf_counter() - start
    return stats


def _tagged(row: dict[str, Any], level: int | None) -> dict[str, Any]:
    """The row as written: a refined sweep's rows carry the level their point was added at."""
    return row if level is None else {**row, REFINE_LEVEL: level}
