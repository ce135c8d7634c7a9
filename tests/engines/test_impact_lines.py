"""The exported scripts' impact printer writes the run's samples only when run as a script with a file.

Found by the suite: the module's doctest exec'd the printer under pytest, whose ``sys.argv[1]`` is
``-q``, and left a 63 kB file named ``-q`` in the working folder.
"""

from __future__ import annotations

import subprocess
import sys

from chatterbench.engines.impact_lines import record_lines, report_lines, setup_lines


def _ball_script() -> str:
    """A ball dropped from 1 m that bounces once with R = 0.5 on a floor at 0 (1 ms samples, 0.9 s)."""
    return "\n".join([*setup_lines({"lower": 0.0}, 0.5, 0.0, 0.0, 1e-3, 900), "for k in range(STEPS + 1):",
                      "    t = T0 + k * DT; v1 = (2 * 9.81) ** 0.5; t1 = v1 / 9.81",
                      "    y = 1 - 9.81 * t * t / 2 if t < t1 else 0.5 * v1 * (t - t1) - 9.81 * (t - t1) ** 2 / 2",
                      "    vy = -9.81 * t if t < t1 else 0.5 * v1 - 9.81 * (t - t1)", "    a = -9.81; x1 = 0.0",
                      *record_lines("    "), '    forces["lower"].append(0.0)', *report_lines()])


def test_exec_of_the_printer_writes_no_file_whatever_argv_holds(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", ["pytest", "-q"])
    exec(_ball_script(), {})  # noqa: S102  as a doctest or a user's notebook runs it
    assert list(tmp_path.iterdir()) == []


def test_the_script_run_with_a_file_writes_the_samples_the_judge_reads(tmp_path):
    script = tmp_path / "ball.py"
    script.write_text(_ball_script())
    done = subprocess.run([sys.executable, str(script), str(tmp_path / "run.csv")], capture_output=True, text=True,
                          check=True)
    assert "impact t=0.451524" in done.stdout
    lines = (tmp_path / "run.csv").read_text().splitlines()
    assert lines[0] == "t,x1,x2,v1,v2,force_lower" and len(lines) == 902
