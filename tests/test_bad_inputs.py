"""The bad-input table: every user mistake tried on the CLI, and the message it gets.

Each case is (id, what is wrong, argv, scene file content or None, words the message must
contain). The test runs ``chatterbench`` in-process and asserts exit code 2, no traceback,
and that the message names the field. ``docs/bad-inputs.md`` is generated from the same
cases with the messages the CLI actually prints::

    python3 tests/test_bad_inputs.py > docs/bad-inputs.md

A file case writes its content to ``bad.toml`` in a scratch directory and runs there, so
the messages (which quote the path) are the same on every machine.

Below the table: the refusals that could break the CLI's promise of "one line naming the
field, never a traceback" in other ways (argparse, a newline typed into a key, PyBullet's
import banner), and absurd values that must end (refused, or a classified run) rather than hang.
"""

from __future__ import annotations

import functools
import gzip
import json
import math
import os
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import pytest

from helpers import cli, cli_process, needs_engine
from shared_runs import session_folder

FILE = "bad.toml"  # argv placeholder for the case's scene file
AFILE, ADIR = "afile", "adir"  # in every scratch directory: a file where a directory is wanted, and the reverse
APIPE = "apipe"  # and a named pipe where a file is wanted
CSV = "bad.csv"  # argv placeholder for a case's dataset (chart, report --sweep)
CSVGZ = "bad.csv.gz"  # ... and for a compressed trajectory (judge)
ROWS = "engine,dt,verdict,cost_per_sim_s,restitution\nmujoco,0.0001,match,0.02,0.5\npybullet,0.0001,late,0.2,0.5\n"

GOOD_FILE = """\
name = "pair"
mass1 = 1.0
mass2 = 1.0
restitution = 0.5
duration = 1.0
[gap]
lower = -0.1
upper = 0.1
[[forces]]
kind = "harmonic"
on = "body1"
amplitude = 1.0
omega = 1.0
"""


class Generated(str):
    """A case file too big or too binary to spell out: ``make(path)`` writes it; the doc shows this text."""

    def __new__(cls, text: str, make):
        made = str.__new__(cls, text)
        made.make = make
        return made


@functools.cache
def _gzip_member() -> bytes:
    """32 MiB of CSV rows, gzip-compressed once (33 kB)."""
    return gzip.compress(b"0.001,0,0.5,0,0\n" * 2**21, 9)


def _gzip_bomb(path: Path) -> None:
    # a header and ten members of 32 MiB each: 320 MiB decompressed, over the judge's 256 MiB
    path.write_bytes(gzip.compress(b"t,x1,x2,v1,v2\n") + _gzip_member() * 10)


def _sparse(size: int):
    def make(path: Path) -> None:
        with open(path, "wb") as f:
            f.truncate(size)  # a hole: no disk used, NUL bytes when read
    return make


def _ball_csv(edit=None) -> str:
    """The bouncing ball's exact samples every 10 ms as a CSV trajectory (``judge``), changed by ``edit``."""
    from chatterbench.comparisons import reference_trajectory, trajectory_table
    from chatterbench.reference.scene import load_scene

    table = trajectory_table(reference_trajectory(load_scene("bouncing-ball"), 0.01))[["t", "x1", "x2", "v1", "v2"]]
    return (edit(table) if edit else table).to_csv(index=False)


def _file(**replace: str) -> str:
    """GOOD_FILE with lines swapped: ``_file(**{"restitution = 0.5": "restitution = nan"})``."""
    text = GOOD_FILE
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    return text


# (id, what is wrong, argv, file content or None, words the message must contain)
CASES: list[tuple[str, str, list[str], str | None, tuple[str, ...]]] = [
    # restitution
    ("R=1", "R = 1 (must be < 1)", ["run", "feigin-pair", "--set", "restitution=1"], None, ("restitution", "[0, 1)")),
    ("R=1.5", "R above 1", ["run", "feigin-pair", "--set", "restitution=1.5"], None, ("restitution",)),
    ("R<0", "negative R", ["run", "feigin-pair", "--set", "restitution=-0.1"], None, ("restitution",)),
    ("R-file", "R = 1 in a scene file", ["run", FILE], _file(**{"restitution = 0.5": "restitution = 1.0"}), ("restitution",)),
    # masses
    ("mass2=0", "zero mass", ["run", "feigin-pair", "--set", "mass2=0"], None, ("mass2", "> 0")),
    ("mass2<0", "negative mass", ["run", "feigin-pair", "--set", "mass2=-1"], None, ("mass2",)),
    ("mass1=0", "zero mass of body 1", ["run", "feigin-pair", "--set", "mass1=0"], None, ("mass1",)),
    ("mass1-word", "mass1 a word other than inf", ["run", "feigin-pair", "--set", "mass1=heavy"], None, ("mass1", "inf")),
    ("mass2=inf", "infinite body 2", ["run", "feigin-pair", "--set", "mass2=inf"], None, ("mass2", "finite")),
    # gravity: an acceleration [m/s^2], any finite number
    ("gravity=nan", "gravity not a number", ["run", "bouncing-ball", "--set", "gravity=nan"], None,
     ("gravity", "finite", "m/s^2")),
    ("gravity-word", "gravity a word", ["run", "bouncing-ball", "--set", "gravity=down"], None, ("gravity", "number")),
    # timesteps
    ("--dt 0", "zero engine timestep", ["run", "feigin-pair", "--engine", "mujoco", "--dt", "0"], None, ("--dt",)),
    ("--dt -1", "negative engine timestep", ["run", "feigin-pair", "--engine", "mujoco", "--dt", "-1"], None, ("--dt",)),
    ("--dt nan", "non-finite engine timestep", ["run", "feigin-pair", "--engine", "mujoco", "--dt", "nan"], None, ("--dt",)),
    ("mujoco.dt=0", "zero timestep as an engine setting",
     ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.dt=0"], None, ("mujoco.dt",)),
    ("pybullet.dt<0", "negative timestep as an engine setting",
     ["run", "feigin-pair", "--engine", "pybullet", "--set", "pybullet.dt=-1"], None, ("pybullet.dt",)),
    # gap and initial state
    ("gap-crossed", "upper wall below the lower one", ["run", "feigin-pair", "--set", "gap.upper=-0.2"], None,
     ("gap.upper", "gap.lower")),
    ("gap-equal", "walls at the same place", ["run", "feigin-pair", "--set", "gap.lower=0.1"], None, ("gap.upper",)),
    ("y-above", "initial y above the upper wall", ["run", "feigin-pair", "--set", "initial.y=0.5"], None, ("initial.y", "gap")),
    ("y-below", "initial y below a one-sided gap", ["run", "bouncing-ball", "--set", "initial.y=-1"], None, ("initial.y",)),
    ("x1-fixed", "fixed body 1 given a velocity", ["run", "bouncing-ball", "--set", "initial.v1=1"], None, ("initial.v1", "fixed")),
    # non-finite numbers
    ("R=nan", "NaN restitution", ["run", "feigin-pair", "--set", "restitution=nan"], None, ("restitution", "finite")),
    ("vy=inf", "infinite initial velocity", ["run", "feigin-pair", "--set", "initial.vy=inf"], None, ("initial.vy", "finite")),
    ("omega=-inf", "infinite forcing frequency", ["run", "feigin-pair", "--set", "forces.0.omega=-inf"], None, ("omega",)),
    ("duration=nan", "NaN duration", ["run", "feigin-pair", "--set", "duration=nan"], None, ("duration",)),
    ("mass2-nan-file", "NaN in a scene file", ["run", FILE], _file(**{"mass2 = 1.0": "mass2 = nan"}), ("mass2", "finite")),
    ("w0_dt=inf", "infinite engine setting", ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.w0_dt=inf"], None,
     ("mujoco.w0_dt",)),
    # other values out of range, wrong types
    ("duration<0", "negative duration", ["run", "feigin-pair", "--set", "duration=-1"], None, ("duration", "> 0")),
    ("omega=0", "harmonic force of zero frequency", ["run", "feigin-pair", "--set", "forces.0.omega=0"], None, ("omega", "> 0")),
    ("R-word", "a word for a number", ["run", "feigin-pair", "--set", "restitution=abc"], None, ("restitution", "number")),
    ("gap-array", "an array for a number", ["run", "feigin-pair", "--set", "gap.lower=[1, 2]"], None, ("gap.lower", "number")),
    ("gap-string-file", "a string for a number in a file", ["run", FILE], _file(**{"lower = -0.1": "lower = \"-0.1\""}),
     ("gap.lower", "number")),
    ("gap-not-table", "a number for a table", ["run", FILE], _file(**{"[gap]\nlower = -0.1\nupper = 0.1\n": "gap = 0.1\n"}),
     ("gap", "table")),
    ("kind-typo", "force kind misspelt", ["run", FILE], _file(**{'kind = "harmonic"': 'kind = "harmonik"'}),
     ("forces[0].kind", "harmonic")),
    ("on-typo", "force on a body that does not exist", ["run", FILE], _file(**{'on = "body1"': 'on = "body3"'}),
     ("on", "body1")),
    ("force-param", "a parameter of another force kind", ["run", FILE], _file(**{"omega = 1.0": "omega = 1.0\nstiffness = 3.0"}),
     ("forces[0].stiffness", "harmonic")),
    ("prescribed-finite", "prescribed motion of a finite body", ["run", FILE],
     _file(**{"duration = 1.0": "duration = 1.0\n[prescribed]\namplitude = 0.01\nomega = 30.0"}), ("prescribed", "inf")),
    ("missing-field", "required field missing", ["run", FILE], _file(**{"mass2 = 1.0\n": ""}), ("mass2", "missing")),
    # unknown keys
    ("key-file", "unknown scene key in a file", ["run", FILE], _file(**{"restitution = 0.5": "restitutoin = 0.5"}),
     ("restitutoin", "did you mean 'restitution'")),
    ("key-section-file", "unknown key in a table", ["run", FILE], _file(**{"upper = 0.1": "uper = 0.1"}), ("gap.uper", "upper")),
    ("key-set", "unknown --set key", ["run", "feigin-pair", "--set", "restitutoin=0.5"], None,
     ("restitutoin", "did you mean 'restitution'")),
    ("key-set-section", "unknown --set key in a table", ["run", "feigin-pair", "--set", "initial.vz=1"], None,
     ("initial.vz", "initial.vy")),
    ("key-set-force", "--set on a force that does not exist", ["run", "feigin-pair", "--set", "forces.3.amplitude=1"], None,
     ("forces.3.amplitude",)),
    ("key-set-table", "--set on a whole table", ["run", "feigin-pair", "--set", "gap=1"], None, ("gap", "table")),
    ("mujoco.nope", "unknown engine setting", ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.nope=1"], None,
     ("mujoco.nope", "unknown mujoco setting")),
    ("mujoco.nope-ref", "engine setting without an engine", ["run", "feigin-pair", "--set", "mujoco.nope=1"], None,
     ("mujoco.nope", "--engine")),
    ("mujoco-typo", "engine setting misspelt", ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.w0dt=0.05"], None,
     ("mujoco.w0dt", "did you mean 'w0_dt'")),
    ("integrator", "engine setting value not allowed",
     ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.integrator=rk5"], None, ("mujoco.integrator", "rk4")),
    # names
    ("scene-name", "unknown scene", ["run", "feigin-par"], None, ("feigin-par", "did you mean 'feigin-pair'")),
    ("scene-file", "scene file that does not exist", ["run", "nowhere.toml"], None, ("nowhere.toml", "cannot be read")),
    ("engine-run", "unknown engine (run)", ["run", "feigin-pair", "--engine", "bullet"], None, ("--engine", "bullet")),
    ("engine-compare", "unknown engine (compare)", ["compare", "feigin-pair", "--engines", "mujoco,bulet"], None,
     ("bulet", "did you mean 'pybullet'")),
    ("chatter", "unknown chatter mode", ["run", "feigin-pair", "--chatter", "full"], None, ("--chatter", "full")),
    # engine stability
    ("w0_dt-any", "w0 dt past every stability limit",
     ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.w0_dt=3"], None, ("mujoco.w0_dt", "stability limit")),
    ("w0_dt-scene", "w0 dt past this scene's stability limit (R = 0.5)",
     ["run", "feigin-pair", "--engine", "mujoco", "--set", "mujoco.w0_dt=1.9"], None, ("mujoco.w0_dt", "stability limit")),
    # absurd but finite values: the reference refuses a run it cannot finish (before this guard: a hang)
    ("omega-absurd", "forcing frequency of 1e300 rad/s (a flow step of 1.6e-300 s)",
     ["run", "feigin-pair", "--set", "forces.0.omega=1e300"], None, ("stalled", "max_steps")),
    ("tune-repeats", "a billion timed repeats of tune's finalists (before: no bound)",
     ["tune", "bouncing-ball", "--engines", "pybullet", "--repeats", "1000000000"], None, ("--repeats", "[1, 100]")),
    ("stiffness-absurd", "a coupling spring of 1e300 N/m (before: the flow overflowed to NaN with numpy warnings, "
     "the engines diverged and the time-series figure raised a matplotlib traceback)",
     ["compare", "spring-pair", "--engines", "pybullet", "--set", "forces.0.stiffness=1e300", "--out", "o"], None,
     ("stalled", "max_steps", "stiffnesses")),
    ("amplitude-absurd", "force of 1e100 N, compared against the engines (no engine starts)",
     ["compare", "feigin-pair", "--set", "forces.0.amplitude=1e100"], None, ("stalled", "max_steps")),
    # sweep specs (chatterbench sweep SPEC.toml): checked whole before any engine starts
    ("sweep-empty-grid", "empty grid", ["sweep", FILE], 'scene = "bouncing-ball"\n[grid]\ndt = []\n', ("grid.dt", "empty")),
    ("sweep-no-points", "no grid and no points", ["sweep", FILE], 'scene = "bouncing-ball"\n', ("no points",)),
    ("sweep-key", "unknown top-level key", ["sweep", FILE], 'scene = "bouncing-ball"\ngird = {dt = [1e-3]}\n',
     ("gird", "did you mean 'grid'")),
    ("sweep-engine", "engine misspelt", ["sweep", FILE], 'scene = "bouncing-ball"\nengines = ["mujoko"]\n[grid]\ndt = [1e-3]\n',
     ("mujoko", "did you mean 'mujoco'")),
    ("sweep-R", "a grid value out of range", ["sweep", FILE], 'scene = "bouncing-ball"\n[grid]\nrestitution = [0.5, 1.2]\n',
     ("grid.restitution = 1.2", "[0, 1)")),
    ("sweep-mixed", "a grid of numbers and strings", ["sweep", FILE], 'scene = "bouncing-ball"\n[grid]\ndt = [1e-3, "fast"]\n',
     ("grid.dt", "one kind")),
    ("sweep-timeout", "negative run time limit", ["sweep", FILE], 'scene = "bouncing-ball"\ntimeout = -1\n[grid]\ndt = [1e-3]\n',
     ("timeout", "> 0")),
    ("sweep-setting", "a setting of an engine not in the sweep", ["sweep", FILE],
     'scene = "bouncing-ball"\nengines = ["pybullet"]\n[grid]\nmujoco.w0_dt = [0.03]\n', ("mujoco.w0_dt", "not in engines")),
    ("sweep-both", "a key both fixed and varied", ["sweep", FILE],
     'scene = "bouncing-ball"\n[set]\ndt = 1e-3\n[grid]\ndt = [1e-3]\n', ("grid.dt", "also in [set]")),
    ("sweep-workers", "zero workers", ["sweep", "examples/sweeps/bouncing-ball-dt.toml", "--workers", "0"], None, ("--workers",)),
    # [refine] tables (adaptive maps): the field named, nothing run
    ("sweep-refine-axis", "a refined axis misspelt", ["sweep", FILE],
     'scene = "bouncing-ball"\n[grid]\ndt = [1e-3, 1e-2]\nrestitution = [0.3, 0.5]\n[refine]\naxes = ["dtt", "restitution"]\ndepth = 2\n',
     ("refine.axes", "'dtt'", "did you mean 'dt'")),
    ("sweep-refine-grid", "a refined axis that is not in [grid]", ["sweep", FILE],
     'scene = "bouncing-ball"\n[set]\nmass2 = 2.0\n[grid]\ndt = [1e-3, 1e-2]\n[refine]\naxes = ["dt", "mass2"]\ndepth = 2\n',
     ("refine.axes", "'mass2' is not a key of [grid]")),
    ("sweep-refine-depth", "refinement depth out of range", ["sweep", FILE],
     'scene = "bouncing-ball"\n[grid]\ndt = [1e-3, 1e-2]\nrestitution = [0.3, 0.5]\n[refine]\naxes = ["dt", "restitution"]\ndepth = 7\n',
     ("refine.depth = 7", "[1, 6]")),
    ("sweep-refine-boundary", "an unknown verdict or metric as the boundary", ["sweep", FILE],
     'scene = "bouncing-ball"\n[grid]\ndt = [1e-3, 1e-2]\nrestitution = [0.3, 0.5]\n[refine]\naxes = ["dt", "restitution"]\n'
     'depth = 2\nboundary = "mach"\n', ("refine.boundary = 'mach'", "did you mean 'match'")),
    ("sweep-refine-threshold", "a metric boundary without its threshold", ["sweep", FILE],
     'scene = "bouncing-ball"\n[grid]\ndt = [1e-3, 1e-2]\nrestitution = [0.3, 0.5]\n[refine]\naxes = ["dt", "restitution"]\n'
     'depth = 2\nboundary = "exit_error_max"\n', ("refine.threshold", "missing")),
    # gate files (chatterbench gate GATES.toml): every problem of the file, one per line
    ("gate-metric", "unknown metric", ["gate", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = ["exit_eror_max <= 1e-3"]\n', ("exit_eror_max", "exit_error_max")),
    ("gate-no-limits", "a check without limits", ["gate", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = []\n', ("limits", "at least one")),
    ("gate-dt", "zero timestep", ["gate", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\ndt = 0\nlimits = ["verdict == match"]\n', ("dt = 0", "> 0")),
    ("gate-empty", "no checks", ["gate", FILE], 'description = "nothing"\n', ("no checks",)),
    ("gate-tolerance", "an unknown tolerance in a gate file", ["gate", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\ntolerances = { stik = 0.1 }\nlimits = ["verdict == match"]\n',
     ("stik", "did you mean 'stick'")),
    ("gate-verdict", "a verdict that does not exist", ["gate", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = ["verdict in [match, bounce]"]\n',
     ("bounce", "rebound")),
    # verdict tolerances (--tolerance KEY=VALUE on every command that judges)
    ("tol-key", "an unknown tolerance", ["compare", "bouncing-ball", "--tolerance", "stik=0.1"], None,
     ("stik", "did you mean 'stick'")),
    ("tol-range", "a tolerance above 1", ["compare", "bouncing-ball", "--tolerance", "exit=2"], None, ("exit = 2", "(0, 1]")),
    ("tol-word", "a tolerance that is a word", ["report", "--tolerance", "stick=small"], None, ("stick", "number")),
    ("tol-count", "a negative impact count", ["gate", "gates/default.toml", "--tolerance", "impact_count=-1"], None,
     ("impact_count = -1", "integer")),
    ("tol-sweep", "an out-of-range tolerance in a sweep spec", ["sweep", FILE],
     'scene = "bouncing-ball"\n[grid]\ndt = [1e-3]\n[tolerances]\nrestitution = 0\n', ("restitution = 0", "(0, 1]")),
    ("tol-tune", "a tune tolerance that is no number", ["tune", "bouncing-ball", "--engine", "pybullet", "--tolerance", "tight"],
     None, ("--tolerance", "KEY=VALUE")),
    # chart (chatterbench chart ...) on a dataset that is not there
    ("chart-missing", "no sweep dataset", ["chart", "nowhere", "--kind", "work-precision"], None, ("nowhere",)),
    # malformed input
    ("toml", "malformed TOML file", ["run", FILE], "mass1 = 1.0\nmass2 = \n", ("not valid TOML",)),
    ("toml-binary", "binary file", ["run", FILE], "\x00\x01\x02", ("not valid TOML",)),
    ("toml-empty", "empty file", ["run", FILE], "", ("mass1", "missing")),
    ("set-no-eq", "--set without '='", ["run", "feigin-pair", "--set", "restitution"], None, ("--set", "KEY=VALUE")),
    ("set-empty-key", "--set with an empty key", ["run", "feigin-pair", "--set", "=0.5"], None, ("--set", "empty key")),
    ("set-newline", "two assignments in one --set (a line break)", ["run", "feigin-pair", "--set", "restitution=0.3\nmass2=3"],
     None, ("--set", "one KEY=VALUE")),
    ("set-superscript", "a force index that is not an ASCII digit", ["run", "feigin-pair", "--set", "forces.\u00b2.amplitude=1"],
     None, ("forces.N.param",)),
    # runaway inputs: estimated from the inputs and refused before anything runs (pipeline/budget.py)
    ("dt=1e-7", "4e8 MuJoCo steps", ["run", "feigin-pair", "--engine", "mujoco", "--dt", "1e-7"], None,
     ("dt = 1e-07", "4.02e+08 steps", "--max-steps")),
    ("duration=1e5-engine", "1e9 MuJoCo steps", ["run", "feigin-pair", "--engine", "mujoco", "--set", "duration=1e5"], None,
     ("duration = 1e+05", "--max-steps", "GiB")),
    ("dt=1e-300", "a timestep that overflows the step count", ["run", "feigin-pair", "--engine", "mujoco", "--dt", "1e-300"],
     None, ("dt = 1e-300", "steps")),
    ("pybullet-dt=1e-12", "4e13 PyBullet steps", ["run", "feigin-pair", "--engine", "pybullet", "--dt", "1e-12"], None,
     ("dt = 1e-12", "--max-memory")),
    ("pybullet-duration=1e9", "1e13 PyBullet steps", ["run", "feigin-pair", "--engine", "pybullet", "--set", "duration=1e9"],
     None, ("duration = 1e+09", "--max-steps")),
    ("compare-duration=1e6", "a million-second comparison", ["compare", "feigin-pair", "--set", "duration=1e6"], None,
     ("duration = 1e+06", "--max-steps")),
    ("reference-duration=1e6", "a reference run of 1.6e5 forcing periods", ["run", "feigin-pair", "--set", "duration=1e6"],
     None, ("the reference", "duration = 1e+06", "events", "--max-memory")),
    ("platemap-huge", "a 1e10-strike plate map", ["platemap", "feigin-pair", "--phases", "100000", "--speeds", "100000"], None,
     ("--phases 100000", "--speeds 100000", "GiB", "--max-memory")),
    ("platemap-unforced", "a plate map of a scene without forcing (before: exit 0, speeds to 4e13 m/s)",
     ["platemap", "bouncing-ball"], None, ("bouncing-ball", "no forcing")),
    ("scenes --toml typo", "a built-in scene name misspelt", ["scenes", "--toml", "feigin"], None,
     ("--toml", "did you mean 'feigin-pair'")),
    ("--max-memory 0.01", "a memory limit below a process's own size", ["run", "feigin-pair", "--max-memory", "0.01"], None,
     ("--max-memory", ">=")),
    # numbers that cannot be represented
    ("initial.t=1e20", "a start time where the run's span cannot be told apart", ["run", "feigin-pair", "--set", "initial.t=1e20"],
     None, ("initial.t = 1e+20", "keep |initial.t| below")),
    ("initial.t=1e12-compare", "a start time where the engine's steps cannot be told apart",
     ["compare", "feigin-pair", "--engines", "pybullet", "--set", "initial.t=1e12"], None, ("initial.t",)),
    ("mass2-5000-digits", "a 5000-digit integer in --set", ["run", "feigin-pair", "--set", "mass2=" + "1" * 5000], None,
     ("mass2", "characters)", "number")),
    ("mass2-5000-digits-file", "a 5000-digit integer in a scene file", ["run", FILE],
     _file(**{"mass2 = 1.0": "mass2 = " + "1" * 5000}), ("too long",)),
    ("mass2-400-digits", "a 400-digit mass", ["run", "feigin-pair", "--set", "mass2=" + "1" * 400], None,
     ("mass2", "too large", "characters)")),
    ("mujoco-mass2=1e-300", "a mass MuJoCo's compiler refuses", ["run", "feigin-pair", "--engine", "mujoco", "--set", "mass2=1e-300"],
     None, ("MuJoCo cannot build", "mass2 = 1e-300")),
    # flags that would be ignored or contradict each other
    ("run-dt-reference", "--dt on a reference run", ["run", "feigin-pair", "--dt", "1e-3"], None, ("--dt", "--engines")),
    ("run-export-reference", "--export-model on a reference run", ["run", "feigin-pair", "--export-model", "m.xml"], None,
     ("--export-model", "--engines")),
    ("run-export-drake", "--export-model for an engine that cannot export", ["run", "bouncing-ball", "--engine", "drake",
     "--export-model", "m.xml"], None, ("--export-model", "mujoco, pybullet")),
    ("run-export-suffix", "--export-model naming a file of another kind", ["run", "bouncing-ball", "--engine", "pybullet",
     "--export-model", "m.xml"], None, ("--export-model m.xml", ".py")),
    ("run-export-over-scene", "--export-model naming the scene file the run reads", ["run", FILE, "--engine", "pybullet",
     "--export-model", FILE], GOOD_FILE, ("--export-model bad.toml", "is the SCENE file", "name another file")),
    ("run-chatter-engine", "--chatter on an engine run", ["run", "feigin-pair", "--engine", "pybullet", "--chatter", "exhaustive"],
     None, ("--chatter",)),
    ("engines-repeated", "the same engine twice", ["compare", "feigin-pair", "--engines", "pybullet,pybullet"], None,
     ("--engines", "more than once")),
    ("tune-engine-twice", "tune given one engine twice", ["tune", "feigin-pair", "--engine", "pybullet,pybullet"], None,
     ("--engines", "more than once")),
    ("tune-max-cost-0", "a cost cap of 0 steps per simulated second", ["tune", "bouncing-ball", "--engines", "pybullet",
     "--max-cost", "0"], None, ("--max-cost", "> 0")),
    ("tune-set-unsearched", "--set an engine setting tune does not search", ["tune", "bouncing-ball", "--engines",
     "mujoco", "--set", "mujoco.erp=1"], None, ("--set mujoco.erp=1", "searches mujoco.w0_dt")),
    ("platemap-dt-no-engine", "--dt on a plate map without engines", ["platemap", "feigin-pair", "--dt", "1e-3"], None,
     ("--dt", "--engines")),
    ("--timeout 1e300", "an engine time limit past a day", ["compare", "feigin-pair", "--timeout", "1e300"], None,
     ("--timeout", "one day")),
    # calibrate (effective restitution against impact speed)
    ("calibrate-R=1", "calibrate against R = 1", ["calibrate", "mujoco", "--restitution", "1"], None,
     ("--restitution", "(0, 1)")),
    ("calibrate-R=0", "calibrate against R = 0 (e / R has no meaning)", ["calibrate", "pybullet", "--restitution", "0"], None,
     ("--restitution", "(0, 1)")),
    ("calibrate-speeds-order", "speeds LO above HI", ["calibrate", "mujoco", "--speeds", "1,0.1"], None,
     ("--speeds", "LO must be below HI")),
    ("calibrate-speeds-one", "one speed where a range is wanted", ["calibrate", "mujoco", "--speeds", "1"], None,
     ("--speeds", "LO,HI")),
    ("calibrate-points", "a million speeds", ["calibrate", "mujoco", "--points", "1000000"], None, ("--points", "[2, 200]")),
    ("calibrate-engine-typo", "an engine misspelt", ["calibrate", "pybulet"], None, ("pybulet", "did you mean 'pybullet'")),
    ("calibrate-R-twice", "R given twice", ["calibrate", "mujoco", "--restitution", "0.5", "--set", "restitution=0.6"], None,
     ("--restitution", "give R once")),
    # output destinations: the table of tests/test_bad_outputs.py (the doc below shows both)
    # datasets (chart, report --sweep): only the judge's verdicts, numbers where numbers belong
    ("dataset-verdict", "a verdict the judge does not have", ["chart", CSV, "--kind", "work-precision"],
     ROWS.replace("late", "slipped"), ("column verdict", "'slipped'", "allowed")),
    ("dataset-text-cost", "text in the cost column", ["chart", CSV, "--kind", "work-precision"],
     ROWS.replace("0.2,", "slow,"), ("column cost_per_sim_s", "'slow'", "not a number")),
    ("report-dataset-verdict", "report --sweep with an unknown verdict", ["report", "bouncing-ball", "--sweep", CSV],
     ROWS.replace("late", "slipped"), ("column verdict",)),
    ("gate --band -1", "a negative regression band", ["gate", FILE, "--band", "-1"],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = ["verdict == match"]\n', ("--band", ">= 0")),
    ("gate --baseline not-json", "a baseline that is not one", ["gate", FILE, "--baseline", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = ["verdict == match"]\n', ("--baseline", "not JSON")),
    ("gate-unclosed-list", "a verdict list without its closing bracket", ["gate", FILE],
     '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = ["verdict in [match"]\n', ("bracketed list",)),
    # issue 25: every input file checked for type and size before it is read; nesting bounded everywhere
    ("run /dev/zero", "a device for a scene file (before: read until memory ran out)", ["run", "/dev/zero"], None,
     ("/dev/zero", "not a regular file")),
    ("run /dev/urandom", "a random device for a scene file", ["run", "/dev/urandom"], None, ("/dev/urandom", "not a regular file")),
    ("run apipe", "a named pipe for a scene file (before: blocked forever)", ["run", APIPE], None, ("apipe", "not a regular file")),
    ("run adir", "a directory for a scene file", ["run", ADIR], None, ("adir", "is a directory")),
    ("sweep scene=/dev/zero", "a sweep of a device", ["sweep", FILE], 'scene = "/dev/zero"\n[grid]\ndt = [1e-3]\n',
     ("/dev/zero", "not a regular file")),
    ("sweep-big", "a sweep spec past 10 MiB", ["sweep", FILE], 'scene = "bouncing-ball"\n[grid]\ndt = [1e-3]\n' + "#" * 11_000_000,
     ("bad.toml", "10 MiB")),
    ("toml-deep-arrays", "arrays nested 5000 deep (before: RecursionError)", ["run", FILE], "a = " + "[" * 5000 + "]" * 5000,
     ("bad.toml", "nested", "32")),
    ("toml-deep-tables", "inline tables nested 3000 deep", ["run", FILE], "a = " + "{b = " * 3000 + "1" + "}" * 3000,
     ("bad.toml", "nested", "32")),
    ("toml-deep-key", "a dotted key 20000 deep (before: RecursionError after 4 s)", ["run", FILE], "a" + ".a" * 20000 + " = 1",
     ("bad.toml", "nested", "32")),
    ("toml-deep-quoted-key", "a dotted key of quoted parts 20000 deep", ["run", FILE], "'a'" + ".'a'" * 20000 + " = 1",
     ("bad.toml", "nested", "32")),
    ("set-deep", "a --set value nested 3000 deep", ["run", "feigin-pair", "--set", "gap.lower=" + "[" * 3000 + "]" * 3000],
     None, ("--set gap.lower", "nested", "32")),
    ("sweep-deep-grid", "a sweep grid nested 4000 deep", ["sweep", FILE],
     'scene = "bouncing-ball"\n[grid]\ndt = ' + "[" * 4000 + "]" * 4000 + "\n", ("bad.toml", "nested", "32")),
    ("gate-deep", "a gate file nested 4000 deep", ["gate", FILE], "check = " + "[" * 4000 + "]" * 4000 + "\n",
     ("bad.toml", "nested", "32")),
    ("gate --baseline /dev/zero", "a device for a baseline (before: read until memory ran out)", ["gate", FILE, "--baseline",
     "/dev/zero"], '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nlimits = ["verdict == match"]\n',
     ("--baseline /dev/zero", "not a regular file")),
    # issue 25: messages safe for a terminal
    ("set-escape", "a terminal escape sequence in a --set key (before: echoed raw)", ["run", "feigin-pair", "--set", "\x1b[2J\x1b[31mred=1"],
     None, ("\\x1b[2J\\x1b[31mred", "unknown")),
    ("set-long-key", "a 10,000-character key (before: echoed whole)", ["run", "feigin-pair", "--set", "k" * 10_000 + "=1"], None,
     ("kkk...kkk", "(10000 characters)")),
    # issue 25: no setting silently ignored or overwritten (before: each was accepted, exit 0)
    ("set-engine-not-run", "a setting of an engine that is not run", ["compare", "feigin-pair", "--engines", "pybullet", "--set",
     "mujoco.w0_dt=0.05"], None, ("--set mujoco.w0_dt=0.05", "mujoco is not run", "--engines pybullet")),
    ("set-drake-not-run", "a Drake setting, Drake not among the engines", ["compare", "feigin-pair", "--set", "drake.accuracy=1e-3"],
     None, ("drake.accuracy", "drake is not run")),
    ("run-set-warp-not-run", "a mujoco_warp setting on a PyBullet run", ["run", "feigin-pair", "--engines", "pybullet", "--set",
     "mujoco_warp.worlds=4"], None, ("mujoco_warp.worlds=4", "mujoco_warp is not run")),
    ("dt-twice", "--dt and ENGINE.dt both given", ["run", "feigin-pair", "--engines", "pybullet", "--dt", "1e-4", "--set",
     "pybullet.dt=1e-3"], None, ("--dt 0.0001", "--set pybullet.dt=1e-3", "give one")),
    ("set-repeated", "one --set key twice, two values", ["run", "feigin-pair", "--set", "restitution=0.3", "--set",
     "restitution=0.5"], None, ("--set restitution=0.3", "--set restitution=0.5", "once")),
    ("tolerance-repeated", "one --tolerance key twice, two values", ["compare", "bouncing-ball", "--tolerance", "stick=0.1",
     "--tolerance", "stick=0.2"], None, ("--tolerance stick=0.1", "--tolerance stick=0.2", "once")),
    ("option-repeated", "an option given twice with two values", ["run", "feigin-pair", "--engines", "mujoco", "--dt", "1e-3",
     "--dt", "2e-3"], None, ("--dt", "0.001 and 0.002", "once")),
    ("scenes-toml-twice", "scenes --toml given two scenes", ["scenes", "--toml", "feigin-pair", "--toml", "bouncing-ball"], None,
     ("--toml", "'feigin-pair'", "'bouncing-ball'", "once")),
    ("description-list", "a description that is not a string (before: made one)", ["run", FILE],
     _file(**{'name = "pair"': 'name = "pair"\ndescription = [1, 2]'}), ("description = [1, 2]", "string")),
    # issue 25: every limit kept by every command, every count bounded, refused up front
    ("platemap-max-steps", "--max-steps on a plate map's engine runs (before: ignored, ran 120 s)",
     ["platemap", "feigin-pair", "--engines", "pybullet", "--max-steps", "1"], None, ("one strike's", "--max-steps 1")),
    ("platemap-dt=1e-9", "a plate map at dt = 1e-9 (before: started the runs)", ["platemap", "feigin-pair", "--engines", "mujoco",
     "--dt", "1e-9"], None, ("dt = 1e-09", "--max-steps")),
    ("platemap-amplitude-absurd", "a plate map of a 1e300 N force (before: hung in the strike kernel, killed after 10 min)",
     ["platemap", "feigin-pair", "--set", "forces.0.amplitude=1e300"], None, ("feigin-pair", "flow steps", "max_steps")),
    ("bench-points=1e9", "a billion points for a benchmark that takes none (before: accepted)", ["bench", "reference", "--points",
     "1000000000"], None, ("--points", "[2, 10000]")),
    ("bench-option-elsewhere", "an option of another benchmark (before: ignored)", ["bench", "reference", "--strikes", "10"],
     None, ("--strikes", "applies to bench platemap")),
    ("bench-repeats=1e9", "a billion repeats", ["bench", "engines", "--repeats", "1000000000"], None, ("--repeats", "[1, 100]")),
    ("sweep-last-of-90000", "a 300 x 300 grid whose one run over the budget is its last point (before: refused after 16 s)",
     ["sweep", FILE], 'scene = "bouncing-ball"\nengines = ["mujoco"]\n[grid]\ndt = [%s]\nduration = [%s]\n' % (
         ", ".join(repr(1e-3 - i * (1e-3 - 2e-6) / 299) for i in range(300)), ", ".join(repr(0.5 + i * 199.5 / 299) for i in range(300))),
     ("grid point", "duration = 200.0", "--max-steps")),
    # issue 25: a report's sections and figures are found by scene name (before: the first scene showed the second's figures)
    ("report-same-scene-twice", "one scene twice in a report", ["report", "bouncing-ball", "bouncing-ball"], None,
     ("'bouncing-ball'", "more than once")),
    ("report-same-name", "two scene files of one name", ["report", "feigin-pair", FILE], _file(**{'name = "pair"': 'name = "feigin-pair"'}),
     ("'feigin-pair'", "more than once", "name")),
    # issue 33: a misspelt subcommand or option gets the nearest name (before: the list of choices, or nothing)
    ("repot", "a misspelt subcommand (before: no did-you-mean)", ["repot"], None, ("'repot'", "did you mean 'report'")),
    ("--dtt", "a misspelt option (before: no did-you-mean, and 'see chatterbench --help')", ["run", "feigin-pair", "--dtt",
     "1e-3"], None, ("--dtt: did you mean '--dt'", "see chatterbench run --help")),
    # issue 34: judge files, bounded before they are read and refused by kind; rows as a user counts them
    ("judge /dev/zero", "a device for a trajectory (before: \"no such file\")", ["judge", "bouncing-ball", "/dev/zero"], None,
     ("'/dev/zero'", "is a device")),
    ("judge adir", "a directory for a trajectory (before: \"no such file\")", ["judge", "bouncing-ball", ADIR], None,
     ("'adir'", "is a directory")),
    ("judge apipe", "a named pipe for a trajectory (before: \"no such file\")", ["judge", "bouncing-ball", APIPE], None,
     ("'apipe'", "is a named pipe")),
    ("judge-escapes", "a trajectory name with terminal escapes (before: echoed raw)", ["judge", "bouncing-ball",
     "\x1b[2J\x1b[31mred.csv"], None, ("'\\x1b[2J\\x1b[31mred.csv'", "no such file")),
    ("judge-gzip-bomb", "a .csv.gz of 320 MiB decompressed (before: read whole: 2.85 GiB for a 2 GiB bomb)",
     ["judge", "bouncing-ball", CSVGZ], Generated("(10 gzip members of 32 MiB of rows each, 0.3 MB compressed)", _gzip_bomb),
     ("'bad.csv.gz'", "decompressed, larger than 256 MiB")),
    ("judge-sparse-64MB", "a 64 MB sparse file, all NUL bytes (before: read whole: 3.7 GB, 38 s, then judged)",
     ["judge", "bouncing-ball", CSV], Generated("(a 64 MB hole: NUL bytes)", _sparse(64 * 10**6)), ("'bad.csv'", "NUL byte")),
    ("judge-sparse-2GB", "a 2 GB sparse file (before: read whole: 2.23 GiB)", ["judge", "bouncing-ball", CSV],
     Generated("(a 2 GB hole: NUL bytes)", _sparse(2 * 10**9)), ("'bad.csv'", "larger than 256 MiB")),
    ("judge-t-1e300", "times scaled by 1e300 (before: an OverflowError traceback)", ["judge", "bouncing-ball", CSV],
     _ball_csv(lambda f: f.assign(t=f["t"] * 1e300)), ("column 't', row 2 (line 3)", "outside the scene's time")),
    ("judge-n/a", "a cell \"n/a\" (before: \"row 2: np.float64(nan) before the end\")", ["judge", "bouncing-ball", CSV],
     _ball_csv(lambda f: f.astype(object).assign(x2=f["x2"].astype(object).where(f.index != 2, "n/a"))),
     ("column 'x2', row 3 (line 4)", "'n/a' is not a number")),
    ("judge-nan", "a NaN before the last rows (before: \"row 2: np.float64(nan)\", rows counted from 0)",
     ["judge", "bouncing-ball", CSV], _ball_csv(lambda f: f.assign(v2=f["v2"].where(f.index != 2))),
     ("column 'v2', row 3 (line 4): nan before the end",)),
    ("judge-x1-empty", "an all-empty x1 column (before: \"fewer than 2 finite samples\")", ["judge", "bouncing-ball", CSV], _ball_csv(lambda f: f.assign(x1=None)),
     ("column 'x1'", "no finite value")),
    ("judge-fixed-body-moves", "body 1, fixed by the scene, swinging 0.3 m in the file (before: judged \"match\")",
     ["judge", "bouncing-ball", CSV], _ball_csv(lambda f: f.assign(x1=0.3 * (f["t"] * 6.283).map(math.sin),
                                                                   x2=f["x2"] + 0.3 * (f["t"] * 6.283).map(math.sin))),
     ("column 'x1'", "fixes body 1 at x1 = 0 m", "did not run this scene")),
    ("judge-engine-path", "an engine label that is a path (before: wrote x.csv outside --out)",
     ["judge", "bouncing-ball", CSV, "--engine", "/../../../../outside/x", "--out", "o"], _ball_csv(),
     ("--engine '/../../../../outside/x'", "no '/'")),
    ("judge-precision", "a precision the judge does not know", ["judge", "bouncing-ball", CSV, "--precision", "float16"],
     _ball_csv(), ("--precision", "float32")),
]


@contextmanager
def _scratch(content: str | None, name: str = FILE):
    """A scratch working directory holding ``afile``, ``adir/`` and file ``name`` (when there is content)."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, AFILE).write_text("a file\n")
        Path(tmp, ADIR).mkdir()
        os.mkfifo(Path(tmp, APIPE))
        if isinstance(content, Generated):
            content.make(Path(tmp, name))
        elif content is not None:
            Path(tmp, name).write_text(content)
        os.chdir(tmp)
        try:
            yield Path(tmp)
        finally:
            os.chdir(old)


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def run_cli(argv: list[str], content: str | None) -> tuple[int, str]:
    """Run the CLI in-process in a scratch directory; returns (exit code, stderr).

    A refusal writes nothing: the scratch directory must hold what it held before.
    """
    with _scratch(content, next((a for a in argv if a in (CSV, CSVGZ)), FILE)) as tmp:
        before = _tree(tmp)
        done = cli(argv)
        left = _tree(tmp) - before
    if done.code == 2:
        assert not left, f"{argv}: refused, but left {sorted(left)}"
    return done.code, done.err


def message(err: str) -> str:
    """The message: stderr from its ``chatterbench: error:`` line on (a gate file's problems
    follow on their own lines); the last line if there is none."""
    lines = err.strip().splitlines()
    for i, line in enumerate(lines):
        if line.startswith("chatterbench: error:"):
            return "\n".join(lines[i:])
    return lines[-1] if lines else ""


def _engines_named(argv: list[str]) -> list[str]:
    """The known engines a command line names (``--engine``/``--engines``): a case about one skips where it is absent."""
    from chatterbench.engines.registry import ENGINE_NAMES

    named = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a in ("--engine", "--engines")]
    return [e for value in named for e in value.split(",") if e in ENGINE_NAMES]


# case id -> (exit code, stderr) of its run in test_bad_input_is_refused, which checked that no engine ran: the doc
# (markdown) shows these runs where this process made them, or where another worker of this test session left them
# (``_published``), and runs the others itself
_REFUSED: dict[str, tuple[int, str]] = {}


def _engines_tests():
    """``tests/engines/test_plugin_faults.py`` as a module: its plugin cases' runs (``shared_outcomes``)."""
    folder = str(Path(__file__).resolve().parent / "engines")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    import test_plugin_faults

    return test_plugin_faults


def _published(folder: Path | None, index: int) -> tuple[int, str] | None:
    """The run of ``CASES[index]`` that a worker of this test session left in ``folder`` (None: none there)."""
    path = folder / "bad-inputs" / f"{index}.json" if folder is not None else None
    return tuple(json.loads(path.read_text())) if path is not None and path.exists() else None


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_refused(case, engine_runs, tmp_path_factory):
    _, _, argv, content, words = case
    needs_engine(*_engines_named(argv))
    code, err = _REFUSED[case[0]] = run_cli(argv, content)
    folder = session_folder(tmp_path_factory)
    if folder is not None:  # for the doc check of another worker (test_doc_is_current): the run as it was made here
        (folder / "bad-inputs").mkdir(exist_ok=True)
        path = folder / "bad-inputs" / f"{CASES.index(case)}.json"
        path.with_suffix(".tmp").write_text(json.dumps([code, err]))
        path.with_suffix(".tmp").replace(path)
    assert code == 2, (code, err)
    assert engine_runs() == [], "issue 25: every refusal before any engine runs"
    assert "Traceback" not in err, err
    msg = message(err)
    assert "error:" in msg, err
    for word in words:
        assert word in msg, (word, msg)
    # issue 25: no control character reaches the terminal, no word of more than 120 characters is echoed whole
    assert not [c for c in msg if (c < " " and c != "\n") or "\x7f" <= c <= "\x9f"], repr(msg)
    assert max(map(len, msg.split())) < 200, msg[:300]


def test_case_ids_are_unique():
    ids = [c[0] for c in CASES]
    assert len(ids) == len(set(ids))


def test_doc_is_current(tmp_path_factory):
    # docs/bad-inputs.md is this table's output; regenerate with the command in the docstring. It is written where
    # every built-in engine is installed and no plugin is (.ci/run): the messages list the engines there are
    from chatterbench.engines.registry import BUILT_IN, ENGINE_NAMES

    needs_engine(*(row.name for row in BUILT_IN))
    plugins = sorted(set(ENGINE_NAMES) - {row.name for row in BUILT_IN})
    if plugins:
        pytest.skip(f"engine plugins installed ({', '.join(plugins)}): docs/bad-inputs.md lists the built-in engines")
    doc = Path(__file__).resolve().parents[1] / "docs" / "bad-inputs.md"
    shared = session_folder(tmp_path_factory)  # the runs other workers made (pytest-xdist)
    assert doc.read_text() == markdown(shared), "docs/bad-inputs.md is stale: python3 tests/test_bad_inputs.py > docs/bad-inputs.md"


# -- the one-line promise, where argparse, a typed newline or PyBullet's import could break it --
@pytest.mark.parametrize("argv", [["run", "feigin-pair", "--dt", "0"], ["run", "feigin-pair", "--chatter", "full"],
                                  ["bogus"], ["run"]])
def test_argparse_refusals_are_one_line(argv):
    code, err = run_cli(argv, None)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("chatterbench: error: "), err


@pytest.mark.parametrize("argv,content", ids=["file", "set"], argvalues=[
    (["run", FILE], '"rest\\nitution" = 0.5\n' + GOOD_FILE),
    (["run", "feigin-pair", "--set", "rest\nitution=0.5"], None),
])
def test_newline_in_a_key_stays_one_line(argv, content):
    code, err = run_cli(argv, content)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("chatterbench: error: "), err
    assert "rest\\nitution" in err  # shown escaped


def test_bench_of_warp_without_its_extra_is_refused():
    # before: "not measured", exit 0; the extra is hidden the way Python hides a module (sys.modules[name] = None)
    code = ("import sys; sys.modules['mujoco_warp'] = None\n"
            "from chatterbench.comparisons.cli.main import main; sys.exit(main(['bench', 'sweep', '--only', 'warp']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("chatterbench: error: --only warp: nothing to time") and proc.stderr.count("\n") == 1


def test_pybullet_refusal_is_one_line_in_a_process():
    # importing pybullet writes "pybullet build time: ..." from C; the adapter silences it
    proc = cli_process("run", "feigin-pair", "--engine", "pybullet", "--set", "pybullet.dt=-1", timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("chatterbench: error: "), proc.stderr


# -- the doc ------------------------------------------------------------------------------------
def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", "<br>")


def describe_file(content: str) -> str:
    """Short form of a case's file: the lines changed from GOOD_FILE, or the whole content."""
    if isinstance(content, Generated):
        return str(content)
    good, lines = GOOD_FILE.splitlines(), content.splitlines()
    if len(set(good) & set(lines)) >= 5:
        added = [ln for ln in lines if ln not in good]
        removed = [ln for ln in good if ln not in lines]
        shown = "; ".join([*(f"+ {ln}" for ln in added), *(f"- {ln}" for ln in removed)]) or "(the valid scene as it is)"
    else:
        shown = repr(content) if content else "(empty file)"
    return shown if len(shown) <= 200 else f"{shown[:120]}... ({len(content)} characters)"


def markdown(shared: Path | None = None) -> str:
    """docs/bad-inputs.md: every case with the message the CLI prints for it now (the runs this process made, or that
    a worker of this test session left in ``shared``, read instead of made again)."""
    out = [
        "# Bad inputs and what `chatterbench` says",
        "",
        "Generated by `python3 tests/test_bad_inputs.py > docs/bad-inputs.md` from the cases of",
        "`tests/test_bad_inputs.py`, which checks each one: exit code 2, no traceback, a message that",
        "names the field. A file case runs on `bad.toml`: either the content shown, or a valid two-mass",
        "scene (`GOOD_FILE` in the test module) with the lines shown added (+) or removed (-). Messages from",
        "argparse (`--dt`, `--chatter`, `--engine`) name the subcommand and point to its `--help`. The scratch",
        "directory also holds `afile`, `adir/` and a named pipe `apipe`. Every refusal comes before any engine runs (checked).",
        "",
        "| case | what is wrong | command | `bad.toml` or `bad.csv` | message (exit code) |",
        "|---|---|---|---|---|",
    ]
    for index, (cid, what, argv, content, _) in enumerate(CASES):
        command = "chatterbench " + " ".join(a if a and " " not in a else repr(a) for a in argv)
        shown = "" if content is None else f"`{_cell(describe_file(content))}`"
        code, err = _REFUSED.get(cid) or _published(shared, index) or run_cli(argv, content)
        out.append(f"| `{cid}` | {_cell(what)} | `{_cell(command)}` | {shown} | {_cell(message(err))} ({code}) |")
    import test_bad_outputs as outputs  # its scratch directory holds a pipe, a broken link, ...

    out += ["", "## Output destinations", "",
            "From `tests/test_bad_outputs.py`: every output option given a place it cannot write, refused",
            "before any work. Its scratch directory holds `afile`, `adir/`, a named pipe `apipe`, a broken link",
            "`alink`, and two sweep output directories with a link inside: `linkedrows/rows -> ../elsewhere` and",
            "`linkedlock/.lock -> ../victim`; the permission cases (`rodir/`, `rofile`) are left out here, their",
            "message depends on the user (root writes through them).", "",
            "| case | what is wrong | command | file | message (exit code) |", "|---|---|---|---|---|"]
    for cid, what, argv, content, _ in outputs.CASES:
        if cid in outputs.PERMISSION:
            continue
        command = "chatterbench " + " ".join(a if a and " " not in a else repr(a) for a in argv)
        shown = "" if content is None else f"`{_cell(describe_file(content))}`"
        got = outputs.run_cli(argv, content)
        out.append(f"| `{cid}` | {_cell(what)} | `{_cell(command)}` | {shown} | {_cell(message(got.stderr))} ({got.code}) |")
    import test_hostile_cases as hostile  # gate outputs and baselines, interruptions, planted links, guide sections

    out += ["", "## Gate outputs, baselines, interruptions, links and guide sections", "",
            "From `tests/test_hostile_cases.py`: each case prepares its scratch directory (a one-check gate file",
            "`gate.toml`, a named pipe `apipe`, a folder `elsewhere/` outside every output, and what the case says), runs",
            "the command and checks the disk after; an interrupted case gets a real SIGINT or SIGTERM from its own",
            "process right after the function named. The message column holds the command's own lines about it and",
            "what was on disk after. (The full-disk case needs root to mount a tmpfs: tested, not shown.)", "",
            "| case | what is wrong | command | what it says and leaves (exit code) |", "|---|---|---|---|",
            *hostile.markdown_rows(shared)]
    out += plugin_rows(shared)
    out += [
        "",
        "Every message is one stderr line: argparse's refusals too (no usage line), a newline typed into",
        "a key is shown as `\\n`, and PyBullet's import banner (`pybullet build time: ...`) is silenced",
        "(`tests/test_bad_inputs.py` checks each). Gate files are the one exception by design: a refused",
        "gate file lists every problem, one per line.",
    ]
    import test_round_five as round_five  # issue 45, Why 8-12

    out += round_five.markdown_rows(shared)
    out += round_five_rows(shared)  # issue 45's security cases: the file's last section
    return "\n".join(out) + "\n"


def round_five_rows(shared: Path | None = None) -> list[str]:
    """The doc's section of issue 45's cases (``tests/test_hostile_round_five.py``), last in the file."""
    import test_hostile_round_five as round_five

    return ["", "## Round five: links, CI logs, pages, device targets", "",
            "From `tests/test_hostile_round_five.py` (issue 45), run as the section above runs its cases: a link in an",
            "input folder (`report --tune DIR`, `--sweep DIR`) is refused by name and nothing it points to reaches a page;",
            "every name a gate prints or writes to `$GITHUB_STEP_SUMMARY` passes one encoder (`pipeline/inert_text.py`),",
            "so none starts a line, a workflow command (`::warning`), a heading or a table row; a guide section keeps no",
            "`style`, `class` or `id`; the Markdown outputs escape every name from an input; an output that is a link,",
            "a pipe or a device is never renamed over (`/dev/stdout` and `/dev/stderr` are written through). `INJ` below",
            "stands for the text `x\\n::warning title=INJ::injected\\n## INJ fake PASS\\n##[warning]INJ legacy\\n| INJ | row |`.",
            "", "| case | what is wrong | command | what it says and leaves (exit code) |", "|---|---|---|---|",
            *round_five.markdown_rows(shared)]


def plugin_rows(shared: Path | None = None) -> list[str]:
    """The doc's section of engine plugins and engines' own child processes (``tests/engines/plugin_cases.py``): their
    runs made once per test session (``test_plugin_faults.shared_outcomes``)."""
    outcomes = _engines_tests().shared_outcomes(shared)
    import plugin_cases as plugins

    out = ["", "## Engine plugins and engines' own processes", "",
           "From `tests/engines/plugin_cases.py` (checked by `tests/engines/test_plugin_faults.py`): every command runs",
           "in its own process with all of that module's test plugins installed at once (`cbtest-NAME`: broken ones, and",
           "`line`, the plugin page's engine (docs/how-to/plugin.md) with a `fault` setting), and, for Siconos, a python that answers the probe and",
           "then misbehaves (`CHATTERBENCH_SICONOS_PYTHON`). A broken plugin is one line only where it is named; a",
           "fault inside a run is that run's status, and the engines beside it are judged as ever.", "",
           "| case | what is wrong | command | what chatterbench says (exit code) |", "|---|---|---|---|"]
    for case in plugins.CASES:
        done = outcomes[case.id]
        env = "".join(f"{k}={v} " for k, v in case.env.items())
        command = env + "chatterbench " + " ".join(case.argv)
        out.append(f"| `{case.id}` | {_cell(case.what)} | `{_cell(command)}` | "
                   f"{_cell(plugins.said(case, done))} ({done.returncode}) |")
    return out


if __name__ == "__main__":
    sys.stdout.write(markdown())
