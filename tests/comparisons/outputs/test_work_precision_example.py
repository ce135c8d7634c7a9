"""The smallest example sweep gives a work-precision chart with points; a chart of runs without episodes says why, once."""

import pandas as pd
import pytest

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.outputs.work_precision import work_precision_figure
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.summary import summarize
from chatterbench.comparisons.studies.sweep import load_rows
from chatterbench.reference import load_scene

EXAMPLE = "examples/sweeps/bouncing-ball-dt.toml"


def _fits(fig) -> None:
    """Every legend entry and the title inside the figure (none cut at its edge), the title on at most 2 lines."""
    fig.canvas.draw()
    width = fig.bbox.width
    for legend in fig.legends:
        for text in legend.get_texts():
            box = text.get_window_extent()
            assert 0 <= box.x0 and box.x1 <= width, text.get_text()  # before: "mujoco" drawn as "ujoco"
    assert fig._suptitle.get_text().count("\n") <= 1, fig._suptitle.get_text()  # before: four lines


@pytest.mark.slow
def test_the_example_sweep_charts_both_engines(tmp_path):
    # before: 0.6 s runs with no sticking episode at all: an empty chart
    assert main(["sweep", EXAMPLE, "--out", str(tmp_path / "bb"), "--workers", "2"]) == 0
    rows = load_rows(tmp_path / "bb")
    fig = work_precision_figure(rows)
    ax = fig.axes[0]
    assert ax.get_gid() == "stick_error_rel_max"  # the ball never exits: sticking start drawn first
    for engine in ("mujoco", "pybullet"):
        (curve,) = [ln for ln in ax.get_lines() if ln.get_gid() == f"curve:{engine}"]
        assert len(curve.get_xdata()) >= 1
    # PyBullet's hard contact sticks within the tolerance at every dt here (measured: 0.2% to 2.4% of the chatter)
    assert (rows.loc[rows["engine"] == "pybullet", "stick_error_rel_max"] <= 0.05).all()
    _fits(fig)


def test_runs_without_an_episode_say_so_once():
    # the old example: 0.6 s, one impact and no sticking (verdict none); MuJoCo at 1 ms goes through the floor
    scene = load_scene("bouncing-ball", ["duration=0.6"])
    rows = pd.DataFrame([summarize(compare(scene, settings=settings_for((e,), dt)), e, {"dt": dt})
                         for e in ("mujoco", "pybullet") for dt in (1e-3, 3e-4)])
    assert set(rows["verdict"]) <= {"none", "penetrated"} and (rows["verdict"] == "none").any()
    fig = work_precision_figure(rows)
    (why,) = [t.get_text().replace("\n", " ") for t in fig.axes[0].texts if " measured: " in t.get_text()]
    # before: "no run reproduced the episodes (2 penetrated, 16 none)": there was no episode to reproduce
    assert "no exit time or sticking start measured: no episode to judge" in why
    assert "neither the reference nor the engine sticks" in why
    assert "measured" not in fig._suptitle.get_text()  # said in the panel, not again in the title
    _fits(fig)
