"""Broken and faulty engine plugins, and a misbehaving Siconos child, each in a real child process: one line or one row.

Every plugin of ``plugin_cases.PLUGINS`` is installed at once (written as pip writes a package,
``plugin_cases.install``), so each command below runs with all of them present: a broken one is
its own one-line error (exit 2) only where it is named, a fault inside a run is that run's
``crashed`` or ``timeout``, and the other engines and commands go on as if none were there.
Before: tracebacks (``TypeError: Can't instantiate abstract class``, ``ModuleNotFoundError``), a
segfault of the command itself (exit 139) for a plugin that crashes on import, a hang past
``--timeout``, ``BrokenProcessPool`` in sweeps (issue 34).
"""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path

import pytest
from shared_runs import made_once, session_folder  # noqa: F401  (session_folder: tests/test_bad_inputs.py's too)

import plugin_cases
from plugin_cases import CASES, ROUND_FIVE, install, outcomes, run_case, said


@functools.cache
def shared_outcomes(folder: Path | None) -> dict[str, subprocess.CompletedProcess]:
    """``plugin_cases.outcomes()``, made once per test session: the worker that comes first runs every case and leaves
    them in ``folder`` (``shared_runs.made_once``); a worker that needs them later, or meanwhile, reads them there."""
    if folder is None:
        return outcomes()
    made = made_once(folder, "plugin-outcomes", lambda: {case: [done.args, done.returncode, done.stdout, done.stderr]
                                                          for case, done in outcomes().items()})
    return {case: subprocess.CompletedProcess(*done) for case, done in made.items()}


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A folder holding every test plugin as an installed package (and the fake Siconos pythons)."""
    return install(tmp_path_factory.mktemp("site-packages"))


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES + ROUND_FIVE, ids=[c.id for c in CASES + ROUND_FIVE])
def test_a_broken_or_faulty_plugin_is_one_line_or_one_row(case, tmp_path_factory):
    # every case run once, with every plugin installed (shared with docs/bad-inputs.md: in this process, or in the
    # worker that ran them first)
    done = shared_outcomes(session_folder(tmp_path_factory))[case.id]
    assert done.returncode == case.code, done.stdout[-2000:] + done.stderr[-2000:]
    assert "Traceback" not in done.stderr + done.stdout, done.stderr[-3000:]
    line = said(case, done)
    assert all(word in line for word in case.words), (case.words, line, done.stderr[-2000:])
    if case.code == 2:  # every error line is one line of its own (``chatterbench engines``: one per broken plugin)
        assert all(ln.startswith("chatterbench: error: ") for ln in done.stderr.strip().splitlines()), done.stderr
    if case.id == "plugin-segfault":  # the engine beside it in the same command: judged as ever
        summary = done.stdout.split("summary:")[1].splitlines()
        header = summary[1].split()
        rows = {r.split()[0]: r.split() for r in summary[2:] if r.strip()}
        # its run complete, and its verdict at its default settings, as alone: it sticks on time, then keeps bouncing
        # at g dt (restitution threshold 0: buzz; gates/default.toml)
        assert rows["pybullet"][header.index("status")] == "ok"
        assert rows["pybullet"][header.index("verdict")] == "buzz"
        assert rows["line"][header.index("status")] == "crashed"
    if case.id == "plugin-version-raises":  # issue 45: both runs judged and shown; the fault a note, not a traceback
        summary = done.stdout.split("summary:")[1].splitlines()
        header = summary[1].split()
        rows = {r.split()[0]: r.split() for r in summary[2:] if r.strip()}
        assert rows["badversion"][header.index("status")] == "ok" and rows["pybullet"][header.index("status")] == "ok"
    if case.id == "plugin-snippet-raises":  # issue 45: the search's files written, the snippet the settings as held
        assert "wrote under tuned: recommended.json, guide.md" in done.stdout, done.stdout[-2000:]


@pytest.mark.slow
def test_other_engines_and_commands_do_not_notice_the_broken_plugins(site, tmp_path):
    # before: with one broken plugin installed, run --export-model failed for every engine
    case = plugin_cases.Case("others", "", ["run", "bouncing-ball", "--engines", "pybullet", "--export-model",
                                            str(tmp_path / "ball.py")], 0, ())
    done = run_case(case, site)
    assert done.returncode == 0 and "written to" in done.stdout, done.stderr[-2000:]
    assert "import pybullet" in (tmp_path / "ball.py").read_text()
    # 2 s: each plugin is loaded in a fork of this command, whose imports are done (milliseconds); only the
    # plugin built to hang (hang_load) waits it out
    listed = run_case(plugin_cases.Case("list", "", ["engines", "--timeout", "2"], 2, ()), site)
    rows = [(ln.split()[0], ln.split()[-1]) for ln in listed.stdout.splitlines()[1:]
            if ln.split() and not ln.split()[0].endswith(":")]  # (engine, status); below the table, the reasons
    assert {("mujoco", "ok"), ("pybullet", "ok"), ("line", "ok"), ("backwards", "ok")} <= set(rows), listed.stdout
    broken = set(plugin_cases.PLUGINS) - set(plugin_cases.LOADING)
    assert {name for name, status in rows if status == "broken"} == broken
    assert len(listed.stderr.strip().splitlines()) == len(broken)  # one line each


@pytest.mark.slow
def test_sweep_and_tune_pools_survive_a_plugin_that_segfaults(site):
    # before: the sweep worker's warm-up ran the plugin unisolated (BrokenProcessPool); tune's pool likewise
    (site / "sweep.toml").write_text('scene = "bouncing-ball"\nengines = ["line", "pybullet"]\ntimeout = 60\n'
                                     '[set]\nduration = 0.6\nline.fault = "segfault"\n[grid]\ndt = [1e-3, 3e-4]\n')
    swept = run_case(plugin_cases.Case("sweep", "", ["sweep", "sweep.toml", "--out", "swept", "--workers", "2"], 0, ()), site)
    assert swept.returncode == 0 and "BrokenProcessPool" not in swept.stderr, swept.stderr[-2000:]
    import pandas as pd

    rows = pd.read_parquet(site / "swept" / "rows.parquet")
    assert sorted(rows[rows.engine == "line"].status) == ["crashed", "crashed"]
    assert set(rows[rows.engine == "pybullet"].status) == {"ok"}
    # tune searches line.fault in ("", "segfault") (the plugin's tuning space): crashing candidates are rows too (its
    # first 4 runs, on 2 workers, are 2 dt values each with fault "" and "segfault": measured in its candidates.csv)
    tuned = run_case(plugin_cases.Case("tune", "", ["tune", "bouncing-ball", "--engines", "line", "--tolerance", "0.1",
                                                    "--max-runs", "4", "--workers", "2"], 1, ()), site)
    assert tuned.returncode in (0, 1) and "Traceback" not in tuned.stderr, tuned.stderr[-2000:]
    assert "fault /segfault" in tuned.stdout, tuned.stdout  # the crashing value was searched
