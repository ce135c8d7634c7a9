"""Hypothesis profiles for the property and fuzz tests, and Ctrl-C as a terminal delivers it.

    $ pytest                                   # "dev": 50 random examples per test
    $ CI=true pytest                           # "ci": 25 derandomized examples, reproducible
    $ HYPOTHESIS_PROFILE=thorough pytest       # "thorough": 1000 examples, for local hunting

``ci`` is chosen when the environment variable CI is set to anything but "", "0" or
"false" (CI services set CI=true), unless HYPOTHESIS_PROFILE names a profile. It is
derandomized, so a CI failure is the same failure on every rerun and on a laptop
(``CI=true pytest ...``), and it prints the reproduction blob. It keeps the whole
hypothesis suite within about a minute on two cores. No profile has a deadline: a
reference run's time depends on how many impacts the drawn scene has (a chatter at
R = 0.9 takes a few hundred), not on a regression.

Ctrl-C: a suite started in the background of a non-interactive shell (``pytest &``, some CI
runners) has SIGINT ignored, and every command a test starts inherits that, so a Ctrl-C test's
SIGINT would never reach the command under test. The suite restores Python's own handler
(``_ctrl_c_as_a_terminal_sends_it``): the commands it starts then get SIGINT as a user's terminal
delivers it, whichever way the suite was started.

The engines on warp (MuJoCo Warp, Newton) compile their kernels once per machine into warp's cache: the controller
process starts ``python -m chatterbench.engines.warm`` in the background before the workers start, one process per
family of kernels (``pytest_configure``), the workers run other tests meanwhile, and a worker that reaches a run of
those engines waits on the cache's lock (``engines/warp_cache.py``) instead of compiling the same kernels again.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import signal
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, settings

# The test modules are rewritten by pytest (its assertions) and compiled once, not again by each worker at every
# start: where PYTHONDONTWRITEBYTECODE is set (this project's CI machines set it), each of the two workers would
# rewrite and compile the 200-odd test modules on every run, 3 s each. The bytecode goes to __pycache__ folders
# (.gitignore); the commands the tests start keep the environment's setting.
sys.dont_write_bytecode = False

_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])

settings.register_profile("dev", max_examples=50, **_COMMON)
settings.register_profile("ci", max_examples=25, derandomize=True, print_blob=True, **_COMMON)
settings.register_profile("thorough", max_examples=1000, print_blob=True, **_COMMON)


def _profile() -> str:
    chosen = os.environ.get("HYPOTHESIS_PROFILE")
    if chosen:
        return chosen
    if os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):
        return "ci"
    return "dev"


settings.load_profile(_profile())


def _ctrl_c_as_a_terminal_sends_it() -> None:
    """SIGINT to Python's own handler when this process was started with it ignored (module docstring)."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


_ctrl_c_as_a_terminal_sends_it()

# A command that runs 5 s without a word prints a plain progress line on stderr (cli/progress.py). On a loaded
# machine any command may, so tests that read stderr line by line would read a line the load put there: they run
# without these lines (inherited by the commands they start); tests/comparisons/cli/test_progress_lines.py turns
# them on where it tests them.
os.environ["CHATTERBENCH_PROGRESS_LINES"] = "off"


@pytest.fixture
def engine_runs(monkeypatch, tmp_path_factory):
    """The engine runs made while the test ran, as ``["pybullet.run", ...]``: a spy on the adapters' ``run`` and
    ``run_batch`` (the real engines still run) that logs each call that returned a result; a call refused with an
    exception (``SettingsError``: settings the scene cannot run with, refused before the engine steps) is no run.
    It logs to a file, so runs in forked children (isolated runs, process pools) count too. A test of a refusal
    asserts ``engine_runs() == []``: refused before any engine ran."""
    from chatterbench.engines import base
    from chatterbench.engines.registry import adapter

    for name in ("mujoco", "pybullet"):  # the default engines' classes, so that their own overrides are spied too
        adapter(name)
    log = tmp_path_factory.mktemp("engine-runs") / "runs.log"
    log.touch()

    def spy(method: str, original):
        @functools.wraps(original)
        def wrapper(self, *args, **kwargs):
            result = original(self, *args, **kwargs)
            with open(log, "a", encoding="utf-8") as f:
                f.write(f"{self.name}.{method}\n")
            return result
        return wrapper

    classes, todo = set(), [base.EngineAdapter]
    while todo:
        cls = todo.pop()
        classes.add(cls)
        todo.extend(cls.__subclasses__())
    for cls in classes:
        for method in ("run", "run_batch"):
            if method in vars(cls):
                monkeypatch.setattr(cls, method, spy(method, vars(cls)[method]))
    return lambda: log.read_text(encoding="utf-8").splitlines()


_WARMING: list[subprocess.Popen] = []


def pytest_configure(config) -> None:
    """The warp engines' kernels warmed in the background, once, by the controller (module docstring)."""
    if hasattr(config, "workerinput"):
        return  # a worker: the controller warms
    families = {"mujoco_warp": ["mujoco_warp"], "newton": ["newton_xpbd", "newton_semi"]}
    for package, engines in families.items():
        if importlib.util.find_spec(package) is not None:
            _WARMING.append(subprocess.Popen([sys.executable, "-m", "chatterbench.engines.warm", *engines],
                                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))


def pytest_unconfigure(config) -> None:
    for process in _WARMING:  # done long before the suite ends; a suite stopped early does not leave it behind
        if process.poll() is None:
            process.terminate()
        process.wait()
