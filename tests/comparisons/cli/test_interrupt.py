"""Ctrl-C ends a command with exit 130 even when Python swallows the ``KeyboardInterrupt``.

Before: a Ctrl-C of ``report --out r`` landing while matplotlib collected garbage was raised
inside a weakref callback, printed as "Exception ignored in ... KeyboardInterrupt", and the
report ran to the end with exit 0 (issue 25, "Ctrl-C ... was ignored"; timing-dependent). Here
the SIGINT is delivered, deterministically, inside such a callback.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

# a child process running `chatterbench scenes` as the console script, its listing replaced by ``listing`` (the part
# between: it calls ``real``, the listing itself)
SCENES_HEAD = r'''
import os, signal, sys, time, weakref
sys.argv[0] = "chatterbench"          # as the console script
from chatterbench.comparisons import cli
from chatterbench.comparisons.cli import main as cli_main, scenes

real = scenes.cmd_scenes
'''
SCENES_TAIL = r'''
scenes.cmd_scenes = listing
sys.exit(cli_main.main(["scenes"]))
'''

SWALLOWED = SCENES_HEAD + r'''
class Thing:
    pass

def listing(args):
    thing = Thing()
    weakref.finalize(thing, os.kill, os.getpid(), signal.SIGINT)  # the signal arrives in a GC callback
    del thing
    return real(args)
''' + SCENES_TAIL


def test_a_ctrl_c_swallowed_by_a_callback_still_exits_130():
    proc = subprocess.run([sys.executable, "-c", SWALLOWED], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130, (proc.returncode, proc.stderr)
    assert proc.stderr.strip().splitlines() == ["chatterbench: interrupted"], proc.stderr


# a Ctrl-C test of a command in a child process (the one above: 0.6 s, where a sweep's takes 2.5 s): with SIGINT
# ignored in the suite and nothing restoring it, its command inherits that and never sees the SIGINT (tried with
# tests/conftest.py's restoring turned off: this test fails, as test_sweep_outside_out.py's Ctrl-C of a sweep does)
INTERRUPTED_TEST = "tests/comparisons/cli/test_interrupt.py::test_a_ctrl_c_swallowed_by_a_callback_still_exits_130"
IGNORING = r'''
import signal, subprocess, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)  # as `pytest &` in a non-interactive shell starts the suite
sys.exit(subprocess.call([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", sys.argv[1]]))
'''


def test_the_ctrl_c_tests_hold_in_a_suite_started_with_sigint_ignored():
    # before: a suite started in the background (SIGINT ignored, inherited by every command a test starts) failed every
    # Ctrl-C test: the sweep never saw the interrupt and finished (tests/conftest.py restores Python's handler)
    root = __import__("pathlib").Path(__file__).resolve().parents[3]
    proc = subprocess.run([sys.executable, "-c", IGNORING, INTERRUPTED_TEST], cwd=root, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert "1 passed" in proc.stdout


# A Ctrl-C while an extension module's init imports another module: numba._dispatcher's init imports
# numba._devicearray, and a KeyboardInterrupt raised in there comes out of numba as "ImportError: numba._devicearray
# failed to import" (seen once in 60 Ctrl-Cs of a sweep under load). Here the SIGINT is sent, deterministically,
# as that import starts, in a command whose work loads numba (the reference's solve).
IN_AN_IMPORT = r'''
import os, signal, sys
sys.argv[0] = "chatterbench"          # as the console script
from chatterbench.comparisons.cli import main as cli_main

class Kick:
    def find_spec(self, name, path, target=None):
        if name == sys.argv[1]:
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, Kick())
assert "numba" not in sys.modules
sys.exit(cli_main.main(["compare", "bouncing-ball", "--engines", "mujoco", "--out", sys.argv[2]]))
'''


def test_a_ctrl_c_inside_an_extensions_import_is_one_line_exit_130(tmp_path):
    for module in ("numba._devicearray", "numba.core.config"):  # inside numba's C init, and a plain module's import
        proc = subprocess.run([sys.executable, "-c", IN_AN_IMPORT, module, str(tmp_path / module)], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 130, (module, proc.returncode, proc.stderr[-3000:])
        assert proc.stderr.strip().splitlines() == ["chatterbench: interrupted"], (module, proc.stderr[-3000:])
        assert not (tmp_path / module / "episodes.csv").exists()  # interrupted long before the comparison's files


# A Ctrl-C received by another thread than the main one (the kernel hands SIGINT to any thread not blocking it: a
# progress thread, tqdm's monitor, a BLAS thread while the main thread blocks it): Python 3.11 notices it only when
# the main thread runs again, and a sweep whose main thread waited for its workers without a timeout went on until
# its next run finished (8.9 s under load, seen). Here the SIGINT is sent to a thread of the command's own, once its
# main thread waits for its workers (in _drain); every run lasts far longer than that.
ELSEWHERE = r'''
import signal, sys, threading, time
sys.argv[0] = "chatterbench"          # as the console script
from chatterbench.comparisons.cli import main as cli_main

def kick():
    main = threading.main_thread().ident
    while True:  # until the main thread waits for the workers
        frame, names = sys._current_frames().get(main), set()
        while frame is not None:
            names.add(frame.f_code.co_name)
            frame = frame.f_back
        if sys.argv[1] in names:
            break
        time.sleep(0.05)
    time.sleep(0.5)
    signal.pthread_kill(threading.get_ident(), signal.SIGINT)  # to this thread, not the main one

threading.Thread(target=kick, daemon=True).start()
sys.exit(cli_main.main(sys.argv[2:]))
'''


def test_a_ctrl_c_another_thread_receives_stops_a_sweep_before_any_run_ends(tmp_path):
    # runs of the bouncing ball of 10 million steps (a minute or more each): none ends before the Ctrl-C
    (tmp_path / "long.toml").write_text('scene = "bouncing-ball"\nengines = ["pybullet"]\n[set]\nduration = 100\n'
                                        "[grid]\ndt = [1e-5, 2e-5]\n")
    proc = subprocess.run([sys.executable, "-c", ELSEWHERE, "_drain", "sweep", "long.toml", "--out", "swept", "--workers",
                           "2"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 130, (proc.returncode, proc.stderr[-3000:])
    assert proc.stderr.strip().splitlines()[-1] == "chatterbench: interrupted", proc.stderr[-3000:]
    assert not list((tmp_path / "swept" / "rows").glob("*.parquet"))  # stopped before any run finished: no row


def _waiting_in(frame, name: str, filename: str) -> bool:
    """Whether a thread's stack (its innermost ``frame``) runs the function ``name`` of the file ``filename``."""
    while frame is not None:
        if frame.f_code.co_name == name and frame.f_code.co_filename == filename:
            return True
        frame = frame.f_back
    return False


def test_a_wait_for_a_worker_hears_a_ctrl_c_another_thread_received():
    # tune's wait for a candidate's row (studies/tune.py, _row) is waits.result: the interrupt comes before the result
    import signal
    import threading
    import time
    from concurrent.futures import Future

    from chatterbench.comparisons.studies import waits

    never = Future()  # a worker's result that does not come ...
    guard = threading.Timer(60.0, never.set_result, ("came after 60 s",))  # ... until this guard gives up on the test

    def kick():  # once the main thread waits in waits.result, however late a loaded machine gets it there
        main = threading.main_thread().ident
        while not _waiting_in(sys._current_frames().get(main), "result", waits.__file__):
            time.sleep(0.01)
        time.sleep(0.3)  # a slice or more into the wait
        signal.pthread_kill(threading.get_ident(), signal.SIGINT)  # to this thread, not the main one

    guard.start()
    threading.Thread(target=kick, daemon=True).start()
    try:
        with pytest.raises(KeyboardInterrupt):
            waits.result(never)
    finally:
        guard.cancel()
    assert not never.done()


# A Ctrl-C whose KeyboardInterrupt is raised inside a fork hook while the sweep's pool forks its workers (logging's
# _releaseLock runs after each fork): Python reports it as unraisable and goes on, and the sweep ran until its runs
# finished (seen under load, 9 s). Here the SIGINT arrives, deterministically, inside such a hook at the first fork.
IN_A_FORK_HOOK = r'''
import os, signal, sys
sys.argv[0] = "chatterbench"          # as the console script
from chatterbench.comparisons.cli import main as cli_main

parent, done = os.getpid(), []

def hook():
    if os.getpid() == parent and not done:
        done.append(1)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # the pool's start holds it back; let it in here
        os.kill(parent, signal.SIGINT)
        sum(range(1000))  # Python code in the hook: the handler runs, its KeyboardInterrupt is swallowed

os.register_at_fork(after_in_parent=hook)
sys.exit(cli_main.main(sys.argv[1:]))
'''


def test_a_ctrl_c_swallowed_in_a_fork_hook_stops_a_sweep_before_any_run_ends(tmp_path):
    (tmp_path / "long.toml").write_text('scene = "bouncing-ball"\nengines = ["pybullet"]\n[set]\nduration = 30\n'
                                        "[grid]\ndt = [1e-5, 2e-5]\n")  # 3 and 1.5 million steps: 10 s or more each
    proc = subprocess.run([sys.executable, "-c", IN_A_FORK_HOOK, "sweep", "long.toml", "--out", "swept", "--workers",
                           "2"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 130, (proc.returncode, proc.stderr[-3000:])
    assert proc.stderr.strip().splitlines() == ["chatterbench: interrupted"], proc.stderr[-3000:]
    assert not list((tmp_path / "swept" / "rows").glob("*.parquet"))  # stopped before any run finished: no row


def test_a_result_that_comes_just_after_a_slice_is_returned_not_a_timeout():
    # found in review: a task finishing between a slice's timeout and the check of done() gave a TimeoutError, which
    # ended a tune whose candidate had succeeded
    from concurrent.futures import Future

    from chatterbench.comparisons.studies import waits

    class JustAfter(Future):  # the task's result comes right after the first slice has timed out
        def result(self, timeout=None):
            try:
                return super().result(timeout)
            except TimeoutError:
                if not self.done():
                    self.set_result("the row")
                raise

    assert waits.result(JustAfter()) == "the row"
    failed = Future()
    failed.set_exception(TimeoutError("the task's own"))
    with pytest.raises(TimeoutError, match="the task's own"):
        waits.result(failed)


# Found in review: each Ctrl-C held for an import started its own chain of re-sent signals, and after the import each
# raised its KeyboardInterrupt 10 ms after the one before, inside the cleanup the first one began (a staged folder's
# removal, the pool's stop). Here three Ctrl-Cs arrive during one import; the cleanup after the first must finish.
SEVERAL = r'''
import os, signal, sys, time
sys.argv[0] = "chatterbench"          # as the console script
from chatterbench.comparisons import cli
cli.quiet_interrupts(False)           # as during a command's work

class Slow:
    def find_spec(self, name, path, target=None):
        if name == "a_module_that_takes_a_while":
            for _ in range(3):
                os.kill(os.getpid(), signal.SIGINT)
                start = time.monotonic()
                while time.monotonic() - start < 0.113:  # not a multiple of the 20 ms re-send: chains apart
                    pass
        return None

sys.meta_path.insert(0, Slow())
try:
    try:
        import a_module_that_takes_a_while
    except ModuleNotFoundError:
        pass
    start = time.monotonic()
    while time.monotonic() - start < 5:
        pass
    print("not interrupted")
except KeyboardInterrupt:
    try:
        start = time.monotonic()
        while time.monotonic() - start < 0.5:  # the cleanup
            pass
        print("interrupted once")
    except KeyboardInterrupt:
        print("interrupted again, in the cleanup")
'''


def test_several_ctrl_cs_during_an_import_are_one_interrupt():
    proc = subprocess.run([sys.executable, "-c", SEVERAL], capture_output=True, text=True, timeout=120)
    assert proc.stdout.strip() == "interrupted once", (proc.stdout, proc.stderr[-2000:])


# Found in review: an isolated engine run (engines/isolate.py) waited for its child in one poll of the whole run limit,
# so a Ctrl-C that another thread received waited for the run's end. Here the run lasts 20 s; the interrupt stops it.
ISOLATED = r'''
import os, signal, sys, threading, time
from chatterbench.engines.isolate import run_isolated

def run():  # an engine run of 20 s that leaves a mark when it ends
    time.sleep(20.0)
    open(sys.argv[1], "w").write("the run ended")

def kick():
    time.sleep(1.0)
    signal.pthread_kill(threading.get_ident(), signal.SIGINT)  # to this thread, not the main one

threading.Thread(target=kick, daemon=True).start()
try:
    run_isolated(run)
    print("not interrupted")
except KeyboardInterrupt:
    time.sleep(0.5)
    print("interrupted;", "the run had ended" if os.path.exists(sys.argv[1]) else "the run was stopped")
'''


def test_an_isolated_run_hears_a_ctrl_c_another_thread_received(tmp_path):
    proc = subprocess.run([sys.executable, "-c", ISOLATED, str(tmp_path / "ended")], capture_output=True, text=True,
                          timeout=120)
    assert proc.stdout.strip() == "interrupted; the run was stopped", (proc.stdout, proc.stderr[-2000:])


# the Ctrl-C swallowed at the very end of the work: its resend (``_again``, 20 ms) still armed when ``main`` raises for
# ``interrupt.seen`` and says "interrupted"; a slow stderr (a loaded machine, a pipe) holds that line past 20 ms
RESENT_LATE = SCENES_HEAD + r'''
class SlowErr:
    def __init__(self, stream):
        self.stream = stream
    def write(self, text):
        time.sleep(0.2)               # the resend fires while the line is written
        return self.stream.write(text)
    def __getattr__(self, name):
        return getattr(self.stream, name)

def listing(args):
    code = real(args)
    type(cli.interrupt).seen = True   # as a Ctrl-C swallowed in a garbage-collection callback at the end
    cli._again()
    sys.stderr = SlowErr(sys.stderr)
    return code
''' + SCENES_TAIL


def test_a_ctrl_c_resent_while_main_says_interrupted_still_exits_130():
    # found in a suite run under load: -2 and a KeyboardInterrupt traceback after "chatterbench: interrupted" (the
    # resent SIGINT raised again inside main's own handling of the first)
    proc = subprocess.run([sys.executable, "-c", RESENT_LATE], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130, (proc.returncode, proc.stderr)
    assert proc.stderr.strip().splitlines() == ["chatterbench: interrupted"], proc.stderr
