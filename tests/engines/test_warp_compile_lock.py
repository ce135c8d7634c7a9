"""Warp kernels (Newton's, MuJoCo Warp's) compile once across processes: ``warp_cache.compile_lock`` holds an exclusive
lock on a file in warp's kernel cache while a process loads them, so a second process (a test worker, a sweep worker)
waits and then reads what the first compiled. (By hand, two processes loading Newton's semi-implicit kernels on one
empty cache, the warm command before it was folded into ``engines/warm.py``: one "compiled its kernels ... in
11.9 s", the other "loaded its kernels from warp's cache ... in 12.3 s".)"""

from __future__ import annotations

import fcntl
import subprocess
import sys

import pytest

from chatterbench.engines.warp_cache import compile_lock, lock_name

HOLD = """
import sys, pathlib
from chatterbench.engines.warp_cache import compile_lock
folder = pathlib.Path(sys.argv[1])
with compile_lock(str(folder), "newton"):
    print("held", flush=True)
    sys.stdin.readline()  # held until the test writes a line
"""


def _free(folder, family: str = "newton") -> bool:
    """Whether the family's lock file can be taken now, without waiting."""
    with open(folder / lock_name(family), "a+") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        fcntl.flock(handle, fcntl.LOCK_UN)
        return True


def test_a_second_process_cannot_load_while_the_first_holds_the_cache(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"  # the event: it holds the lock now (or it died: "")
        assert not _free(tmp_path)
    finally:
        holder.stdin.write("go\n")
        holder.stdin.close()
        holder.wait(timeout=120)
    assert holder.returncode == 0 and _free(tmp_path)  # the other way: released when the loading is done


def test_a_cache_it_cannot_write_lets_each_process_load_on_its_own(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")  # a file where the cache folder should be: no lock file can be made under it
    with compile_lock(str(blocker / "cache"), "newton"):
        pass  # no error, no lock: warp compiles or loads as it would without us


def test_the_lock_is_taken_in_process_too(tmp_path):
    with compile_lock(str(tmp_path), "newton"):
        assert not _free(tmp_path)  # another open of the file (a thread, a fork) waits too
    assert _free(tmp_path)


def test_the_two_families_compile_side_by_side(tmp_path):
    with compile_lock(str(tmp_path), "newton"):
        assert _free(tmp_path, "mujoco_warp")  # MuJoCo Warp's modules are its own: no wait for Newton's


def test_warm_makes_each_named_engines_first_run_and_refuses_an_unknown_name():
    pytest.importorskip("newton", reason="the newton extra is not installed: pip install \".[newton]\"")
    done = subprocess.run([sys.executable, "-m", "chatterbench.engines.warm", "newton_semi"], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0 and done.stdout.startswith("newton_semi: kernels "), done.stderr
    bad = subprocess.run([sys.executable, "-m", "chatterbench.engines.warm", "no_such_engine"], capture_output=True,
                         text=True, timeout=600)
    assert bad.returncode == 2 and bad.stderr.startswith("engine 'no_such_engine': one of ")
