"""Progress on stderr for the commands that run long: one tqdm bar, one step per unit of work, what runs now.

    >>> from chatterbench.comparisons.cli.progress import Progress
    >>> with Progress(3, "compare bouncing-ball", unit="run", enabled=False) as bar:
    ...     for what in ("reference", "mujoco", "pybullet"):
    ...         bar.stage(what)                     # the step before is done; this one runs now
    >>> bar.n
    3

Promises: the bar goes to stderr (stdout keeps the tables, for pipes and files) and is drawn
only on a terminal (tqdm's ``disable=None``), so logs and captured output stay clean; it is
redrawn every ``REFRESH_S`` seconds, so a step that holds the process for minutes (an engine
run in a child process, MuJoCo Warp compiling its kernels) still shows its time passing.
``note`` lines (what a step will cost, e.g. a kernel compile) are printed on every stream,
terminal or not: a log says why it paused.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from concurrent.futures import Executor, Future
from typing import Any, Callable

from chatterbench.engines.registry import ENGINE_NAMES, adapter, unavailable_reason

REFRESH_S = 1.0  # [s] how often the bar is redrawn while one step runs

_LOADED = time.perf_counter()  # the fallback's origin where /proc is missing


def waited_s() -> float:
    """Seconds since this process started [s]: what the user waited for, imports and file writes included (the
    time a command prints, e.g. ``gate``'s "N checks in S s"). The kernel's start time of the process (Linux
    ``/proc/self/stat`` field 22, in clock ticks since boot, against ``/proc/uptime``); elsewhere, since this
    module was loaded."""
    try:
        with open("/proc/self/stat", encoding="ascii") as stat, open("/proc/uptime", encoding="ascii") as up:
            ticks = float(stat.read().rsplit(")", 1)[1].split()[19])  # after "pid (comm)", field 22 is index 19
            return float(up.read().split()[0]) - ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return time.perf_counter() - _LOADED


class Progress:
    """A tqdm bar on stderr (module docstring); ``total`` None: a counter with elapsed time."""

    def __init__(self, total: int | None, desc: str, unit: str = "step", enabled: bool | None = None, file=None,
                 eta: bool = False):
        """``eta``: show a rate and the time left (units of like cost: strikes); False: elapsed time only (stages of
        unlike cost, where a rate would promise nothing)."""
        from tqdm import tqdm  # only the long commands pay its import

        self.file = file or sys.stderr
        self.desc = desc
        fmt = None if eta else ("{desc} |{bar}| {n_fmt}/{total_fmt} " + unit + "s done [{elapsed}]" if total is not None
                                else "{desc}: {n_fmt} " + unit + "s done [{elapsed}]")
        self.bar = tqdm(total=total, desc=desc, unit=unit, file=self.file, leave=False, dynamic_ncols=True,
                        bar_format=fmt, disable=None if enabled is None else not enabled)
        self.started = False
        self._n = 0
        self._noted: set[str] = set()
        self._stop = threading.Event()
        self._thread = None
        if not self.bar.disable:
            self._thread = threading.Thread(target=self._redraw, daemon=True)
            self._thread.start()

    @property
    def n(self) -> int:
        """Units done (counted on a disabled bar too)."""
        return self._n

    def _update(self, n: int) -> None:
        self._n += n
        self.bar.update(n)

    def _redraw(self) -> None:
        while not self._stop.wait(REFRESH_S):
            self.bar.refresh()

    def stage(self, what: str) -> None:
        """``what`` starts now: the step before it is counted done; an engine's first-run cost is noted once."""
        if self.started:
            self._update(1)
        self.started = True
        for engine in ENGINE_NAMES:  # what its first run costs before it steps (``EngineAdapter.first_run_note``)
            if (engine in what.split() or what.endswith(engine)) and not unavailable_reason(engine):
                if adapter(engine).first_run_note:
                    self.note(f"{engine}: {adapter(engine).first_run_note}")
        self.bar.set_description_str(f"{self.desc}: {what}", refresh=True)

    def done(self, n: int = 1) -> None:
        """``n`` more units finished (for work counted as it completes, not as it starts)."""
        self._update(n)

    def note(self, line: str) -> None:
        """One line on stderr, terminal or not, above the bar; each text once."""
        if line in self._noted:
            return
        self._noted.add(line)
        self.bar.write(f"chatterbench: note: {line}", file=self.file)

    def write(self, line: str) -> None:
        """A progress line (a log's record of what finished), printed above the bar."""
        self.bar.write(line, file=self.file)

    def printing(self):
        """A context in which tables may go to stdout: the bar steps aside and is redrawn after."""
        return self.bar.external_write_mode()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self.started and self.bar.total is not None and self._n < self.bar.total:
            self._update(1)  # the last stage ran to its end
        self.bar.close()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class CountingExecutor(Executor):
    """An executor that counts each finished task on a ``Progress`` (work whose size is known only as it goes)."""

    def __init__(self, inner: Executor, progress: Progress):
        self.inner, self.progress = inner, progress

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        future = self.inner.submit(fn, *args, **kwargs)
        future.add_done_callback(lambda f: self.progress.done())
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self.inner.shutdown(wait=wait, cancel_futures=cancel_futures)
