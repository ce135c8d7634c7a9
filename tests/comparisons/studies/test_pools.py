"""The renewed pool of tune and atlas: every ``renew`` tasks a fresh pool, so what an engine leaves in a worker (Drake:
about 90 kB a diagram) does not pile up; the same results; killed at once, the pools it left behind included."""

from __future__ import annotations

import ctypes
import os
import time
from concurrent.futures import wait

import pytest

from chatterbench.comparisons.studies.pools import (MOST_WORKER_MB, RenewedPool, _processes, process_pool, resident_mb,
                                                    stop_pool)
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


_KEPT: list[bytes] = []  # what a worker holds on to (as MuJoCo Warp's kept rigs and caches over a long search)


def _swell(mb: int) -> tuple[int, float]:
    """This worker's pid after it keeps ``mb`` MiB more, written so that it is resident."""
    _KEPT.append(b"\x01" * (mb * 2**20))
    return os.getpid(), resident_mb(os.getpid())


def test_a_worker_grown_past_the_limit_is_renewed_at_the_next_task():
    # tune's parts of a pass (up to 8 candidates a task) let a worker live through 8 times the candidates before the
    # count renewed it (seen: 850 MB workers in a MuJoCo Warp atlas case); the pool now also renews a grown worker
    with process_pool(1, renew=1000) as pool:
        first, held = pool.submit(_swell, 0).result()
        pool.limit_mb = held + 100.0  # [MiB] this worker's own size, whatever the (forked) test process holds
        assert pool.submit(_swell, 200).result() == (first, pytest.approx(held + 200.0, abs=60.0))
        after = pool.submit(_square, 3).result()[0]
    assert after != first
    with process_pool(1, renew=1000) as pool:  # the other way: a worker under the limit is kept
        first, held = pool.submit(_swell, 0).result()
        pool.limit_mb = held + 100.0
        kept = {pool.submit(_swell, 1).result()[0] for _ in range(3)} | {pool.submit(_square, 2).result()[0]}
    assert kept == {first}


def test_the_limit_is_the_larger_of_the_fixed_one_and_half_of_it_over_the_forking_process(monkeypatch):
    # a fork starts with up to its parent's pages: a pytest worker of 1.2 GB forked pool workers of about 1 GB, and a
    # fixed 640 MiB renewed them at every task (seen in CI: Drake's renewal test found a fresh worker each task)
    from chatterbench.comparisons.studies import pools

    for parent, limit in ((1200.0, 1200.0 + MOST_WORKER_MB / 2), (100.0, MOST_WORKER_MB)):
        monkeypatch.setattr(pools, "resident_mb", lambda pid, parent=parent: parent if pid == os.getpid() else 0.0)
        with process_pool(1, renew=1000) as pool:
            assert pool.limit_mb == limit


def test_resident_memory_is_read_from_the_process_status(tmp_path):
    (tmp_path / "42").mkdir()
    (tmp_path / "42" / "status").write_text("Name:\tpython\nVmHWM:\t  9999 kB\nVmRSS:\t  2048 kB\n")
    assert resident_mb(42, proc=str(tmp_path)) == 2.0
    assert resident_mb(43, proc=str(tmp_path)) == 0.0  # gone (an exited worker): nothing to renew for
    assert resident_mb(None, proc=str(tmp_path)) == 0.0
    if os.path.exists(f"/proc/{os.getpid()}/status"):
        assert resident_mb(os.getpid()) > 1.0


def test_a_renewed_worker_has_given_back_what_drake_kept():
    needs_engine("drake")
    if not hasattr(ctypes.CDLL(None), "mallinfo2"):
        pytest.skip("no glibc mallinfo2 (glibc 2.33 or later) to count the memory a worker holds")
    with process_pool(1, renew=2) as pool:
        (pid1, first), (pid2, second), (pid3, third) = (pool.submit(_held_after_diagrams, 150).result() for _ in range(3))
    assert pid1 == pid2 != pid3
    assert second - first > 5.0  # 150 more diagrams kept by the same worker: ~13 MB
    assert third < second - 5.0  # a fresh worker: back where the first one began


def _ended(pid: int, within: float = 10.0) -> bool:
    """Whether process ``pid`` ends within ``within`` [s]: gone, or a zombie. A left pool's own thread may reap its
    killed worker first, and then ``Process.exitcode`` stays None (its ``waitpid`` finds no child: seen 1 in 12)."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
            with open(f"/proc/{pid}/status") as status:
                if any(line.startswith("State:") and "Z" in line.split()[1] for line in status):
                    return True
        except (ProcessLookupError, FileNotFoundError):
            return True
        time.sleep(0.05)
    return False


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
        assert worker.exitcode is not None or _ended(worker.pid)  # killed, not left sleeping
    assert not wait(futures, timeout=30).not_done  # each pool saw its worker die: broken, none waited on for ever


def test_a_renew_below_one_is_refused_naming_it():
    with pytest.raises(ValueError, match="renew = 0: must be an integer >= 1"):
        RenewedPool(1, renew=0)
