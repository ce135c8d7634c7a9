"""What many test modules share, written once: the cached reference solution and the CLI, in-process or not.

Test modules import it as ``from helpers import cli, solution``: pytest puts ``tests/`` (the
folder of the root ``conftest.py``) on ``sys.path``.
"""

from __future__ import annotations

import functools
import io
import subprocess
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Callable, NamedTuple

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.pipeline.solution import ReferenceSolution, solve
from chatterbench.reference.scene import load_scene


@functools.cache
def reference_run(name: str, mode: str, overrides: tuple[str, ...] = ()):
    """The reference result for a catalogue scene in a chatter mode, simulated once per test session (bit-identical
    per input). Here, not in ``tests/reference/conftest.py``: a test module that imported it from ``conftest`` got
    another folder's conftest when both folders were collected."""
    from chatterbench.reference import simulate

    return simulate(load_scene(name, list(overrides)), mode)


@functools.cache
def solution(scene: str | Path) -> ReferenceSolution:
    """The reference solution of a built-in scene's name or a scene file, solved once per test session."""
    return solve(load_scene(scene))


class CliRun(NamedTuple):
    """What one ``chatterbench`` command did: its exit code and what it printed."""

    code: int
    out: str
    err: str


def cli(argv: list[str]) -> CliRun:
    """Run ``chatterbench ARGV`` in this process; argparse's refusals (SystemExit) become the exit code.

    Any other exception escapes, so a test sees a traceback the user would have seen.
    """
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)  # as sys.exit does
    return CliRun(int(code), out.getvalue(), err.getvalue())


def cli_process(*args: str, cwd: str | Path | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``chatterbench ARGS`` in a fresh Python process (``python -m chatterbench.comparisons.cli``), as a
    user's shell would: exit code, stdout and stderr as text."""
    return subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


# The gate every gate test starts from: the ball's one sliding episode (its Zeno point 1.355 s) in a 1.6 s run at
# dt 1e-4, 0.2 s of engine time a check. PyBullet's restitution_velocity_threshold = 0.002 m/s (just above its resting
# bounce, g dt = 1e-3 m/s: gates/default.toml) lets the ball rest: match; its default 0 keeps it bouncing: buzz.
BALL_DEFAULTS = """[defaults]
dt = 1e-4
scene_overrides = { duration = 1.6 }
"""
RESTS = "{ restitution_velocity_threshold = 0.002 }"  # PyBullet's settings with which the ball rests (above)


def ball_check(name: str, limits: list[str], engine: str = "pybullet", settings: str = "", comment: str = "",
               extra: str = "") -> str:
    """One ``[[check]]`` of the ball on ``engine`` in gate TOML: ``settings`` an inline table ("": the defaults),
    ``comment`` after the header (``# ...``), ``extra`` lines before the limits; one limit a line when several."""
    lines = [f"[[check]]{'   ' + comment if comment else ''}", f'name = "{name}"', 'scene = "bouncing-ball"',
             f'engine = "{engine}"']
    lines += [f"settings = {settings}"] if settings else []
    lines += [extra.rstrip("\n")] if extra else []
    quoted = ", ".join(f'"{limit}"' for limit in limits)
    lines.append(f"limits = [{quoted}]")
    return "\n".join(lines) + "\n"


def ball_gate(*checks: str, description: str = "", defaults: str = "") -> str:
    """A gate TOML of ``checks`` (``ball_check``'s) under ``BALL_DEFAULTS`` (``defaults``: more lines of it)."""
    head = f'description = "{description}"\n' if description else ""
    return head + "\n" + BALL_DEFAULTS + defaults + "".join("\n" + check for check in checks)


# a gate of one cheap check (0.2 s of engine time): the ball's one sliding episode on PyBullet, its settings the
# defaults (its last line is its limits: a test may add ``settings = ...`` after it)
BALL_PYBULLET_GATE = ball_gate(ball_check("ball/pybullet", ["verdict == match", "stick_error_rel_max <= 0.05"]))


def count_settings_made(monkeypatch) -> list[str]:
    """The engine of every settings object ``registry.make_settings`` makes from now on, in order (its values
    are applied by ``settings_with_overrides``, wrapped here to count: the real one still runs)."""
    import chatterbench.engines.registry as registry

    made, real = [], registry.settings_with_overrides

    def count(base, overrides, prefix):
        made.append(prefix)
        return real(base, overrides, prefix)

    monkeypatch.setattr(registry, "settings_with_overrides", count)
    return made


MEASURED = ("verdict", "n_episodes", "n_match", "stick_error_max", "stick_error_rel_max", "restitution_error_max",
            "penetration_max")  # a summary row's measured columns (cost_per_sim_s is the machine's, not the run's)


def measured(row) -> dict:
    """A summary row's ``MEASURED`` columns, NaN as "nan" (nothing measured equals nothing measured)."""
    return {k: ("nan" if row[k] != row[k] else row[k]) for k in MEASURED}


def wait_until(condition: Callable[[], bool], what: str, limit: float = 120.0, every: float = 0.02) -> None:
    """Poll ``condition`` until it holds; fail with ``what`` if it has not after ``limit`` [s].

    A hang guard, not a speed test: ``limit`` is far above what the slowest loaded machine needs, and the
    test goes on to assert the behaviour it waited for (``tests/test_no_wall_clock.py`` allows a clock read
    only in a polling loop's condition)."""
    end = time.monotonic() + limit
    while not condition() and time.monotonic() < end:
        time.sleep(every)
    assert condition(), f"{what} (waited {limit:g} s)"


class TimedRun(NamedTuple):
    """A child process's output and two clock readings [s, epoch] that bracket what it printed about its own age:
    ``started`` at or after the kernel started it (taken in the child between fork and exec), ``ended`` after it
    exited."""

    proc: subprocess.CompletedProcess
    before: float  # taken before the child was started
    started: float  # taken in the child, after the kernel started it, before Python's own start
    ended: float  # taken after it exited


def run_timed(argv: list[str], timeout: float = 300, **kwargs) -> TimedRun:
    """``argv`` in a child process, with the clock readings that bound any age it prints (``TimedRun``)."""
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        mark = os.path.join(tmp, "started")

        def note() -> None:  # runs in the child after fork, before exec
            with open(mark, "w", encoding="ascii") as f:
                f.write(repr(time.time()))

        before = time.time()
        proc = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, preexec_fn=note, **kwargs)
        ended = time.time()
        with open(mark, encoding="ascii") as f:
            started = float(f.read())
    return TimedRun(proc, before, started, ended)


def check_printed_age(printed: float, run: TimedRun, last_write: float, rounding: float) -> None:
    """``printed`` [s], a child's own "since the command started", is its age at the print: at least from its start to
    ``last_write`` (the mtime of a file it wrote before printing), at most the time it lived. Both bounds hold on a
    machine of any load: the start is bounded from below by ``started`` (taken after the kernel started it) and the
    whole life from above by ``ended - before``; ``rounding`` is the print's, plus 0.02 s for the kernel's clock
    ticks and the file system's coarse timestamps."""
    slack = rounding + 0.02
    assert printed + slack >= last_write - run.started, ("the age printed misses part of the run", printed,
                                                          last_write - run.started)
    assert printed - slack <= run.ended - run.before, ("the age printed is more than the process lived", printed,
                                                       run.ended - run.before)


def needs_engine(*names: str) -> None:
    """Skip the calling test, with the engine's install line as the reason, when an engine it runs is not installed
    (an optional extra absent, Siconos's interpreter missing): the suite passes with any subset of extras."""
    import pytest

    from chatterbench.engines.registry import unavailable_reason

    for name in names:
        reason = unavailable_reason(name)
        if reason:
            pytest.skip(reason)


def band_failures(scene, entry: dict, engine: str) -> tuple[int, list]:
    """A tuned point (a ``recommended.json`` frontier entry or answer: ``dt``, ``settings``, and ``tolerances``
    or ``tol``) checked over its band from outside tune (issue 41): a fresh ``compare`` at every dt of
    [0.8, 1.25] x dt (``tune.grid.band_dts``, both ends included) at each impact phase (``phases.PHASES``: the
    scene started phase x dt later on its exact motion), at the point's own tolerances. Returns (the runs, the
    failing (dt, phase, verdicts))."""
    from chatterbench.comparisons.pipeline.compare import compare
    from chatterbench.comparisons.pipeline.tolerances import Tolerances
    from chatterbench.comparisons.studies.phases import PHASES, phase_scene
    from chatterbench.comparisons.studies.tune.grid import band_dts
    from chatterbench.comparisons.studies.tune.passes import agrees

    tol = Tolerances(**entry["tolerances"]) if "tolerances" in entry else entry["tol"]
    ref = solve(scene)
    dts = sorted({*band_dts(float(f"{entry['dt'] * 0.8:.6g}"), float(f"{entry['dt'] * 1.25:.6g}")), entry["dt"]})
    assert len(dts) >= 16, dts  # the point's own dt with them (off the band's lattice when it was bisected)
    sets = [f"{k}={v}" for k, v in entry["settings"].items()]
    failing = []
    for dt in dts:
        for phase in PHASES:
            verdicts = compare(phase_scene(ref, dt, phase), settings=settings_for((engine,), dt, sets),
                               tol=tol).table["verdict"].tolist()
            if not (verdicts and all(agrees(v) for v in verdicts)):
                failing.append((dt, phase, verdicts))
    return len(dts) * len(PHASES), failing
