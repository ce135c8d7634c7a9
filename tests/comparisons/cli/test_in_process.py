"""``chatterbench``'s ``main`` called in a process that goes on (a test, a notebook): a command's ``--timeout`` holds its
own runs and is gone after it.

Before: ``compare ... --timeout 2`` called in-process left every later engine run of that process limited to 2 s, so
a Siconos run of feigin-pair in a later test of the same pytest worker came back ``timeout`` on a loaded machine.
"""

from __future__ import annotations

from chatterbench.comparisons.cli.main import main
from chatterbench.engines.isolate import RUN_LIMIT, run_limit


def test_a_commands_timeout_is_not_left_behind_for_the_next_runs(capsys):
    assert run_limit() == RUN_LIMIT
    assert main(["compare", "bouncing-ball", "--engines", "mujoco", "--dt", "1e-3", "--timeout", "2", "--no-figures"]) == 0
    assert "match" in capsys.readouterr().out  # the command ran, under its limit
    assert run_limit() == RUN_LIMIT  # and its limit went with it
    assert main(["compare", "bouncing-ball", "--engines", "nonsense", "--timeout", "3"]) == 2  # refused: still restored
    assert run_limit() == RUN_LIMIT
