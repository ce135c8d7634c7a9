"""The main thread's waits for workers, in slices, so that a Ctrl-C is acted on whichever thread received it.

A Ctrl-C (SIGINT) goes to any thread of the process that does not block it: the main thread
mostly, but a progress thread, tqdm's monitor or a BLAS thread when the main thread blocks it
for a moment (``sweep.runner._local_pool`` does while its workers fork). Python 3.11 runs the
handler in the main thread only, and notices a signal another thread received only when the main
thread takes the GIL again: a wait for a worker's result that never returns held an
interrupted sweep until its next run finished (8.9 s under load, seen). Waited for in slices of
``POLL_S``, the interrupt is acted on within one slice.

    >>> from concurrent.futures import ThreadPoolExecutor
    >>> from chatterbench.comparisons.studies.waits import result
    >>> with ThreadPoolExecutor(1) as pool:
    ...     result(pool.submit(sum, [1, 2]))
    3
"""

from __future__ import annotations

from typing import Any

from chatterbench.engines.isolate import POLL_S  # [s] the longest the main thread blocks in one wait for a worker


def result(future: Any) -> Any:
    """``future.result()`` (a ``concurrent.futures.Future``, or any future whose ``result`` takes a timeout), waited
    for ``POLL_S`` at a time; what the task raised, raised."""
    while True:
        try:
            return future.result(timeout=POLL_S)
        except TimeoutError:
            if future.done():  # the task's own TimeoutError, or its result that came just after the slice ended
                return future.result()
