"""Jobs run side by side, ``at_once`` at a time, each in a thread of its own: an atlas's cases, each with its pool.

    >>> from chatterbench.comparisons.studies.side_by_side import side_by_side
    >>> done = []
    >>> side_by_side([1, 2, 3], 2, lambda x: x * x, finished=lambda x, y: done.append((x, y)))
    >>> sorted(done)
    [(1, 1), (2, 4), (3, 9)]

Why: a case of the atlas (one ``tune``) keeps its pool's workers busy only while a pass runs. Between
passes the search decides in the command's process, and a pass ends on its last candidates with a
worker idle: the atlas kept before this ran at 166% CPU on 2 cores with 2 workers. A second case
beside it takes those idle stretches. Each job brings its own pool (the atlas's ``pool``), so the
machine runs ``at_once`` x ``--workers`` workers at the busiest.

Promises:

- **The same results.** Nothing a job computes depends on what runs beside it (each case's
  search is its own; a task's result does not depend on the worker that ran it). Only the
  measured times (a run's ``cost_per_sim_s``, a case's ``wall_s``) include the sharing.
- **Finished in this thread.** ``started`` and ``finished`` are called here, in the calling
  thread, as each job starts and ends (in the order they end), so what ``finished`` writes is
  written by the thread that a Ctrl-C or a SIGTERM interrupts (``atomic.staged`` removes a
  half-written file there).
- **Stopped at once.** An exception here (Ctrl-C, ``cli.Terminated``) or in a job kills every
  process this one started through ``multiprocessing`` (the jobs' pool workers: their runs die
  with them, ``isolate.die_with_parent``), again until the jobs have ended (``STOP_S`` at most),
  and is raised here. No job's result is reported after it: a job still running is dropped,
  whatever the kill made of it (the atlas's case runs again when it resumes). The threads are
  daemons: they end with the process.
"""

from __future__ import annotations

import multiprocessing
import queue
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

WAIT_S = 0.5  # [s] the longest the calling thread waits on the jobs at once (a signal is handled between waits)
STOP_S = 10.0  # [s] the longest a stop waits for the jobs to see their workers killed (then they end with the process)


def side_by_side(items: Iterable[Any], at_once: int, work: Callable[[Any], Any],
                 started: Callable[[Any], None] | None = None,
                 finished: Callable[[Any, Any], None] | None = None) -> None:
    """``work(item)`` for each of ``items``, ``at_once`` at a time in threads (module docstring); ``started(item)`` as
    each begins and ``finished(item, result)`` as each ends, here. ``at_once`` 1: one after another, in this
    thread."""
    if isinstance(at_once, bool) or not isinstance(at_once, int) or at_once < 1:
        raise ValueError(f"at_once = {at_once!r}: must be an integer >= 1")
    todo = list(items)
    if at_once == 1:
        for item in todo:
            if started is not None:
                started(item)
            result = work(item)
            if finished is not None:
                finished(item, result)
        return
    ended: queue.Queue = queue.Queue()

    def job(item: Any) -> None:
        try:
            ended.put((item, work(item), None))
        except BaseException as exc:  # noqa: BLE001  (handed to the calling thread, which raises it)
            ended.put((item, None, exc))

    running, threads = 0, []
    try:
        while todo or running:
            while todo and running < at_once:
                item = todo.pop(0)
                if started is not None:
                    started(item)
                threads.append(threading.Thread(target=job, args=(item,), daemon=True, name=f"side-by-side {item}"))
                threads[-1].start()
                running += 1
            while True:
                try:
                    item, result, exc = ended.get(timeout=WAIT_S)
                    break
                except queue.Empty:
                    continue
            running -= 1
            if exc is not None:
                raise exc
            if finished is not None:
                finished(item, result)
    except BaseException:
        stop_children(threads)
        raise


def stop_children(threads: list[threading.Thread], most_s: float = STOP_S) -> None:
    """Kill every live process this one started through ``multiprocessing`` (the pools' workers), again and again
    until ``threads`` have ended or ``most_s`` [s] have passed: a job's pool may start fresh workers for its next
    tasks before its search sees the kill (``pools.RenewedPool``)."""
    end = time.monotonic() + most_s
    while True:
        for child in multiprocessing.active_children():
            child.kill()
        if not any(t.is_alive() for t in threads) or time.monotonic() > end:
            return
        time.sleep(0.05)
