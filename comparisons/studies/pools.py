"""The process pools of ``tune``, ``atlas`` and ``sweep``: shut down after their last run, or at once when the command is
interrupted.

    >>> from chatterbench.comparisons.studies.pools import process_pool
    >>> with process_pool(1) as pool:
    ...     pool.submit(sum, [1, 2]).result()
    3

A ``ProcessPoolExecutor`` left by ``with`` (or ``shutdown()``) runs every task already handed to it before it returns:
a search pass of a tune hands out all of its candidates at once, so a ``tune`` or an ``atlas`` that a CI job's
SIGTERM or a Ctrl-C interrupted ran on until the pass was done (a Drake case: minutes; ``tests/comparisons/cli/
test_search_stops.py``). Interrupted, the pool's workers are killed and what was queued is cancelled; nothing they
were running is wanted any more (a killed atlas resumes from its finished cases).

A pool that ``renew``s itself (``RenewedPool``) hands every ``renew`` tasks to a fresh pool of fresh workers, so
what an engine leaves in a worker does not pile up over a search: Drake keeps about 90 kB of every diagram it
builds (a bare ``AddMultibodyPlantSceneGraph`` + ``Build``, pydrake 1.51.1), and a tune builds one a run and one
a strike, 20 to 120 strikes a candidate: a worker of an atlas's Drake spring pair held 1.1 GB after 26 minutes.
A task's result does not depend on the worker it ran in, so the rows are the same. It renews sooner when a worker
has grown past ``MOST_WORKER_MB`` resident, or past half of it over what the forking process holds (read from
``/proc``; not on a system without it): tune's parts of a pass
(``rows.evaluate_part``: up to 8 candidates a task) let a worker live through 8 times the candidates, and an
atlas's MuJoCo Warp bouncing-ball case then peaked at 850 MB a worker (648 MB with a task a candidate); counted as
their candidates instead, the parts renewed MuJoCo Warp's workers 8 times as often, each fresh worker loading its
kernels and capturing its rigs again (the case 124.8 s -> 169.5 s).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any

RENEW_TASKS = 100  # tasks a tune's or an atlas's pool runs before a fresh one takes the next (50 a worker of two)
MOST_WORKER_MB = 640.0  # [MiB] resident: a worker past this has its pool renewed at the next task handed out, or
# past half of it over what the process that forks the workers holds (a fork starts with up to its parent's pages)


class RenewedPool(Executor):
    """A ``ProcessPoolExecutor`` of ``max_workers`` that hands every ``renew`` tasks to a fresh one (module
    docstring); the one it leaves runs what it was handed, then its workers exit."""

    def __init__(self, max_workers: int | None, renew: int) -> None:
        if renew < 1:
            raise ValueError(f"renew = {renew!r}: must be an integer >= 1")
        self.max_workers, self.renew = max_workers, renew
        self.left: list = []  # the workers of the pools left behind (a pool shut down forgets its own)
        self._fresh()

    def _fresh(self) -> None:
        """A fresh pool, and the resident size [MiB] past which its workers are renewed (``MOST_WORKER_MB``)."""
        self.pool, self.handed = ProcessPoolExecutor(max_workers=self.max_workers), 0
        self.limit_mb = max(MOST_WORKER_MB, resident_mb(os.getpid()) + MOST_WORKER_MB / 2)

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        if self.handed >= self.renew or any(resident_mb(w.pid) > self.limit_mb for w in _processes(self.pool)):
            self.left = [w for w in self.left if w.is_alive()] + _processes(self.pool)
            self.pool.shutdown(wait=False)  # its workers end once its tasks are done
            self._fresh()
        self.handed += 1
        return self.pool.submit(fn, *args, **kwargs)

    def workers(self) -> list:
        """Every worker process that may still run: those of the pools left behind, then the current pool's."""
        return [*(w for w in self.left if w.is_alive()), *_processes(self.pool)]

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self.pool.shutdown(wait=wait, cancel_futures=cancel_futures)
        if wait:
            for worker in self.left:
                worker.join()


def resident_mb(pid: int | None, proc: str = "/proc") -> float:
    """Process ``pid``'s resident memory [MiB] (``VmRSS`` of ``proc``/pid/status); 0 where it cannot be read (an
    exited process, a system without ``/proc``)."""
    try:
        with open(f"{proc}/{int(pid)}/status", encoding="ascii", errors="replace") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0  # kB
    except (OSError, TypeError, ValueError, IndexError):
        return 0.0
    return 0.0


def _processes(pool: Executor) -> list:
    """The worker processes of a pool (every one a ``RenewedPool`` has that may still run)."""
    if isinstance(pool, RenewedPool):
        return pool.workers()
    return list((getattr(pool, "_processes", None) or {}).values())


def stop_pool(pool: Executor, interrupted: bool) -> None:
    """Shut ``pool`` down: after its last task, or at once, its workers killed, when the work was interrupted (any
    exception: nothing they compute is read any more)."""
    if interrupted:
        for process in _processes(pool):
            process.kill()  # the runs they isolate die with them (``isolate.die_with_parent``)
    pool.shutdown(wait=not interrupted, cancel_futures=True)


@contextmanager
def process_pool(max_workers: int | None, renew: int | None = None) -> Iterator[Executor]:
    """A ``ProcessPoolExecutor`` of ``max_workers`` (None: one per core) for a ``with`` block, stopped by ``stop_pool``:
    waited for when the block ends, killed when an exception (a Ctrl-C, a SIGTERM, an error) leaves it. ``renew``:
    a ``RenewedPool``, fresh workers every ``renew`` tasks."""
    pool = ProcessPoolExecutor(max_workers=max_workers) if renew is None else RenewedPool(max_workers, renew)
    ended = False
    try:
        yield pool
        ended = True
    finally:
        stop_pool(pool, interrupted=not ended)
