"""``chatterbench judge`` and ``judge_trajectory``: any simulator's samples in a file, known answers both ways."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from chatterbench.comparisons import compare, judge_trajectory, reference_trajectory, trajectory_table
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.pipeline.trajectory_file import CONTACT_FROM_FORCE, CONTACT_FROM_GAP
from chatterbench.engines.registry import make_settings, run_engine

from helpers import solution
from synthetic import SCENES

SCENE = str(SCENES / "two-wall-3to1.toml")
DT = 1e-3


def _times(scene, uneven: bool) -> np.ndarray | None:
    """Even steps, or steps of DT x (0.5 .. 1.5) at random (a variable-step integrator)."""
    if not uneven:
        return None
    steps = DT * np.random.default_rng(7).uniform(0.5, 1.5, int(1.2 * scene.duration / DT))
    t = scene.initial.t + np.concatenate(([0.0], np.cumsum(steps)))
    return t[t <= scene.t_end]


def _exact_table(uneven: bool, forces: bool, scene=None) -> pd.DataFrame:
    ref = solution(SCENE)
    scene = scene or ref.scene
    table = trajectory_table(reference_trajectory(scene, DT, None if scene is not ref.scene else ref.exhaustive,
                                                  times=_times(scene, uneven)))
    return table if forces else table[["t", "x1", "x2", "v1", "v2"]]


@pytest.mark.parametrize("uneven", [False, True])
@pytest.mark.parametrize("forces", [True, False])
def test_the_exact_answer_in_a_file_matches_and_exits_0(tmp_path, capsys, uneven, forces):
    path = tmp_path / "exact.csv"
    _exact_table(uneven, forces).to_csv(path, index=False)
    assert main(["judge", SCENE, str(path), "--engine", "exact"]) == 0
    out = capsys.readouterr().out
    assert (CONTACT_FROM_FORCE if forces else CONTACT_FROM_GAP) in out  # says how contact was taken
    result = judge_trajectory(SCENE, path, engine="exact", solution=solution(SCENE))
    assert len(result.table) == 3 and set(result.table["verdict"]) == {"match"}, result.table


def test_the_wrong_restitution_in_a_file_exits_1(tmp_path, capsys):
    scene = solution(SCENE).scene
    wrong = dataclasses.replace(scene, restitution=scene.restitution * 0.8)
    path = tmp_path / "wrong.parquet"
    _exact_table(False, True, wrong).to_parquet(path)
    assert main(["judge", SCENE, str(path)]) == 1
    assert "match" not in set(judge_trajectory(SCENE, path, solution=solution(SCENE)).table["verdict"])


def test_a_pybullet_run_in_a_file_gets_the_verdicts_compare_gives(tmp_path):
    ref = solution(SCENE)
    traj = run_engine("pybullet", ref.scene, make_settings("pybullet", DT))
    path = tmp_path / "pybullet.csv"
    trajectory_table(traj).to_csv(path, index=False)
    direct = compare(ref.scene, engines=("pybullet",), trajectories={"pybullet": traj}, solution=ref).table
    via_file = judge_trajectory(SCENE, path, engine="pybullet", solution=ref).table
    assert via_file["verdict"].tolist() == direct["verdict"].tolist()
    # CSV keeps 17 significant digits: the same floats, the same errors
    cols = ["t_stick", "t_exit", "stick_error_rel", "exit_error_rel", "restitution_error"]
    pd.testing.assert_frame_equal(via_file[cols], direct[cols], rtol=1e-9, atol=1e-12)


def test_out_writes_what_compare_writes(tmp_path):
    path = tmp_path / "exact.csv"
    _exact_table(False, True).to_csv(path, index=False)
    assert main(["judge", SCENE, str(path), "--engine", "exact", "--out", str(tmp_path / "out"), "--no-figures"]) == 0
    episodes = pd.read_csv(tmp_path / "out" / "episodes.csv")
    assert episodes["verdict"].tolist() == ["match"] * 3 and set(episodes["engine"]) == {"exact"}
    assert (tmp_path / "out" / "events_exact.csv").is_file() and (tmp_path / "out" / "provenance.json").is_file()


@pytest.mark.parametrize("edit, message", [
    (lambda f: f.drop(columns="v2"), "missing column 'v2'"),
    # rows counted as a user counts them (issue 34): the 6th data row, on line 7 of the file (before: "row 5")
    (lambda f: f.assign(t=f["t"].where(f.index != 5, f["t"].iloc[3])), "column 't', row 6 (line 7): 0.003 after 0.004"),
    (lambda f: f.assign(x2=f["x2"].where(f.index != 40, np.nan)), "column 'x2', row 41 (line 42): nan before the end"),
    (lambda f: f.assign(v1=f["v1"].astype(object).where(f.index != 9, "fast")), "column 'v1', row 10 (line 11): 'fast' is"),
    # a cell "n/a" is text, named as such (before: "np.float64(nan) before the end of the run")
    (lambda f: f.assign(v2=f["v2"].astype(object).where(f.index != 7, "n/a")), "column 'v2', row 8 (line 9): 'n/a' is not"),
    (lambda f: f.assign(t=f["t"] * 1e300), "column 't', row 2 (line 3): 1e+297 s is outside the scene's time, 0 to"),
])
def test_bad_files_are_refused_in_one_line_with_exit_2(tmp_path, capsys, edit, message):
    path = tmp_path / "bad.csv"
    edit(_exact_table(False, True)).to_csv(path, index=False)
    assert main(["judge", SCENE, str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_a_run_that_blows_up_at_the_end_is_diverged_not_bad_input():
    table = _exact_table(False, True)
    table.loc[table.index[-100:], ["x2", "v2"]] = np.nan  # the last 0.1 s
    result = judge_trajectory(SCENE, table, solution=solution(SCENE))
    assert result.runs["engine"].status == "diverged"
    assert result.table["verdict"].tolist() == ["match", "match", "diverged"]  # the last visit is still open


def test_the_pytest_fixture_gates_on_a_file(tmp_path):
    # an engine's own CI, in a fresh process: the fixture comes with the installed package (pytest11)
    import subprocess
    import sys

    (tmp_path / "test_engine.py").write_text(f"""
from chatterbench.comparisons import reference_trajectory, trajectory_table
from chatterbench.reference.scene import load_scene

def test_mine(chatter_judge):
    scene = load_scene({SCENE!r})
    chatter_judge(scene, trajectory_table(reference_trajectory(scene, 1e-3)), engine="mine")

def test_wrong(chatter_judge):
    wrong = load_scene({SCENE!r}, ["restitution=0.2"])
    chatter_judge({SCENE!r}, trajectory_table(reference_trajectory(wrong, 1e-3)), engine="wrong")
""")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_engine.py"],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 1 and "1 failed, 1 passed" in proc.stdout, proc.stdout
    assert "wrong on two-wall-3to1: 3 of 3 episodes not in match, none" in proc.stdout


def test_the_pymunk_example_writes_a_file_the_judge_reads_both_ways(tmp_path):
    # examples/judge/pymunk_ball.py, run as a user runs it (its own process: pymunk, numpy, pandas only)
    pytest.importorskip("pymunk")
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).parents[3] / "examples" / "judge" / "pymunk_ball.py"
    ball = SCENES / "ball-07.toml"
    wrong = tmp_path / "ball-05.toml"  # the same ball with R = 0.5, judged as the R = 0.7 scene
    wrong.write_text(ball.read_text().replace("restitution = 0.7", "restitution = 0.5"))
    for scene, want in ((ball, 0), (wrong, 1)):
        out = tmp_path / f"{scene.stem}.csv"
        subprocess.run([sys.executable, str(script), str(out), "--scene", str(scene), "--dt", "1e-3"], check=True,
                       capture_output=True, timeout=120)
        assert main(["judge", str(ball), str(out), "--engine", "pymunk"]) == want
