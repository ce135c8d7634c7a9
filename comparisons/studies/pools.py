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
"""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager


def stop_pool(pool: ProcessPoolExecutor, interrupted: bool) -> None:
    """Shut ``pool`` down: after its last task, or at once, its workers killed, when the work was interrupted (any
    exception: nothing they compute is read any more)."""
    if interrupted:
        for process in list((getattr(pool, "_processes", None) or {}).values()):
            process.kill()  # the runs they isolate die with them (``isolate.die_with_parent``)
    pool.shutdown(wait=not interrupted, cancel_futures=True)


@contextmanager
def process_pool(max_workers: int | None) -> Iterator[ProcessPoolExecutor]:
    """A ``ProcessPoolExecutor`` of ``max_workers`` (None: one per core) for a ``with`` block, stopped by ``stop_pool``:
    waited for when the block ends, killed when an exception (a Ctrl-C, a SIGTERM, an error) leaves it."""
    pool = ProcessPoolExecutor(max_workers=max_workers)
    ended = False
    try:
        yield pool
        ended = True
    finally:
        stop_pool(pool, interrupted=not ended)
