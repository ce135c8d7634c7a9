"""The per-episode error figure draws the judge's relative errors, each against its tolerance band."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from chatterbench.comparisons import compare
from chatterbench.comparisons.outputs.episode_errors import CLIP, PANELS, episode_errors_figure
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.engines.registry import make_settings, run_engine, settings_for
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
    c = compare(load_scene("bouncing-ball", ["duration=1.6"]), settings=settings_for(("pybullet",), 1e-3))
    exit_ax = episode_errors_figure(c).axes[1]
    assert not len(_points(exit_ax, "points:exit_error_rel:pybullet")[1])
    assert any(t.get_text().startswith("no exit measured: no sliding stretch of the reference ends") for t in exit_ax.texts)


@pytest.mark.slow
def test_far_and_unmeasured_episodes_say_so():
    # MuJoCo on the impact damper at its default settings misses the first sliding stretches and
    # later sticks most of a chatter duration late: past CLIP tolerances, drawn on the edge
    c = compare(load_scene("impact-damper", ["duration=3"]), settings=settings_for(("mujoco",), 1e-4))
    ax = episode_errors_figure(c).axes[0]
    table = c.table[c.table["wall"] != ""]
    far = table[table["stick_error_rel"].abs() > CLIP * c.tolerances.stick]
    missed = table[table["verdict"] == "missed"]
    assert len(far) and len(missed)
    _, y = _points(ax, "clipped:stick_error_rel:mujoco")
    assert len(y) == len(far) and np.allclose(np.abs(y), 0.97 * -ax.get_ylim()[0])  # the values span -limit..limit
    assert {f"{v:+.3g}" for v in far["stick_error_rel"]} <= {t.get_text() for t in ax.texts}
    x, _ = _points(ax, "unmeasured:stick_error_rel:mujoco")
    assert len(x) == len(missed) and [t.get_text() for t in ax.texts].count("missed") == len(missed)


def test_a_missed_episode_is_drawn_outside_the_band_and_labelled():
    # PyBullet with R x 1.5 (0.75) on the ball: it still bounces at 1.6 s where the reference slides (missed)
    solution = solve(load_scene("bouncing-ball", ["duration=1.6"]))
    scene = dataclasses.replace(solution.scene, restitution=solution.scene.restitution * 1.5)
    traj = run_engine("pybullet", scene, make_settings("pybullet", 1e-3))
    c = compare(solution.scene, engines=("pybullet",), trajectories={"pybullet": traj}, solution=solution)
    assert c.table["verdict"].tolist() == ["missed"]
    ax = episode_errors_figure(c).axes[0]
    tol = c.tolerances.stick
    x, y = _points(ax, "unmeasured:stick_error_rel:pybullet")
    # before: a cross at 0, inside the grey band, where a pass is drawn
    assert len(y) == 1 and (np.abs(y) > tol).all()
    (strip,) = [p for p in ax.patches if p.get_gid() == "unmeasured-strip:stick_error_rel"]
    low, high = strip.get_window_extent().y0, strip.get_window_extent().y1
    y_px = ax.transData.transform((x[0], y[0]))[1]
    assert low < y_px < high  # in its own strip, above the panel's values and their band
    (band,) = [p for p in ax.patches if p.get_gid() == "band:stick_error_rel"]
    assert band.get_window_extent().y1 < low
    shown = [(t, lab.get_text()) for t, lab in zip(ax.get_yticks(), ax.get_yticklabels())
             if ax.get_ylim()[0] <= t <= ax.get_ylim()[1]]
    in_strip = [text for t, text in shown if ax.transData.transform((0, t))[1] >= low]
    assert len(shown) > 1 and in_strip == ["not\nmeasured"]  # no error value labels the strip: only its name
    assert "missed" in [t.get_text() for t in ax.texts]


def test_the_not_measured_label_leaves_the_strips_markers_free():
    # PyBullet with R x 1.5 on Feigin's pair misses all 13 visits: a cross per visit in the strip, the
    # first 0.6 visits from the axis. Before: the strip's "not measured" label was drawn over the first cross.
    solution = solve(load_scene("feigin-pair"))
    scene = dataclasses.replace(solution.scene, restitution=solution.scene.restitution * 1.5)
    traj = run_engine("pybullet", scene, make_settings("pybullet", 1e-3))
    c = compare(solution.scene, engines=("pybullet",), trajectories={"pybullet": traj}, solution=solution)
    fig = episode_errors_figure(c)
    fig.canvas.draw()
    ax = fig.axes[0]
    (label,) = [t for t in [*ax.texts, *ax.get_yticklabels()] if " ".join(t.get_text().split()) == "not measured"]
    box = label.get_window_extent().expanded(1.0, 1.0)
    x, y = _points(ax, "unmeasured:stick_error_rel:pybullet")
    assert len(x) == 13
    half = 7 * fig.dpi / 72 / 2  # the crosses' half size [px]
    for px, py in ax.transData.transform(np.column_stack([x, y])):
        assert px + half < box.x0 or px - half > box.x1 or py + half < box.y0 or py - half > box.y1, (px, box)
