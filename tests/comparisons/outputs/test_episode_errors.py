"""The per-episode error figure draws the judge's relative errors, each against its tolerance band."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from chatterbench.comparisons import compare
from chatterbench.comparisons.outputs.episode_errors import CLIP, PANELS, episode_errors_figure
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.engines.registry import make_settings, run_engine
from chatterbench.reference import load_scene

# two visits to a wall, the first with an exit (Zeno points 1.64 and 5.37 s, exit at pi)
SCENE = ("feigin-pair", ["duration=6"])


@pytest.fixture(scope="module")
def solution():
    return solve(load_scene(*SCENE))


def _points(ax, gid):
    found = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    return (np.concatenate([ln.get_xdata() for ln in found]), np.concatenate([ln.get_ydata() for ln in found])) \
        if found else (np.empty(0), np.empty(0))


def _pybullet(solution, restitution_factor=1.0):
    """PyBullet judged against the scene; run with R x ``restitution_factor`` (1: the right R)."""
    scene = dataclasses.replace(solution.scene, restitution=solution.scene.restitution * restitution_factor)
    traj = run_engine("pybullet", scene, make_settings("pybullet", 1e-4))
    return compare(solution.scene, engines=("pybullet",), trajectories={"pybullet": traj}, solution=solution)


def test_every_episode_error_is_drawn_at_its_value_inside_the_band(solution):
    c = _pybullet(solution)
    fig = episode_errors_figure(c)
    assert [ax.get_gid() for ax in fig.axes] == [p[0] for p in PANELS]
    table = c.table
    for ax, (column, field, *_) in zip(fig.axes, PANELS):
        x, y = _points(ax, f"points:{column}:pybullet")
        want = table[column].dropna()
        # one point per measured episode, at the judge's number, in the visit's place
        np.testing.assert_array_equal(y, want.to_numpy())
        np.testing.assert_array_equal(x, np.arange(1, len(table) + 1)[table[column].notna().to_numpy()])
        tol = getattr(c.tolerances, field)
        (band,) = [p for p in ax.patches if p.get_gid() == f"band:{column}"]
        assert band.get_extents().height > 0
        assert (np.abs(y) <= tol).all()  # PyBullet with the scene's R matches: every point inside its band
    assert len(_points(fig.axes[1], "points:exit_error_rel:pybullet")[1]) == 1  # one exit: the second visit runs on


def test_a_wrong_restitution_puts_the_points_outside_the_band(solution):
    # R x 1.1: each resolved impact rebounds 10% too fast, twice the 5% tolerance
    c = _pybullet(solution, 1.1)
    ax = episode_errors_figure(c).axes[2]
    _, y = _points(ax, "points:restitution_error:pybullet")
    assert len(y) == 2 and (np.abs(y - 0.1) < 0.02).all()  # 0.02: the ladder's forcing bends a rebound by ~1%
    assert (np.abs(y) > c.tolerances.restitution).all()


def test_the_ball_has_no_exit_and_its_panel_says_why():
    c = compare(load_scene("bouncing-ball", ["duration=1.6"]), engines=("pybullet",), dt=1e-3)
    exit_ax = episode_errors_figure(c).axes[1]
    assert not len(_points(exit_ax, "points:exit_error_rel:pybullet")[1])
    assert any(t.get_text().startswith("no exit measured: no sliding stretch of the reference ends") for t in exit_ax.texts)


@pytest.mark.slow
def test_far_and_unmeasured_episodes_say_so():
    # MuJoCo on the impact damper at its default settings misses the first sliding stretches and
    # later sticks most of a chatter duration late: past CLIP tolerances, drawn on the edge
    c = compare(load_scene("impact-damper", ["duration=2.5"]), engines=("mujoco",), dt=1e-4)
    ax = episode_errors_figure(c).axes[0]
    table = c.table[c.table["wall"] != ""]
    far = table[table["stick_error_rel"].abs() > CLIP * c.tolerances.stick]
    missed = table[table["verdict"] == "missed"]
    assert len(far) and len(missed)
    _, y = _points(ax, "clipped:stick_error_rel:mujoco")
    assert len(y) == len(far) and np.allclose(np.abs(y), 0.97 * ax.get_ylim()[1])
    assert {f"{v:+.3g}" for v in far["stick_error_rel"]} <= {t.get_text() for t in ax.texts}
    x, _ = _points(ax, "unmeasured:stick_error_rel:mujoco")
    assert len(x) == len(missed) and [t.get_text() for t in ax.texts].count("missed") == len(missed)
