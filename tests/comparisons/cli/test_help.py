"""``--help`` loads only what it describes: no pandas, numba, matplotlib or engine (issue 33: every help under 1 s).

Before: every ``--help`` took 3-4 s (1.0 s on this machine, idle), because the command line
imported every subcommand and ``chatterbench.reference`` imported the whole reference (pandas,
numba). The time itself is measured by ``chatterbench bench help`` (a benchmark, never a timed
test); here, in a fresh process that shows every help in turn, the modules each one loads.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from chatterbench.comparisons.cli.commands import COMMANDS
from chatterbench.comparisons.cli.main import build_parser

HEAVY = ("pandas", "numba", "matplotlib", "scipy", "pyarrow", "tqdm", "mujoco", "pybullet", "pydrake",
         "chatterbench.reference.simulate", "chatterbench.comparisons.pipeline.compare")
PROBE = r'''
import contextlib, io, json, sys
from chatterbench.comparisons.cli.main import main
heavy, got = json.loads(sys.argv[2]), []
for words in json.loads(sys.argv[1]):  # modules stay loaded: each help's are those it adds to the ones before
    with contextlib.redirect_stdout(io.StringIO()) as shown:
        try:
            main([*words, "--help"])
        except SystemExit as exc:
            assert exc.code == 0, exc.code
    got.append({"heavy": [m for m in heavy if m in sys.modules], "usage": shown.getvalue().splitlines()[0]})
print(json.dumps(got))
'''
HELPS = [[], *([name] for name in COMMANDS)]  # the top level's, then each subcommand's


@pytest.fixture(scope="module")
def helps() -> dict[str, dict]:
    """What each help of ``HELPS`` printed first and the heavy modules loaded after it, in one fresh process: one help
    after another, so a module one loads is seen after it and every later one (a later help adds none to it)."""
    proc = subprocess.run([sys.executable, "-c", PROBE, json.dumps(HELPS), json.dumps(HEAVY)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return {" ".join(words): got for words, got in zip(HELPS, json.loads(proc.stdout))}


@pytest.mark.parametrize("words", [[], *([name] for name in COMMANDS if name != "judge")],
                         ids=["top", *(name for name in COMMANDS if name != "judge")])
def test_a_help_loads_nothing_heavy(words, helps):
    got = helps[" ".join(words)]
    assert got["usage"].startswith("usage: chatterbench" + "".join(f" {w}" for w in words))
    assert got["heavy"] == [], f"chatterbench {' '.join(words)} --help (or one before it) loaded {got['heavy']}"


def test_the_judges_help_loads_nothing_heavy(helps):
    assert helps["judge"]["heavy"] == []


def test_the_judges_precisions_are_the_judges_own():
    # --precision's choices are written in cli/judge.py so that its help loads no numpy: they must stay the judge's
    from chatterbench.comparisons.cli.judge import PRECISIONS
    from chatterbench.comparisons.pipeline.gap_contact import PRECISIONS as JUDGED

    assert PRECISIONS == tuple(JUDGED)


def test_the_longest_timeout_is_the_sweeps_own():
    # --timeout's upper bound is written in cli/common.py so that parsing it loads no sweep module: it must stay the
    # sweep spec's (a sweep file's ``timeout`` and the command line's --timeout accept the same range)
    from chatterbench.comparisons.cli.common import MAX_TIMEOUT
    from chatterbench.comparisons.studies.sweep.spec import MAX_TIMEOUT as SWEEPS

    assert MAX_TIMEOUT == SWEEPS


def test_the_listing_is_the_table_and_each_subcommand_says_the_same():
    full = build_parser()  # every subcommand registered, as the tests of the options read it
    listed = next(a for a in full._actions if a.__class__.__name__ == "_SubParsersAction")
    assert list(listed.choices) == list(COMMANDS)
    helps = {c.dest: c.help for c in listed._choices_actions}
    assert helps == COMMANDS  # one text per subcommand: the table's, which `chatterbench --help` lists
    listing = " ".join(build_parser([]).format_help().split())  # the top level, no subcommand loaded
    assert all(f"{name} {text}" in listing for name, text in COMMANDS.items())


@pytest.mark.slow
def test_bench_help_times_every_help_against_its_goal():
    from helpers import cli

    done = cli(["bench", "help", "--repeats", "1"])
    assert done.code in (0, 1), done.err  # 1: a help over its goal (the figures are measured, never asserted)
    timed = [" ".join(line.split()[:-2]) for line in done.out.splitlines() if line.strip().startswith("chatterbench ")]
    assert timed == ["chatterbench --help", *(f"chatterbench {name} --help" for name in COMMANDS)], done.out
    goal = [line for line in done.out.splitlines() if line.startswith(("PASS: best_s", "FAIL: best_s"))]
    assert len(goal) == 1 and "(goal <= 1:" in goal[0], done.out
