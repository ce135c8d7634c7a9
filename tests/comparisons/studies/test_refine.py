"""Adaptive maps: the cells a sweep splits, the fine map they stand for, resumed and drawn at their size.

The cell logic is checked on landscapes with a known boundary (a line across the map); the
sweeps are real, on the bouncing ball's first impact (dt = 1e-3 .. 1e-2: MuJoCo goes
through the floor at the coarse steps, not at the fine ones), where identical inputs give
bit-identical rows.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import PolyCollection

from chatterbench.comparisons.outputs.stability_map import stability_map_figure
from chatterbench.comparisons.outputs.sweep_data import VERDICT_COLOURS
from chatterbench.comparisons.studies.sweep import Sweep, load_sweep, read_rows, run_sweep
from chatterbench.comparisons.studies.sweep.adaptive import Levels, agreement, fine_sweep
from chatterbench.comparisons.studies.sweep.dataset import part_paths
from chatterbench.comparisons.studies.sweep.refine import fill, lattice, split_points

KEY = ["point_id", "engine"]
COMPARED = KEY + ["verdict", "status", "refine_level", "n_episodes", "exit_error_max", "stick_error_max"]

SPEC = """
scene = "bouncing-ball"
engines = ["mujoco"]
timeout = 60

[set]
duration = 0.6

[grid]
dt = [1e-3, 1e-2]
restitution = [0.2, 0.5, 0.8]

[refine]
axes = ["dt", "restitution"]
depth = 2
"""


def _adaptive(truth, coarse_n: int, depth: int):
    """An adaptive map of the landscape ``truth(i, j)`` (fine indices): (points run, fine map filled from them)."""
    step = 2 ** depth
    known = {(i * step, j * step): truth(i * step, j * step) for i in range(coarse_n) for j in range(coarse_n)}
    added = {c: 0 for c in known}
    inferred: dict = {}
    for level in range(1, depth + 1):
        run, guessed = split_points({**inferred, **known}, level, depth)
        inferred.update(guessed)
        known.update({c: truth(*c) for c in run})
        added.update({c: level for c in run})
    n = (coarse_n - 1) * step + 1
    return known, fill({c: (added[c], lab) for c, lab in known.items()}, (n, n), depth)


def test_a_straight_boundary_is_found_exactly_with_a_fraction_of_the_fine_points():
    # verdict "late" right of the line i + 0.4 j = 20 on a 5 x 5 grid refined 3 times (33 x 33 fine)
    truth = lambda i, j: "late" if i + 0.4 * j > 20 else "match"  # noqa: E731
    known, filled = _adaptive(truth, 5, 3)
    exact = np.array([[truth(i, j) for j in range(33)] for i in range(33)], dtype=object)
    assert (filled == exact).all()  # a boundary that crosses each cell once is never missed
    assert len(known) < 0.3 * 33 * 33, len(known)
    # a map that was not refined is caught: the coarse grid alone gets the cells along the line wrong
    coarse = fill({c: (0, truth(*c)) for c in known if c[0] % 8 == 0 and c[1] % 8 == 0}, (33, 33), 3)
    assert 0 < (coarse != exact).sum() < 0.1 * 33 * 33


def test_an_island_inside_one_coarse_cell_is_missed_as_documented():
    # the promise is about cells whose corners differ: a feature between four equal corners stays unseen
    truth = lambda i, j: "spurious" if (i, j) == (2, 2) else "match"  # noqa: E731
    known, filled = _adaptive(truth, 3, 2)
    assert len(known) == 9 and filled[2, 2] == "match"


def test_lattice_halves_each_axis_in_its_own_scale():
    dts = lattice((1e-4, 1e-2), 2)
    assert len(dts) == 5 and dts[0] == 1e-4 and dts[-1] == 1e-2
    assert dts[2] == pytest.approx(1e-3, rel=1e-11)  # geometric mean: 12 significant digits kept
    assert lattice((0.2, 0.5, 0.8), 1) == (0.2, 0.35, 0.5, 0.65, 0.8)  # arithmetic on a linear axis
    assert len(lattice(tuple(float(k) for k in range(5)), 6)) == 4 * 64 + 1


def test_refine_table_reads_back_and_changes_the_fingerprint(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    sweep = load_sweep(spec)
    back = tmp_path / "back.toml"
    back.write_text(sweep.to_toml())
    assert load_sweep(back).identity() == sweep.identity()
    plain = Sweep(scene="bouncing-ball", fixed={"duration": 0.6}, grid=dict(sweep.grid), timeout=60)
    assert "refine" not in plain.identity() and plain.fingerprint() != sweep.fingerprint()
    fine = fine_sweep(sweep)
    assert fine.refine is None and len(fine.grid["dt"]) == 5 and len(fine.grid["restitution"]) == 9


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("refine")
    (tmp / "spec.toml").write_text(SPEC)
    sweep = load_sweep(tmp / "spec.toml")
    adaptive = run_sweep(sweep, tmp / "adaptive", workers=2, progress=False)
    fine = run_sweep(fine_sweep(sweep), tmp / "fine", workers=2, progress=False)
    return sweep, adaptive, fine, tmp


@pytest.mark.slow  # the fixture's two sweeps: about 10 s
def test_adaptive_sweep_gives_the_fine_grids_verdicts_with_fewer_runs(sweeps):
    sweep, adaptive, fine, _ = sweeps
    assert len(fine) == 5 * 9
    table = agreement(sweep, adaptive, fine).set_index("engine")
    # MuJoCo's penetration boundary runs across the map: refined there only
    assert adaptive.attrs["sweep"]["levels"][0] == 6 and len(adaptive) < 0.5 * len(fine)
    assert adaptive["refine_level"].max() == 2
    assert (table["agreement"] == 1.0).all(), table  # every fine cell's verdict, on this landscape
    # the same points in both sweeps are the same runs: identical rows
    both = adaptive.merge(fine, on=KEY, suffixes=("", "_fine"))
    assert len(both) == len(adaptive) and (both["verdict"] == both["verdict_fine"]).all()
    # a wrong map is caught: the adaptive verdicts shifted by one run
    wrong = adaptive.assign(verdict=np.roll(adaptive["verdict"].to_numpy(), 1))
    assert (agreement(sweep, wrong, fine)["agreement"] < 1.0).any()


@pytest.mark.slow
def test_refined_cells_are_drawn_at_their_size(sweeps):
    matplotlib.use("Agg")
    _, adaptive, _, _ = sweeps
    fig = stability_map_figure(adaptive, "dt", "restitution", engine="mujoco")
    levels = fig.axes[0].collections
    assert all(isinstance(c, PolyCollection) for c in levels)
    rows = adaptive[adaptive["engine"] == "mujoco"]
    assert [len(c.get_paths()) for c in levels] == rows.groupby("refine_level").size().tolist()
    for level, coll in enumerate(levels):
        widths = [np.ptp(np.log10(p.vertices[:4, 0])) for p in coll.get_paths()]
        heights = [np.ptp(p.vertices[:4, 1]) for p in coll.get_paths()]
        # a level-k cell is 2**-k coarse cells: one decade of dt and 0.3 of R at level 0
        assert np.allclose(widths, 1.0 / 2 ** level) and np.allclose(heights, 0.3 / 2 ** level)
        at = rows[rows["refine_level"] == level]
        want = [matplotlib.colors.to_rgba(VERDICT_COLOURS[v]) for v in at["verdict"]]
        assert sorted(map(tuple, coll.get_facecolors())) == sorted(want)


def _has_level(out: Path, level: int) -> bool:
    try:
        rows = read_rows(out, dedupe=False)
    except Exception:  # a part being renamed into place: look again
        return False
    return "refine_level" in rows and bool((rows["refine_level"] >= level).any())


def _level_1_count(out: Path) -> int:
    return int((read_rows(out, dedupe=False)["refine_level"] == 1).sum())


def _trim_to_inside_level_1(out: Path, level_size: int) -> int:
    """Remove the newest part files until level 1 is started but not finished; its row count then."""
    parts = part_paths(out)  # write order
    while _level_1_count(out) >= level_size or _has_level(out, 2):
        parts.pop().unlink()
    return _level_1_count(out)


@pytest.mark.slow
def test_refined_sweep_killed_mid_level_resumes_to_the_uninterrupted_rows(sweeps, sweep_process):
    start, kill_when = sweep_process
    _, adaptive, _, tmp = sweeps
    out = tmp / "killed"
    # one run a unit, one worker: level 1 takes many parts, so the kill lands inside it
    proc = start(str(tmp / "spec.toml"), "--out", str(out), "--workers", "1", "--batch", "1")
    kill_when(proc, lambda: (out / "rows").is_dir() and _has_level(out, 1), "no level-1 rows")
    level_size = adaptive.attrs["sweep"]["levels"][1]
    # a loaded machine may finish level 1's few runs before the kill lands: then take back the
    # newest parts (one run each) to what a kill one part earlier leaves, inside level 1
    in_level_1 = _trim_to_inside_level_1(out, level_size)
    assert 0 < in_level_1 < level_size, (in_level_1, adaptive.attrs["sweep"]["levels"])
    resumed = start(str(tmp / "spec.toml"), "--out", str(out), "--workers", "2", "--resume")
    _, stderr = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, stderr
    assert "set aside" not in stderr  # every part of later levels is recognised as this sweep's
    raw = read_rows(out, dedupe=False)
    assert not raw.duplicated(KEY).any(), "resume re-ran a finished point"
    got = pd.read_parquet(out / "rows.parquet")[COMPARED].reset_index(drop=True)
    # same inputs, same engines, same levels: the rows agree exactly, in the same order
    pd.testing.assert_frame_equal(got, adaptive[COMPARED].reset_index(drop=True))


@pytest.mark.slow
def test_levels_plan_from_rows_alone(sweeps):
    """Planning level by level from the finished rows gives the runs the sweep made (what a resume relies on)."""
    sweep, adaptive, _, _ = sweeps
    levels = Levels(sweep)
    runs = levels.runs(0, None)
    seen = {r.point_id for r in runs}
    for level in (1, 2):
        runs += levels.runs(level, adaptive, start=len(runs), seen=seen)
    assert [r.point_id for r in runs] == adaptive["point_id"].tolist()
    assert list(itertools.accumulate(adaptive.attrs["sweep"]["levels"]))[-1] == len(runs)


def test_each_engine_refines_on_its_own_verdicts_in_each_slice():
    """Rows written by hand (no engine runs): MuJoCo's verdict changes with R, PyBullet's never."""
    sweep = Sweep(scene="bouncing-ball", engines=("mujoco", "pybullet"), fixed={"duration": 0.6},
                  grid={"dt": (1e-3, 1e-2), "restitution": (0.2, 0.8), "mujoco.w0_dt": (0.03, 0.1)},
                  refine={"axes": ["dt", "restitution"], "depth": 1})
    levels = Levels(sweep)
    runs = levels.runs(0, None)
    # 2 x 2 points in each of MuJoCo's two w0_dt slices; PyBullet's runs do not repeat per w0_dt
    assert [r.engine for r in runs].count("mujoco") == 8 and [r.engine for r in runs].count("pybullet") == 4
    rows = pd.DataFrame([{"point_id": r.point_id, "engine": r.engine,
                          "verdict": "late" if r.engine == "mujoco" and dict(r.params)["restitution"] > 0.5 else "match"}
                         for r in runs])
    more = levels.runs(1, rows, start=len(runs), seen={r.point_id for r in runs})
    # the one coarse cell of each MuJoCo slice is split: centre and the two edges across R (the dt edges agree)
    assert [r.engine for r in more] == ["mujoco"] * 6
    assert sorted({dict(r.params)["restitution"] for r in more}) == [0.5]
    assert {dict(r.params)["mujoco.w0_dt"] for r in more} == {0.03, 0.1}
    assert {r.index for r in more} == set(range(len(runs), len(runs) + 6))


def test_bench_sweep_judges_the_adaptive_map_alone_when_only_it_ran():
    from chatterbench.comparisons.cli.bench import goal_lines

    lines, ok = goal_lines("sweep", {"refine_agreement": 0.969, "refine_speedup": 3.7})  # `--only refine`
    assert ok and len(lines) == 2 and lines[0].startswith("PASS: refine_agreement")
    # a map that gets one fine cell in ten wrong fails, however fast
    assert not goal_lines("sweep", {"refine_agreement": 0.9, "refine_speedup": 3.7})[1]


@pytest.mark.parametrize("table, rows, sides", [
    # passing: timing errors are still the run reproducing the episodes; none and the failures are not
    ({"boundary": "passing"}, [{"verdict": "match"}, {"verdict": "late"}, {"verdict": "none"}, {"verdict": "crashed"}],
     [True, True, False, False]),
    ({"boundary": "match"}, [{"verdict": "match"}, {"verdict": "rebound"}], [True, False]),
    # a metric: at most the threshold or not; a run with no such error (NaN) is a side of its own
    ({"boundary": "exit_error_max", "threshold": 1e-3},
     [{"verdict": "match", "exit_error_max": 2e-4}, {"verdict": "late", "exit_error_max": 4e-3},
      {"verdict": "none", "exit_error_max": float("nan")}], [True, False, "missing"]),
])
def test_boundary_labels_put_each_row_on_its_side(table, rows, sides):
    from chatterbench.comparisons.studies.sweep.refine import boundary_label, make_refine

    refine = make_refine({"axes": ["dt", "restitution"], "depth": 1, **table},
                         {"dt": (1e-3, 1e-2), "restitution": (0.2, 0.8)}, ValueError)
    assert [boundary_label(r, refine) for r in rows] == sides
    # the same rows under the plain verdict boundary: every verdict its own side
    plain = make_refine({"axes": ["dt", "restitution"], "depth": 1}, {"dt": (1e-3, 1e-2), "restitution": (0.2, 0.8)},
                        ValueError)
    assert [boundary_label(r, plain) for r in rows] == [r["verdict"] for r in rows]
