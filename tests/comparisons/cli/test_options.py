"""One command line: the same option names for the same things, a default in every help, one set of column names."""

from __future__ import annotations

import argparse

import pytest

from chatterbench.comparisons.cli import compare as compare_cli
from chatterbench.comparisons.cli import tune as tune_cli
from chatterbench.comparisons.cli.main import SUBCOMMANDS, build_parser, main
from chatterbench.comparisons.outputs.report import SUMMARY_COLUMNS as REPORT_COLUMNS
from chatterbench.comparisons.pipeline.summary import ROW_COLUMNS
from chatterbench.comparisons.studies.tune.rows import TUNE_COLUMNS
from chatterbench.comparisons.studies.tune.checks import RATIO_COLUMNS, STRIKE_COLUMNS
from chatterbench.comparisons.studies.tune.search import SEARCH_COLUMNS

# what each shared option means, and the subcommands that take it
SHARED = {"--engines": "engines", "--dt": "timestep", "--set": "override", "--tolerance": "tolerance", "--out": "write",
          "--timeout": "wall-clock limit", "--max-steps": "steps", "--max-memory": "memory"}


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_every_subcommand_is_registered():
    assert set(_subparsers()) == {"scenes", "engines", "run", "compare", "judge", "report", "gate", "platemap", "tune",
                                  "atlas", "calibrate", "sweep", "chart", "bench"}
    assert len(SUBCOMMANDS) == 14


@pytest.mark.parametrize("name", sorted(_subparsers()))
def test_every_option_says_its_default(name):
    sub = _subparsers()[name]
    formatter = sub.formatter_class(prog=sub.prog)
    for action in sub._actions:
        if not action.option_strings or action.dest == "help":
            continue
        text = formatter._get_help_string(action) or ""
        assert action.help and ("default" in text or action.required), f"{name} {action.option_strings}: {text!r}"


@pytest.mark.parametrize("option, meaning", SHARED.items())
def test_shared_options_have_one_name_and_one_meaning(option, meaning):
    takers = {n: p for n, p in _subparsers().items() if option in p._option_string_actions}
    assert len(takers) >= 3, takers.keys()  # used in several subcommands ...
    for name, p in takers.items():  # ... and meaning the same thing in each
        action = p._option_string_actions[option]
        assert meaning in (action.help or "") or (option == "--out" and action.metavar == "DIR"), (name, option)


def test_no_subcommand_spells_the_engines_option_another_way():
    for name, p in _subparsers().items():
        singular = p._option_string_actions.get("--engine")
        if singular is not None:  # an alias of --engines, never its own option
            assert "--engines" in singular.option_strings, name


def test_compare_report_tune_and_sweep_print_the_same_column_names():
    summary = set(ROW_COLUMNS)
    assert set(compare_cli.SUMMARY_SHOW) - {"engine"} <= summary
    # the report's errors are signed: each X_worst is the gate's X_max with its sign (summary.SIGNED_COLUMNS)
    from chatterbench.comparisons.pipeline.summary import SIGNED_COLUMNS

    assert all(c.replace("_worst", "_max") in summary for c in SIGNED_COLUMNS)
    assert set(REPORT_COLUMNS) <= summary | set(SIGNED_COLUMNS)
    # tune's own: the candidate, the checks it failed and their ratios to the tolerances, its cost in steps
    own = {"stage", "settings", "failed", *RATIO_COLUMNS, "steps_per_sim_s", "cost_repeats", "n_non_default",
           *SEARCH_COLUMNS, *STRIKE_COLUMNS,  # the search's (level, robust, failing neighbours); R under the scene's forces
           # the ladder points a run passes at, is robust at, its margins there, and those it was not judged at
           "passes", "robust_at", "margins", "unjudged",
           # at each point passed: the check that set its margin and its rest after the stick (open share, onsets/s)
           "limits", "rests",
           "phase"}  # a band run's start, phase x dt later (studies/phases.py): the run's own, as dt is
    assert set(TUNE_COLUMNS) - own <= summary
    assert set(tune_cli.SHOW) - own <= summary
    # the episode table names its errors as the judge does
    from chatterbench.comparisons.pipeline.compare import COLUMNS

    assert set(compare_cli.EPISODE_SHOW) <= set(COLUMNS)


def test_tune_refuses_an_engine_given_twice(capsys):
    # tune takes several engines (one frontier each: tests/comparisons/studies/test_tune_frontier.py), each once
    assert main(["tune", "bouncing-ball", "--engines", "pybullet,pybullet", "--tolerance", "0.05"]) == 2
    assert "more than once" in capsys.readouterr().err


def test_a_refusal_loads_no_drawing_code():
    # matplotlib takes 0.7 s to import: the drawing modules load only when a command draws, so a
    # refused runaway input answers at once (before: every command imported them at start)
    import subprocess
    import sys

    code = ("import sys\nfrom chatterbench.comparisons.cli.main import main\n"
            "assert main(['run', 'feigin-pair', '--engine', 'mujoco', '--dt', '1e-7']) == 2\n"
            "assert main(['compare', 'feigin-pair', '--set', 'duration=1e6']) == 2\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('matplotlib', 'mujoco', 'pybullet')))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    loaded = proc.stdout.strip()
    assert "matplotlib" not in loaded, loaded
