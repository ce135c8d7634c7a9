"""The time-series chart shows where an engine departs: each engine's sticking and exit, the reference's axis, the zoom."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons import compare
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.outputs.timeseries import MAX_VISITS, engine_episodes, shown_until, timeseries_figure
from chatterbench.reference import load_scene


@pytest.fixture(scope="module")
def feigin():
    # five visits to a wall (Zeno points 1.64, 5.37, 8.51, 11.66, 14.80 s): one more than the main panel shows
    return compare(load_scene("feigin-pair", ["duration=16"]), settings=settings_for(("mujoco", "pybullet"), 1e-4))


@pytest.fixture(scope="module")
def ball():
    # the ball reaches its Zeno point at 1.355 s; MuJoCo's soft contact sticks about 32 ms after it
    return compare(load_scene("bouncing-ball", ["duration=1.6"]), settings=settings_for(("mujoco", "pybullet"), 1e-4))


def _axes(fig):
    return {ax.get_gid(): ax for ax in fig.axes}


def _line(ax, gid):
    found = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    assert len(found) <= 1, gid
    return found[0] if found else None


def test_each_engine_episode_is_marked_where_the_engine_sticks_and_exits(feigin):
    fig = timeseries_figure(feigin)
    run = _axes(fig)["run"]
    t_hi = shown_until(feigin.reference, feigin.scene.t_end)
    assert len(feigin.reference) == MAX_VISITS + 1 and t_hi < feigin.scene.t_end
    assert run.get_xlim()[1] == t_hi and f"first {MAX_VISITS} of {MAX_VISITS + 1} visits" in run.get_title()
    walls = {w: feigin.scene.gap.position(w) for w in feigin.scene.gap.walls}
    for name in ("mujoco", "pybullet"):
        eps = engine_episodes(feigin, name)
        for column, gid in (("t_stick", "stick"), ("t_exit", "exit")):
            want = eps[eps[column] <= t_hi]
            assert len(want) >= 3  # sticks and exits in every visit shown
            line = _line(run, f"{gid}:{name}")
            np.testing.assert_array_equal(line.get_xdata(), want[column].to_numpy())
            # on the engine's own lane, just outside the wall it sticks to, so no marker hides another
            for y, wall in zip(line.get_ydata(), want["wall"]):
                outside = walls[wall] - y if wall == "lower" else y - walls[wall]
                assert 0 < outside < 0.05 * 0.2  # within the axis margin: 5% of the 0.2 m gap


def test_the_zoom_shows_how_late_each_engine_sticks(ball):
    fig = timeseries_figure(ball)
    zoom = _axes(fig)["zoom"]
    zeno = ball.reference["t_stick"].iloc[0]
    lo, hi = zoom.get_xlim()
    for name in ("mujoco", "pybullet"):
        t_stick = engine_episodes(ball, name)["t_stick"].iloc[0]
        assert lo < t_stick < hi and _line(zoom, f"zoom-stick:{name}").get_xdata()[0] == t_stick
        ms = 1e3 * (t_stick - zeno)
        assert any(t.get_text() == f"{name} sticks {ms:+.3g} ms" for t in zoom.texts)
    late = engine_episodes(ball, "mujoco")["t_stick"].iloc[0] - zeno
    assert 0.02 < late < 0.05  # MuJoCo's soft contact: 32 ms late (within the 5% x 0.90 s = 45 ms tolerance)
    # before: the zoom spanned 0.35-1.62 s (a 32 ms delay: 2.5% of it, a few pixels); now it is the last quarter
    # of the chatter and the delay is about a tenth of the window (some 30 px of the zoom at report width)
    assert late / (hi - lo) > 0.08


def test_legends_list_only_what_is_drawn(ball, feigin):
    def labels(fig):
        return [t.get_text() for t in fig.legends[0].get_texts()]

    ball_labels = labels(timeseries_figure(ball))
    # the ball has no plate entry (Feigin's plate needs a force) and never leaves the floor
    assert not [t for t in ball_labels if "plate entry" in t or t in ("reference exit", "engine exits")]
    assert {"reference Zeno point (starts sticking)", "reference sliding (Zeno point on: it never exits)"} <= set(ball_labels)
    feigin_labels = labels(timeseries_figure(feigin))
    assert {"plate entry (Feigin)", "reference exit", "engine exits", "reference sliding (Zeno point to exit)"} <= set(
        feigin_labels)


def test_the_zoom_frames_the_first_real_chatter_not_a_contact_at_rest():
    # spring-pair starts resting on its wall (one "impact" at speed 0 at t = 0): before, the zoom
    # framed that contact and showed nothing with unreadable ticks
    c = compare(load_scene("spring-pair", ["duration=4"]), settings=settings_for(("pybullet",), 1e-4))
    assert c.reference["n_impacts"].iloc[0] == 1
    zoom = _axes(timeseries_figure(c))["zoom"]
    second = c.reference.iloc[1]
    lo, hi = zoom.get_xlim()
    assert "visit 2" in zoom.get_title()
    assert second.t_first_impact < lo < second.t_stick < hi  # the end of visit 2's chatter, its Zeno point inside
    assert hi - lo > 0.1 * second.chatter_duration  # a window of tens of ms, not of microseconds


def test_a_diverged_engine_leaves_the_reference_axis_intact_and_says_so():
    # MuJoCo at w0_dt = 5 (unstable, allowed) blows up at t = 0.9 s and reaches y = -263 m
    c = compare(load_scene("feigin-pair", ["duration=3.5"]), settings=settings_for(("mujoco", "pybullet"), 1e-4, ["mujoco.w0_dt=5", "mujoco.allow_unstable=true"]))
    assert c.runs["mujoco"].status == "diverged" or math.isfinite(c.runs["mujoco"].t_diverged)
    run = _axes(timeseries_figure(c))["run"]
    allowance = c.tolerances.penetration * c.solution.length_scale
    # the walls at -0.1 and 0.1 bound the reference here; the axis is theirs plus the judge's allowance
    assert run.get_ylim() == pytest.approx((-0.1 - allowance, 0.1 + allowance), abs=1e-12)
    legend = run.get_legend()
    assert legend.get_gid() == "clipped"
    (text,) = [t.get_text() for t in legend.get_texts()]
    assert text.startswith("mujoco clipped: leaves the axis at t = 0.9")
    pybullet = timeseries_figure(compare(load_scene("feigin-pair", ["duration=3.5"]), settings=settings_for(("pybullet",), 1e-4)))
    assert _axes(pybullet)["run"].get_legend() is None  # an engine that stays inside is not said to leave


def test_compare_out_writes_every_figure_as_png_and_svg(tmp_path):
    out = tmp_path / "cmp"
    assert main(["compare", "bouncing-ball", "--set", "duration=1.6", "--engines", "pybullet", "--out", str(out)]) == 0
    for stem in ("timeseries", "ladder", "episode_errors"):
        assert (out / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (out / f"{stem}.svg").read_text().lstrip().startswith("<?xml")


def test_a_judged_file_is_drawn_in_a_colour_of_its_own_not_the_reference_grey(tmp_path):
    # issue 33: ``judge --out`` drew a file whose name hashes to the palette's grey ("mine") in grey, like the
    # reference's band, so it vanished under it in the zoom; read back from the figure the user gets (its SVG)
    import re
    from chatterbench.comparisons import reference_trajectory, trajectory_table
    from chatterbench.comparisons.outputs.style import engine_colour

    assert engine_colour("mine") == "#7f7f7f"  # the case: a name that hashes to grey
    trajectory_table(reference_trajectory(load_scene("bouncing-ball"), 1e-3)).to_csv(tmp_path / "run.csv", index=False)
    assert main(["judge", "bouncing-ball", str(tmp_path / "run.csv"), "--engine", "mine", "--out", str(tmp_path / "o")]) == 0
    svg = (tmp_path / "o" / "timeseries.svg").read_text()
    strokes = {s.lower() for s in re.findall(r"stroke:\s*(#[0-9a-fA-F]{6})", svg)}
    chromatic = {s for s in strokes if max(int(s[i:i + 2], 16) for i in (1, 3, 5)) - min(int(s[i:i + 2], 16)
                                                                                       for i in (1, 3, 5)) >= 0x20}
    assert "#7f7f7f" not in strokes and "#1f77b4" in chromatic  # the first palette colour no other run has
