"""``side_by_side``: jobs in threads, ``at_once`` at a time, reported in the calling thread; stopped at once, their
processes killed, when the caller is interrupted. Known answers both ways: jobs do overlap at 2 and never at 1."""

from __future__ import annotations

import multiprocessing
import threading
import time

import pytest

from chatterbench.comparisons.studies.side_by_side import side_by_side


def _overlap(at_once: int) -> int:
    """The most jobs that ran at the same moment, of four jobs of 0.2 s."""
    now, most, lock = [0], [0], threading.Lock()

    def work(item):
        with lock:
            now[0] += 1
            most[0] = max(most[0], now[0])
        time.sleep(0.2)
        with lock:
            now[0] -= 1
        return item

    side_by_side(range(4), at_once, work)
    return most[0]


def test_jobs_overlap_up_to_at_once_and_never_at_one():
    assert _overlap(1) == 1
    assert _overlap(2) == 2
    assert _overlap(8) == 4  # no more than there are jobs


def test_every_job_is_reported_once_in_the_calling_thread_in_the_order_they_end():
    calls = []
    here = threading.get_ident()

    def work(seconds):
        time.sleep(seconds)
        return seconds * 10

    side_by_side([0.4, 0.05, 0.1], 2, work, started=lambda x: calls.append(("start", x, threading.get_ident())),
                 finished=lambda x, y: calls.append(("end", y, threading.get_ident())))
    assert {c[2] for c in calls} == {here}
    # the first two start; the short one ends and the third starts in its place; it ends before the long first
    assert [c[:2] for c in calls] == [("start", 0.4), ("start", 0.05), ("end", 0.5), ("start", 0.1), ("end", 1.0),
                                      ("end", 4.0)]


@pytest.mark.parametrize("at_once", [0, -1, 1.5, True, "2"])
def test_at_once_must_be_a_whole_number_of_at_least_one(at_once):
    with pytest.raises(ValueError, match="at_once"):
        side_by_side([1], at_once, lambda x: x)


def test_a_job_that_raises_raises_here():
    def work(item):
        if item == 2:
            raise RuntimeError("job 2 broke")
        return item

    with pytest.raises(RuntimeError, match="job 2 broke"):
        side_by_side([1, 2, 3], 2, work)


def _sleep(seconds: float) -> None:
    time.sleep(seconds)


def test_an_interrupt_kills_the_jobs_processes_and_reports_no_more():
    """An interrupt in the calling thread (here raised from ``finished``, as a Ctrl-C would be in the wait) kills the
    processes the other jobs started, and nothing more is reported."""
    children, ended = [], []

    def work(item):
        if item == "quick":
            return item
        child = multiprocessing.get_context("fork").Process(target=_sleep, args=(60,))
        child.start()
        children.append(child)
        child.join()  # returns once the child is killed
        return child.exitcode

    def finished(item, result):
        ended.append(item)
        if item == "quick":
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        side_by_side(["slow", "quick", "later"], 2, work, finished=finished)
    assert ended == ["quick"]  # the slow job's result (its killed child) is not reported; "later" never started
    for child in children:
        child.join(5)
        assert not child.is_alive() and child.exitcode == -9  # killed, not its 60 s slept out
