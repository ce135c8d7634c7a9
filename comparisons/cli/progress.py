"""Progress on stderr for the commands that run long: a tqdm bar on a terminal, plain lines in a log.

    >>> from chatterbench.comparisons.cli.progress import Progress
    >>> with Progress(3, "compare bouncing-ball", unit="run", enabled=False) as bar:
    ...     for what in ("reference", "mujoco", "pybullet"):
    ...         bar.stage(what)                     # the step before is done; this one runs now
    >>> bar.n, bar.describe()
    (3, 'compare bouncing-ball: pybullet, 3 of 3 runs done')

Promises: the bar goes to stderr (stdout keeps the tables, for pipes and files) and is drawn
only on a terminal (tqdm's ``disable=None``), so logs and captured output stay clean; it is
redrawn every ``REFRESH_S`` seconds, so a step that holds the process for minutes (an engine
run in a child process, MuJoCo Warp compiling its kernels) still shows its time passing.
Where no bar is drawn (CI, a pipe, a file), ``heartbeat`` (around every command, ``main``)
prints one plain line after ``LINE_EVERY_S`` seconds without one: what runs, n of N done, and
the seconds since the command started (``chatterbench: progress: tune pybullet on feigin-pair:
the search, 12 candidates done; budget 600 runs; 63.0 s elapsed``), so a log is never silent for
longer than that, whatever the command does (``CHATTERBENCH_PROGRESS_LINES=off`` in the
environment turns these lines off, for a harness that compares stderr line by line; the test
suite does so, except where it tests them; ``CHATTERBENCH_PROGRESS_EVERY=S``, a number of seconds
> 0, prints a line after S s without one instead of ``LINE_EVERY_S``: a log that must speak more
often, or a short run that tests the lines; anything else is refused, exit 2). ``note`` lines (what a step will cost, e.g. a
kernel compile, the reference's first numba compile) are printed on every stream, terminal
or not: a log says why it paused.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from concurrent.futures import Executor, Future
from contextlib import contextmanager
from typing import Any, Callable, Iterator

from chatterbench.comparisons.pipeline.inert_text import log_text
from chatterbench.engines.registry import ENGINE_NAMES, adapter, unavailable_reason
from chatterbench.reference.errors import InputError

REFRESH_S = 1.0  # [s] how often the bar is redrawn while one step runs
# [s] the longest a command is silent where no bar is drawn: a line is printed after this long without one. Half the
# 10 s promised (issue 33), so that a line late by a loaded machine or a C call holding the GIL still keeps it
LINE_EVERY_S = 5.0
IMPORTS_S = 2.0  # [s] of a process's start counted as the command's silence before its first line
LINES_ENV = "CHATTERBENCH_PROGRESS_LINES"  # "off": no plain progress lines (the bar on a terminal is unaffected)
EVERY_ENV = "CHATTERBENCH_PROGRESS_EVERY"  # [s] a number > 0: a line after this long without one (LINE_EVERY_S unset)

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


def line_every_s() -> float | None:
    """The seconds without a line after which one is printed, as ``EVERY_ENV`` sets them [s]; None where it is unset
    (``LINE_EVERY_S``). Raises ``InputError`` for a value that is not a number of seconds > 0."""
    text = os.environ.get(EVERY_ENV, "").strip()
    if not text:
        return None
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not 0 < seconds < math.inf:
        raise InputError(f"{EVERY_ENV} = {text!r}: must be a number of seconds > 0 (unset: a line after "
                         f"{LINE_EVERY_S:g} s without one)")
    return seconds


class _Heartbeat:
    """The command's plain progress lines where no bar is drawn (module docstring): a thread that prints one after
    ``LINE_EVERY_S`` s without a line, describing the innermost open ``Progress``."""

    def __init__(self) -> None:
        self.command = "chatterbench"
        self.bars: list[Progress] = []
        self.last = time.monotonic()  # when the command last said something on stderr
        self.every: float | None = None  # [s] the command's own interval (``line_every_s``); None: LINE_EVERY_S

    def interval(self) -> float:
        """The seconds without a line after which one is printed [s]."""
        return LINE_EVERY_S if self.every is None else self.every

    def said(self) -> None:
        self.last = time.monotonic()

    def line(self) -> str:
        """The line printed now: what runs, n of N done, the seconds since the command started."""
        what = self.bars[-1].describe() if self.bars else f"{self.command}: working"
        compiling = reference_compile_note() if "chatterbench.reference.flow" in sys.modules else ""
        return f"chatterbench: progress: {what}{'; ' + compiling if compiling else ''}; {waited_s():.1f} s elapsed"

    def beat(self) -> None:
        """One look: a line when the command has been silent for ``interval()`` s and no bar shows its time."""
        if time.monotonic() - self.last < self.interval() or any(not b.bar.disable for b in self.bars):
            return
        try:
            print(self.line(), file=sys.stderr, flush=True)
        except (OSError, ValueError):  # stderr closed or gone (a reader that left): nothing to tell
            pass
        self.said()

    @contextmanager
    def __call__(self, command: str) -> Iterator[None]:
        """Lines for ``command`` (``chatterbench tune``) while the block runs; none after it."""
        # silent since the process started, its imports included (at most IMPORTS_S of them: a long-lived process, a
        # notebook, runs its first command as a fresh one would)
        self.command, self.bars, self.last = command, [], time.monotonic() - min(waited_s(), IMPORTS_S)
        self.every = line_every_s()  # a bad value is refused (exit 2), lines on or off
        if os.environ.get(LINES_ENV, "").strip().lower() == "off":
            yield
            return
        stop = threading.Event()

        def run() -> None:
            while not stop.wait(min(0.5, self.interval() / 4)):
                self.beat()

        thread = threading.Thread(target=run, name="chatterbench-progress", daemon=True)
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join()


heartbeat = _Heartbeat()


def reference_compile_note() -> str:
    """What the reference's first run costs when numba has not compiled its kernels yet (``cache=True``: once per
    install and Python version); "" when they are cached, or when that cannot be told (numba's cache index is
    looked up through its own objects, which may change between versions)."""
    try:
        from chatterbench.reference import flow  # the event loop's first kernel: every reference run compiles it

        cache = flow.evaluate._cache._cache_file
        if cache._load_index():  # the cached overloads of the current source ({} when none or stale)
            return ""
        return (f"the reference's numba kernels compile on this first run (about 10 s on 2 cores; once, cached in "
                f"{os.path.dirname(cache._index_path)})")
    except Exception:  # noqa: BLE001 - a note is never worth a failure
        return ""


class Progress:
    """A tqdm bar on stderr (module docstring); ``total`` None: a counter with elapsed time."""

    def __init__(self, total: int | None, desc: str, unit: str = "step", enabled: bool | None = None, file=None,
                 eta: bool = False, initial: int = 0):
        """``eta``: show a rate and the time left (units of like cost: strikes); False: elapsed time only (stages of
        unlike cost, where a rate would promise nothing). ``initial``: units done before (a resumed sweep)."""
        from tqdm import tqdm  # only the long commands pay its import

        self.file = file or sys.stderr
        self.desc, self.unit = desc, unit
        self.what = ""
        self.postfix = ""
        fmt = None if eta else ("{desc} |{bar}| {n_fmt}/{total_fmt} " + unit + "s done [{elapsed}]" if total is not None
                                else "{desc}: {n_fmt} " + unit + "s done [{elapsed}]")
        self.bar = tqdm(total=total, desc=desc, unit=unit, file=self.file, leave=False, dynamic_ncols=True,
                        bar_format=fmt, initial=initial, disable=None if enabled is None else not enabled)
        self.started = False
        self._n = initial
        self._noted: set[str] = set()
        self._stop = threading.Event()
        self._thread = None
        if not self.bar.disable:
            self._thread = threading.Thread(target=self._redraw, daemon=True)
            self._thread.start()
        heartbeat.bars.append(self)
        compiling = reference_compile_note()
        if compiling:
            self.note(compiling)

    @property
    def n(self) -> int:
        """Units done (counted on a disabled bar too)."""
        return self._n

    def describe(self) -> str:
        """What runs and how far it is, for a plain progress line: ``sweep feigin-pair, 40 of 216 runs done;
        failed 0``."""
        total = self.bar.total
        of = f" of {total}" if total is not None else ""
        return (f"{self.desc}{': ' + self.what if self.what else ''}, {self._n}{of} {self.unit}s done"
                f"{'; ' + self.postfix if self.postfix else ''}")

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
        self.what = what = log_text(what)  # a check's or scene's name: shown in the heartbeat line too
        for engine in ENGINE_NAMES:  # what its first run costs before it steps (``EngineAdapter.first_run_note``)
            if (engine in what.split() or what.endswith(engine)) and not unavailable_reason(engine):
                if adapter(engine).first_run_note:
                    self.note(f"{engine}: {adapter(engine).first_run_note}")
        self.bar.set_description_str(f"{self.desc}: {what}", refresh=True)

    def done(self, n: int = 1) -> None:
        """``n`` more units finished (for work counted as it completes, not as it starts)."""
        self._update(n)

    update = done  # tqdm's name, for code that drives a tqdm bar (the sweep's runner)

    def set_postfix(self, **values: Any) -> None:
        """Counts shown after the bar and in the plain lines (tqdm's ``set_postfix``: ``failed=2``)."""
        self.postfix = ", ".join(f"{k} {v}" for k, v in values.items())
        self.bar.set_postfix(**values)

    def note(self, line: str) -> None:
        """One line on stderr, terminal or not, above the bar; each text once."""
        if line in self._noted:
            return
        self._noted.add(line)
        self.bar.write(log_text(f"chatterbench: note: {line}"), file=self.file)
        heartbeat.said()

    def write(self, line: str) -> None:
        """A progress line (a log's record of what finished), printed above the bar."""
        self.bar.write(log_text(line), file=self.file)
        heartbeat.said()

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
        if self in heartbeat.bars:
            heartbeat.bars.remove(self)

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class CountingExecutor(Executor):
    """An executor that counts each finished task on a ``Progress`` (work whose size is known only as it goes): a
    task whose result is a list counts its items (tune's part of a pass: one row per candidate)."""

    def __init__(self, inner: Executor, progress: Progress):
        self.inner, self.progress = inner, progress

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        future = self.inner.submit(fn, *args, **kwargs)
        future.add_done_callback(lambda f: self.progress.done(_items(f)))
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self.inner.shutdown(wait=wait, cancel_futures=cancel_futures)


def _items(future: Future) -> int:
    """What a finished task counts: a list result its length, anything else (a failure, a cancel) one."""
    if future.cancelled() or future.exception() is not None:
        return 1
    result = future.result()
    return len(result) if isinstance(result, list) else 1
