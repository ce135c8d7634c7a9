"""The work-precision chart's texts read as the user sees the PNG: none cut by the figure's edge, none over another.

Before (issue 33): on Drake's chart (``examples/sweeps/feigin-pair-drake.toml``) the labels of
the failed runs on the top strip were written over each other ("accuracy=0.0001e-06"); on the
ball's, the right panel's y label ran past the figure's top ("(relative" cut). The rows are
chart input only, as a sweep writes them: Drake's measured sweep (every continuous accuracy
``endless``, no error measured; discrete dt ``early``) and the ball's two panels.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from chatterbench.comparisons.outputs.work_precision import work_precision_figure
from helpers import needs_engine

NAN = math.nan
# measured by `chatterbench sweep examples/sweeps/feigin-pair-drake.toml` (cost in s per simulated s, loaded machine)
DRAKE = [(1e-2, 0.0224, 0.843, 0.293), (1e-3, 0.0313, NAN, 0.0419), (1e-4, 0.0334, NAN, NAN), (1e-5, 0.0443, NAN, NAN),
         (1e-6, 0.0679, NAN, NAN)]
DISCRETE = [(1e-3, 0.287, 6.68e-4, 0.680), (3e-4, 0.996, 2.01e-4, 0.401), (1e-4, 3.69, 6.9e-5, 0.216),
            (3e-5, 6.21, 8.8e-5, 0.0716)]


def _drake_rows() -> pd.DataFrame:
    rows = [{"scene": "feigin-pair", "engine": "drake", "dt": 1e-4, "drake.mode": "continuous", "drake.accuracy": acc,
             "verdict": "endless", "status": "ok", "cost_per_sim_s": cost, "exit_error_rel_max": exit_,
             "stick_error_rel_max": stick} for acc, cost, exit_, stick in DRAKE]
    rows += [{"scene": "feigin-pair", "engine": "drake", "dt": dt, "drake.mode": "discrete", "drake.accuracy": NAN,
              "verdict": "early", "status": "ok", "cost_per_sim_s": cost, "exit_error_rel_max": exit_,
              "stick_error_rel_max": stick} for dt, cost, exit_, stick in DISCRETE]
    return pd.DataFrame(rows)


def _ball_rows() -> pd.DataFrame:
    """The ball's chart at R = 0.5 (bouncing-ball-maps.toml): six curves and four verdicts, so the legend takes the room
    the panels' y labels had."""
    verdicts = ("match", "late", "early", "rebound", "penetrated", "match")
    return pd.DataFrame([{"scene": "bouncing-ball", "engine": engine, "dt": dt, setting: value, "verdict": verdicts[j],
                          "status": "ok", "cost_per_sim_s": cost * (1 + j), "exit_error_rel_max": NAN,
                          "stick_error_rel_max": 0.01 * k * (1 + j), "restitution_error_max": 0.003 * k * (1 + j),
                          "reference_cost_per_sim_s": 1e-3}
                         for j, (engine, setting, value) in enumerate(
                             [("mujoco", "mujoco.w0_dt", w) for w in (0.03, 0.1, 1.0)]
                             + [("pybullet", "pybullet.restitution_velocity_threshold", v) for v in (0.0, 0.1, 0.5)])
                         for k, (dt, cost) in enumerate(((1e-3, 0.002), (3e-4, 0.006), (1e-4, 0.02)), 1)])


def _drawn(fig):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def test_the_failed_runs_strip_labels_are_each_readable():
    needs_engine("drake")  # the strip names Drake's lever (accuracy), which is asked of Drake's adapter
    fig = work_precision_figure(_drake_rows())
    renderer = _drawn(fig)
    for ax in fig.axes:
        strip = [t for t in ax.texts if t.get_text().startswith("accuracy=") and t.xy[1] > 0.9]
        caption = [t for t in ax.texts if t.get_text() == "failed, no error measured"]
        assert strip and caption, [t.get_text() for t in ax.texts]
        said = {v for t in strip for v in t.get_text().removeprefix("accuracy=").split(", ")}
        missing = {"0.0001", "1e-05", "1e-06"} - said  # every failed accuracy is named on the strip
        assert not missing, [t.get_text() for t in strip]
        boxes = [t.get_window_extent(renderer) for t in [*strip, *caption]]
        for i, a in enumerate(boxes):
            for b in boxes[i + 1:]:
                assert not a.overlaps(b), [t.get_text() for t in [*strip, *caption]]


@pytest.mark.parametrize("rows", [_ball_rows, _drake_rows], ids=["ball", "drake"])
def test_every_axis_label_is_whole_inside_the_figure(rows):
    fig = work_precision_figure(rows())
    renderer = _drawn(fig)
    page = fig.bbox
    title = fig.texts[0].get_window_extent(renderer) if fig.texts else None
    for ax in fig.axes:
        for label in (ax.yaxis.label, ax.xaxis.label):
            box = label.get_window_extent(renderer)
            assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= page.y1, \
                (label.get_text(), box, page)
            assert title is None or not box.overlaps(title), label.get_text()
    labels = [" ".join(ax.get_ylabel().split()) for ax in fig.axes]
    assert any(text.endswith("(relative)") for text in labels) or rows is _drake_rows, labels
    assert np.all([text.startswith("worst |error|: ") for text in labels])
