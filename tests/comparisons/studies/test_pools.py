"""The renewed pool of tune and atlas: every ``renew`` tasks a fresh pool, so what an engine leaves in a worker (Drake:
about 90 kB a diagram) does not pile up; the same results; killed at once, the pools it left behind included."""

from __future__ import annotations

import ctypes
import os
import time
from concurrent.futures import wait

import pytest

from chatterbench.comparisons.studies.pools import RenewedPool, _processes, process_pool, stop_pool
from helpers import needs_engine


def _square(x: int) -> tuple[int, int]:
    return os.getpid(), x * x


class _Mallinfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                     "fsmblks", "uordblks", "fordblks", "keepcost")]


def _held_after_diagrams(n: int) -> tuple[int, float]:
    """This worker's pid and the memory its allocator holds in use [MB] (glibc's ``mallinfo2``: what is allocated,
    whatever the resident set a fork inherited) after building ``n`` bare Drake diagrams (a plant and a scene graph:
    what every Drake run builds)."""
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    for _ in range(n):
        builder = DiagramBuilder()
        plant, _ = AddMultibodyPlantSceneGraph(builder, 1e-3)
        plant.Finalize()
        builder.Build()
    libc = ctypes.CDLL(None)
    libc.mallinfo2.restype = _Mallinfo2
    info = libc.mallinfo2()
    return os.getpid(), (info.uordblks + info.hblkhd) / 2**20


def test_every_renew_tasks_go_to_fresh_workers_with_the_same_results():
    with process_pool(2, renew=3) as pool:
        done = [pool.submit(_square, x).result() for x in range(8)]
    assert [r for _, r in done] == [x * x for x in range(8)]
    groups = [{pid for pid, _ in done[i:i + 3]} for i in (0, 3, 6)]
    assert not groups[0] & groups[1] and not groups[1] & groups[2] and not groups[0] & groups[2]
    with process_pool(2) as pool:  # without renew: one pool, its two workers at most
        assert len({pool.submit(_square, x).result()[0] for x in range(8)}) <= 2


def _squares(xs: list[int]) -> list[tuple[int, int]]:
    return [_square(x) for x in xs]


_squares.tasks = lambda xs: len(xs)  # several tasks' work at once (as tune's part of a pass): counted as them


def test_a_task_of_several_counts_them_toward_the_renewal():
    # tune's parts of a pass (``rows.evaluate_part``) hold up to 8 candidates: counted as one task each, a worker ran
    # 8 times the candidates before its renewal (seen: 850 MB workers in a MuJoCo Warp atlas case, 650 MB before)
    with process_pool(2, renew=4) as pool:
        done = [pool.submit(_squares, [2 * k, 2 * k + 1]).result() for k in range(4)]  # 2 + 2 renew, 2 + 2 renew
    assert [r for part in done for _, r in part] == [x * x for x in range(8)]
    pids = [{pid for pid, _ in part} for part in done]
    assert not (pids[0] | pids[1]) & (pids[2] | pids[3])


def test_a_renewed_worker_has_given_back_what_drake_kept():
    needs_engine("drake")
    if not hasattr(ctypes.CDLL(None), "mallinfo2"):
        pytest.skip("no glibc mallinfo2 (glibc 2.33 or later) to count the memory a worker holds")
    with process_pool(1, renew=2) as pool:
        (pid1, first), (pid2, second), (pid3, third) = (pool.submit(_held_after_diagrams, 150).result() for _ in range(3))
    assert pid1 == pid2 != pid3
    assert second - first > 5.0  # 150 more diagrams kept by the same worker: ~13 MB
    assert third < second - 5.0  # a fresh worker: back where the first one began


def test_a_stopped_renewed_pool_kills_the_workers_of_every_pool_it_left():
    pool = RenewedPool(1, renew=1)
    futures = [pool.submit(time.sleep, 60) for _ in range(3)]  # three pools, one sleeping worker each
    deadline = time.monotonic() + 30
    while len(_processes(pool)) < 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = _processes(pool)
    assert len(workers) == 3
    stop_pool(pool, interrupted=True)
    for worker in workers:
        worker.join(timeout=10)
        assert worker.exitcode is not None  # killed, not left sleeping
    assert not wait(futures, timeout=30).not_done  # each pool saw its worker die: broken, none waited on for ever


def test_a_renew_below_one_is_refused_naming_it():
    with pytest.raises(ValueError, match="renew = 0: must be an integer >= 1"):
        RenewedPool(1, renew=0)
