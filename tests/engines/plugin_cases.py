"""Engine plugins for the tests, installed the way pip installs a package: the module and its ``.dist-info``.

    >>> import tempfile
    >>> from plugin_cases import PLUGINS, install
    >>> folder = install(tempfile.mkdtemp(), ["nodt"])
    >>> sorted(p.name for p in folder.iterdir() if p.name.startswith("cbtest"))
    ['cbtest_nodt', 'cbtest_nodt-0.1.dist-info']

``install(folder, names)`` writes each plugin of ``PLUGINS`` as a package in ``folder`` and a
``NAME-0.1.dist-info`` beside it holding its ``METADATA`` and its entry point in the group
``chatterbench.engines`` (``entry_points.txt``): what ``pip install`` writes into site-packages,
so that a python with ``folder`` on its path finds the plugins through ``importlib.metadata``
exactly as it finds installed ones. ``CASES`` are commands run in such a python, each in its
own process (``run_case``), with what they must do; ``tests/engines/test_plugin_faults.py``
checks them and ``tests/test_bad_inputs.py`` lists them in ``docs/bad-inputs.md``.

The plugins: ``line`` (the plugin how-to's from-scratch engine with a ``fault`` setting: ``segfault``,
``exit`` (``os._exit(0)``), ``hang`` in its step, anything else refused with a ValueError); the
five broken at load: ``broken_import`` (imports a module that is not there), ``nodt`` (settings
without ``dt``), ``plain`` (settings not a dataclass), ``nostep`` (``build`` without ``step``) and
``pybullet`` (a built-in engine's name); ``reference`` (the reserved name); three that die while
loading: ``crash_load`` (SIGSEGV), ``exit_load`` (``os._exit(0)``), ``hang_load`` (sleeps); and the
other hostile entries of issue 34: ``nomodule`` (its module not installed), ``noclass``,
``nocolon`` (entry points naming no class), ``unchecked`` (any ``dt`` accepted), ``misnamed`` (an
adapter calling itself ``other``), ``backwards`` (a whole-run adapter whose times go back); and two that run
but whose reporting raises (issue 45): ``badversion`` (``version()``) and ``badsnippet`` (``snippet()``), the
``line`` engine otherwise.
And three pythons for Siconos's child (``$CHATTERBENCH_SICONOS_PYTHON``) that need no Siconos:
one whose child never answers, one whose child writes garbage until its pipe is full, one that
answers the probe with bytes that are not UTF-8.
"""

from __future__ import annotations

import atexit
import functools
import os
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import NamedTuple

PLUGIN_PAGE = Path(__file__).resolve().parents[2] / "docs" / "how-to" / "plugin.md"  # the plugin how-to page
ENV = "CHATTERBENCH_SICONOS_PYTHON"  # the python that runs Siconos's child (engines/siconos_engine/run.py)


def readme_block(first_line: str, source: Path = PLUGIN_PAGE) -> str:
    """The fenced code block of ``source`` (the plugin how-to page, or another Markdown file) that starts with
    ``first_line`` (its text, the fences left out)."""
    for block in re.findall(r"```[a-z]*\n(.*?)```", source.read_text(encoding="utf-8"), flags=re.S):
        if block.startswith(first_line):
            return block
    raise LookupError(f"{source.name} has no code block starting {first_line!r}")


def _line_engine() -> str:
    """The plugin how-to's engine, renamed ``line``, with a ``fault`` setting its step obeys (module docstring)."""
    code = readme_block("# chatterbench_euler.py").replace('"euler', '"line').replace("EulerSettings", "LineSettings")
    code = code.replace("EulerEngine", "LineEngine").replace('"chatterbench-euler"', '"cbtest-line"')
    code = code.replace('''    dt: float = 1e-4  # [s] the step, checked when the settings are made
''', '''    dt: float = 1e-4  # [s] the step, checked when the settings are made
    fault: str = ""  # "", "segfault", "exit" or "hang": what the first step does
''')
    code = re.sub(r"(    def __post_init__\(self\):\n        check_[a-z]+\([^\n]*\)\n)", r'''\1        if self.fault not in ("", "segfault", "exit", "hang"):
            raise ValueError(f"fault {self.fault!r} is not one this plugin knows")
''', code, count=1)  # after its dt check (check_number, or the api's check_dt)
    code = code.replace('''    def step(self, w, forces):
''', '''    def tuning_space(self, scene):
        return {"dt": (1e-3, 3e-4), "line.fault": ("", "segfault")}  # tune tries a crashing candidate too

    def step(self, w, forces):
        if w.fault == "segfault":
            import ctypes
            ctypes.string_at(0)
        elif w.fault == "exit":
            import os
            os._exit(0)
        elif w.fault == "hang":
            import time
            while True:
                time.sleep(1.0)
''')
    code = code.replace("        self.walls = scene.gap.walls\n", "        self.walls, self.fault = scene.gap.walls, settings.fault\n")
    assert "fault not in" in code and code.count("LineEngine") == 1, "the plugin how-to's engine changed: update plugin_cases.py"
    return code


_HEAD = "from dataclasses import dataclass\n\nfrom chatterbench.engines import EngineAdapter\n"
_SETTINGS = ("@dataclass(frozen=True)\nclass Settings:\n    dt: float = 1e-3\n\n"
             "    def __post_init__(self):\n        from chatterbench.engines.settings import SettingsError\n"
             "        from chatterbench.reference.errors import check_number\n"
             "        check_number('dt', self.dt, lo=0.0, lo_open=True, error=SettingsError)\n\n\n")
_STEPS = ("    def build(self, scene, settings):\n        return None\n\n"
          "    def step(self, world, forces):\n        return (None, None, 0.0, 0.0), ()\n")


def _adapter(name: str, settings: str = "Settings", steps: str = _STEPS) -> str:
    return f"class Engine(EngineAdapter):\n    name, package, settings_type = {name!r}, 'cbtest-{name}', {settings}\n\n{steps}"


_BACKWARDS = ("class Engine(EngineAdapter):\n    name, package, settings_type = 'backwards', 'cbtest-backwards', Settings\n\n"
              "    def samples(self, run):  # a whole-run engine that yields its samples in the wrong order\n"
              "        import numpy as np\n"
              "        from chatterbench.engines.api import Samples\n"
              "        t = run.scene.initial.t + run.settings.dt * np.arange(run.n + 1)[::-1]\n"
              "        zero = np.zeros(run.n + 1)\n"
              "        yield Samples(t, {w: zero for w in run.scene.gap.walls}, y=zero + run.scene.initial.y, vy=zero)\n")

# the plugin how-to's engine (``line``, installed beside it) with one of its reporting methods raising: the run is fine, the
# report of it is the plugin's own code that fails
_LINE_CHILD = ("from cbtest_line import LineEngine\n\n\nclass Engine(LineEngine):\n"
               "    name, package = {name!r}, 'cbtest-{name}'\n\n"
               "    def tuning_space(self, scene):\n        return {{'dt': (1e-3, 3e-4)}}\n\n"
               "    def {method}:\n        raise RuntimeError('this plugin cannot say')\n")

PLUGINS = {  # engine name -> module source (the module is cbtest_NAME, the class Engine; None: no module written)
    "line": "",  # the plugin how-to's engine (_line_engine), written when installed; its class is LineEngine
    "broken_import": "import chatterbench_no_such_dependency  # noqa: F401\n" + _HEAD + _SETTINGS + _adapter("broken_import"),
    "nodt": _HEAD + "@dataclass(frozen=True)\nclass Settings:\n    step: float = 1e-3\n\n\n" + _adapter("nodt"),
    "plain": _HEAD + "class Settings:\n    dt = 1e-3\n\n\n" + _adapter("plain"),
    "nostep": _HEAD + _SETTINGS + _adapter("nostep", steps="    def build(self, scene, settings):\n        return None\n"),
    "pybullet": _HEAD + _SETTINGS + _adapter("pybullet"),
    "reference": _HEAD + _SETTINGS + _adapter("reference"),
    "crash_load": "import ctypes\nctypes.string_at(0)\n",
    "exit_load": "import os\nos._exit(0)\n",
    "hang_load": "import time\nwhile True:\n    time.sleep(1.0)\n",
    "nomodule": None,  # its entry point names a module that is not installed
    "noclass": _HEAD + _SETTINGS + _adapter("noclass"),
    "nocolon": _HEAD + _SETTINGS + _adapter("nocolon"),
    "unchecked": _HEAD + "@dataclass(frozen=True)\nclass Settings:\n    dt: float = 1e-3\n\n\n" + _adapter("unchecked"),
    "misnamed": _HEAD + _SETTINGS + _adapter("other"),
    "backwards": _HEAD + _SETTINGS + _BACKWARDS,
    "badversion": _LINE_CHILD.format(name="badversion", method="version(self)"),
    "badsnippet": _LINE_CHILD.format(name="badsnippet", method="snippet(self, scene, settings)"),
}
LOADING = ("line", "backwards", "badversion", "badsnippet")  # the plugins that load (their faults are in their runs); every other one is broken
ENTRIES = {"line": "cbtest_line:LineEngine", "noclass": "cbtest_noclass:Missing", "nocolon": "cbtest_nocolon"}


# pythons that pass the Siconos probe (a version on stdout) and then run BODY instead of the child (module docstring)
FAKE_PYTHONS = {
    "python-sleeps": "exec sleep 30",  # a child that never answers
    "python-garbage": "exec yes garbage",  # non-protocol bytes until the pipe is full (64 KB), then blocked writing
}
NOT_UTF8 = "python-not-utf8"  # a python that answers the probe with bytes that are not UTF-8


def install(folder: str | Path, names=tuple(PLUGINS)) -> Path:
    """Write the plugins ``names`` into ``folder`` as installed packages (module docstring), and the fake pythons of
    ``FAKE_PYTHONS`` and ``NOT_UTF8``; returns the folder."""
    folder = Path(folder)
    scripts = {name: f'if [ "$1" = -c ]; then echo 4.5.0; exit 0; fi\n{body}' for name, body in FAKE_PYTHONS.items()}
    scripts[NOT_UTF8] = "printf '\\377\\376\\n'"
    for name, body in scripts.items():
        (folder / name).write_text(f"#!/bin/sh\n{body}\n")
        (folder / name).chmod(0o755)
    for name in names:
        module = f"cbtest_{name}"
        write_installed(folder, module, _line_engine() if name == "line" else PLUGINS[name], f"cbtest-{name}",
                        f"{name} = {ENTRIES.get(name, f'{module}:Engine')}")
    return folder


def write_installed(folder: Path, module: str, source: str | None, package: str, entry: str, version: str = "0.1") -> None:
    """Module ``module`` (its ``__init__.py`` holding ``source``; None: not written) and the ``MODULE-VERSION.dist-info``
    of distribution ``package`` declaring ``entry`` (``NAME = module:Class``) in the group ``chatterbench.engines``:
    what pip writes into the site-packages ``folder`` (module docstring)."""
    if source is not None:
        (folder / module).mkdir(parents=True, exist_ok=True)
        (folder / module / "__init__.py").write_text(source)
    info = folder / f"{module}-{version}.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text(f"[chatterbench.engines]\n{entry}\n")


class Case(NamedTuple):
    """A command run with the plugins installed, and what it must give."""

    id: str
    what: str  # what is wrong, for the doc
    argv: list[str]
    code: int  # the exit code
    words: tuple[str, ...]  # in its stderr (exit 2) or in the engine's row of stdout (a run)
    env: dict[str, str] = {}


CASES = [
    Case("plugin-import-error", "a plugin whose import raises", ["compare", "bouncing-ball", "--engines", "broken_import"],
         2, ("plugin cbtest-broken_import (engine 'broken_import')", "cannot import cbtest_broken_import",
             "ModuleNotFoundError")),
    Case("plugin-no-dt", "a plugin's settings without dt", ["compare", "bouncing-ball", "--engines", "nodt"],
         2, ("plugin cbtest-nodt (engine 'nodt')", "has no field 'dt'")),
    Case("plugin-not-dataclass", "a plugin's settings not a dataclass", ["compare", "bouncing-ball", "--engines", "plain"],
         2, ("plugin cbtest-plain (engine 'plain')", "is not a dataclass")),
    Case("plugin-no-step", "a plugin that writes build but no step", ["compare", "bouncing-ball", "--engines", "nostep"],
         2, ("plugin cbtest-nostep (engine 'nostep')", "writes build but not step")),
    Case("plugin-no-module", "a plugin whose entry point names a module that is not installed",
         ["compare", "bouncing-ball", "--engines", "nomodule"], 2,
         ("plugin cbtest-nomodule (engine 'nomodule')", "cannot import cbtest_nomodule: ModuleNotFoundError")),
    Case("plugin-no-class", "a plugin whose entry point names a class its module lacks",
         ["compare", "bouncing-ball", "--engines", "noclass"], 2, ("plugin cbtest-noclass", "module cbtest_noclass has no Missing")),
    Case("plugin-no-colon", "a plugin whose entry point names no class (no colon)",
         ["compare", "bouncing-ball", "--engines", "nocolon"], 2,
         ("plugin cbtest-nocolon", "entry point nocolon = 'cbtest_nocolon' names no class (module:Class)")),
    Case("plugin-dt-unchecked", "a plugin whose settings accept any dt",
         ["compare", "bouncing-ball", "--engines", "unchecked"], 2, ("plugin cbtest-unchecked", "dt is not checked")),
    Case("plugin-name-mismatch", "a plugin whose adapter calls itself by another name",
         ["compare", "bouncing-ball", "--engines", "misnamed"], 2,
         ("plugin cbtest-misnamed", "Engine.name is 'other', not the name it is registered under ('misnamed')")),
    Case("plugin-times-backwards", "a whole-run plugin that hands its samples over in the wrong order",
         ["compare", "bouncing-ball", "--engines", "backwards"], 0,
         ("backwards", "error", "sample 0: t = 2 s, not t0 + k dt = 0 s")),
    Case("plugin-name-clash", "a plugin named as a built-in engine", ["engines", "pybullet"],
         2, ("plugin cbtest-pybullet (engine 'pybullet')", "the name of a built-in engine")),
    Case("plugin-reserved", "a plugin named reference", ["engines", "reference"],
         2, ("plugin cbtest-reference (engine 'reference')", "is reserved")),
    Case("plugin-load-segfault", "a plugin that segfaults as it is imported", ["run", "bouncing-ball", "--engines", "crash_load"],
         2, ("plugin cbtest-crash_load (engine 'crash_load')", "killed by SIGSEGV")),
    Case("plugin-load-exit", "a plugin that calls os._exit(0) as it is imported",
         ["run", "bouncing-ball", "--engines", "exit_load"], 2, ("plugin cbtest-exit_load", "exited with code 0")),
    Case("plugin-load-hang", "a plugin whose import never returns",
         ["compare", "bouncing-ball", "--engines", "hang_load", "--timeout", "1"], 2,
         ("plugin cbtest-hang_load", "loading it took more than 1 s")),
    Case("plugin-bad-settings", "a plugin's settings that refuse a value with a ValueError",
         ["compare", "bouncing-ball", "--engines", "line", "--set", "line.fault=bogus"], 2,
         ("plugin cbtest-line (engine 'line')", "its settings refused the values given: ValueError: fault 'bogus'")),
    Case("plugin-segfault", "a plugin whose step segfaults (beside pybullet)",
         ["compare", "bouncing-ball", "--engines", "line,pybullet", "--set", "line.fault=segfault"], 0,
         ("line", "crashed")),
    Case("plugin-os-exit", "a plugin whose step calls os._exit(0)",
         ["run", "bouncing-ball", "--engines", "line", "--set", "line.fault=exit"], 0,
         ("status crashed", "exited with code 0 without a result")),
    Case("plugin-hang", "a plugin whose step never returns",
         ["compare", "bouncing-ball", "--engines", "line", "--set", "line.fault=hang", "--timeout", "1"], 0,
         ("line", "timeout")),
    Case("siconos-child-sleeps", "the Siconos child never answers (a python that passes the probe, then sleeps)",
         ["compare", "bouncing-ball", "--engines", "siconos", "--timeout", "1"], 0, ("siconos", "timeout"),
         {ENV: "./python-sleeps"}),
    Case("siconos-child-garbage", "the Siconos child writes non-protocol bytes until its pipe is full",
         ["run", "bouncing-ball", "--engines", "siconos"], 0, ("status error", "sent what is not the protocol"),
         {ENV: "./python-garbage"}),
    Case("siconos-probe-not-utf8", "a python that answers the Siconos probe with bytes that are not UTF-8",
         ["run", "bouncing-ball", "--engines", "siconos"], 2, ("not UTF-8",), {ENV: "./" + NOT_UTF8}),
]

# issue 45, Why 9: a plugin's reporting code that raises, where the work around it is done (docs/bad-inputs.md shows
# these under "Round five", tests/test_round_five.py)
ROUND_FIVE = [
    Case("plugin-version-raises", "a plugin whose version() raises (before: compare ended in its traceback)",
         ["compare", "bouncing-ball", "--engines", "badversion,pybullet", "--set", "duration=0.5"], 0,
         ("badversion", "version() raised RuntimeError", "recorded as unknown")),
    Case("plugin-snippet-raises", "a plugin whose snippet() raises (before: tune --out ended in its traceback after the "
         "whole search, nothing written)", ["tune", "bouncing-ball", "--engines", "badsnippet", "--set", "duration=0.5",
                                            "--max-runs", "4", "--repeats", "1", "--out", "tuned"], 1,
         ("badsnippet", "snippet() raised RuntimeError", "as chatterbench holds them")),
]


def run_case(case: Case, folder: str | Path, timeout: float = 300) -> subprocess.CompletedProcess:
    """``chatterbench ARGV`` in a fresh python that has the plugins of ``folder`` installed, run in ``folder`` (the
    fake pythons are ``./NAME`` there: the messages that quote them are the same on every machine)."""
    path = os.pathsep.join(filter(None, [str(Path(folder).resolve()), os.environ.get("PYTHONPATH", "")]))
    env = {**os.environ, "PYTHONPATH": path, **case.env}
    return subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", *case.argv], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=folder)


@functools.cache
def outcomes() -> dict[str, subprocess.CompletedProcess]:
    """Every case's command run once per process, a few at a time, with the plugins installed in a temporary
    folder: case id -> what it did (the tests and the doc read the same runs)."""
    folder = install(tempfile.mkdtemp(prefix="cbtest-site-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    with ThreadPoolExecutor(max_workers=3) as pool:  # the cases mostly wait (limits, imports): overlap them
        done = dict(zip((c.id for c in CASES + ROUND_FIVE), pool.map(lambda c: run_case(c, folder), CASES + ROUND_FIVE)))
    return done


def said(case: Case, done: subprocess.CompletedProcess) -> str:
    """What the command said about the case: its error line (exit 2), else its line (stderr, then stdout) holding
    every word of the case ("" when none does)."""
    if done.returncode == 2:
        lines = [ln for ln in done.stderr.splitlines() if case.words[0] in ln]
        return lines[0] if lines else done.stderr.strip().splitlines()[-1]
    lines = [ln for ln in (*done.stderr.splitlines(), *done.stdout.splitlines()) if all(w in ln for w in case.words)]
    return re.sub(r"\b[0-9.]+ s stepping", "(time) s stepping", " ".join(lines[0].split())) if lines else ""
