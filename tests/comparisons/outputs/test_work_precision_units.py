"""The work-precision chart's reference note carries the unit of its panel's metric."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from chatterbench.comparisons.outputs.work_precision import work_precision_figure


def _rows(reference_cost: float | None) -> pd.DataFrame:
    nan = np.nan
    return pd.DataFrame([{"point_id": i, "scene": "bouncing-ball", "engine": "mujoco", "dt": dt, "status": "ok",
                          "verdict": "match", "n_episodes": 1, "n_match": 1, "exit_error_max": nan,
                          "stick_error_max": 1e-3 * i + 1e-3, "stick_error_plate_max": nan, "first_impact_error_max": 1e-4,
                          "exit_error_rel_max": nan, "stick_error_rel_max": 0.01 * (i + 1),
                          "restitution_error_max": 0.02 * (i + 1), "penetration_max": 1e-4, "cost_per_sim_s": 0.01 / dt / 1e3,
                          "reference_cost_per_sim_s": reference_cost, "duration": 2.0, "restitution": 0.5}
                         for i, dt in enumerate((1e-3, 5e-4))])


def test_a_dimensionless_panel_gives_the_reference_no_seconds():
    # before: "reference: error 1e-12 s (off scale)" on the restitution panel, whose error has no unit
    for reference_cost in (0.005, None):
        fig = work_precision_figure(_rows(reference_cost))
        panels = {ax.get_gid(): [t.get_text() for t in [*ax.texts, *ax.findobj(lambda a: hasattr(a, "get_text"))]
                                 if "reference" in str(getattr(t, "get_text", lambda: "")())] for ax in fig.axes}
        assert "restitution_error_max" in panels and panels["restitution_error_max"]
        for metric, notes in panels.items():
            if metric in ("restitution_error_max", "stick_error_rel_max", "exit_error_rel_max"):
                assert not any(re.search(r"\d s\b", n) for n in notes), (metric, notes)
