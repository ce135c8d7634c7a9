"""The grid stops where it stalls: finer dt rows that got no closer are left, and a converging search is not cut.

Before: the coarse grid ran every dt row down to 1/1000 of the scene's tightest timing tolerance while any ladder
point had no answer, however the runs fared. In the kept atlas (840d18b) DART's feigin-pair rows failed ``early``
with the same worst error (20x its tolerance) from dt 3.06 ms down to 35 us, and 314 of the case's 314 s of CPU
went to them; Drake's spring-pair grid spent 1,066 s, 595 s of it on its finest row. Stand-in judges here, so that
only the search runs (the atlas's cases run the engines).
"""

from __future__ import annotations

import math

from chatterbench.comparisons.studies.tune.answer import _coverage
from chatterbench.comparisons.studies.tune.grid import Grid
from chatterbench.comparisons.studies.tune.search import STALL_GAIN, STALL_ROWS, search

SPACE = {"dt": (1e-1, 1e-2, 1e-3, 1e-4, 1e-5), "e.w": (1.0, 2.0)}  # five coarse rows, 17 dts x 5 knob values


def _judge(worst_of):
    """A stand-in judge: every run fails (``late``) with ``worst_of(dt)`` as its worst error over its tolerance, and
    passes (``match``) where that is at most 1."""
    def run_batch(batch, stage, bounds):
        rows = []
        for p in batch:
            worst = worst_of(p["dt"])
            rows.append({**p, "verdict": "match" if worst <= 1.0 else "late", "worst_ratio": worst,
                         "n_match": int(worst <= 1.0)})
        return rows
    return run_batch


def test_rows_that_get_no_closer_stop_the_grid_and_nothing_finer_runs():
    grid = Grid.make(SPACE, 2)
    coarse = [grid.dt[i] for i in grid.coarse(grid.dt)]
    done = search(_judge(lambda dt: 3.0), grid, budget=30)  # the same error at every dt: the contact model's
    assert not done.exhaustive
    assert done.stalled_dt == coarse[STALL_ROWS]  # the first row, then STALL_ROWS rows no closer
    assert min(r["dt"] for r in done.rows) >= coarse[STALL_ROWS]  # neither the grid, its refinement nor the reserve
    finer = sum(1 for i, d in enumerate(grid.dt) if d < coarse[STALL_ROWS]) * len(grid.knob_values)
    assert done.stalled == finer > 0
    assert {r["stage"] for r in done.rows} >= {"grid", "refine 1"}  # the budget went to refining what is left


def test_a_first_order_error_is_followed_to_the_finest_row_and_passes_there():
    grid = Grid.make(SPACE, 2)
    # the step's own error: 2.44x smaller a coarse row, within tolerance only at the finest dt
    done = search(_judge(lambda dt: dt / 1.2e-5), grid, budget=30)
    assert done.stalled_dt is None and done.stalled == 0
    assert min(r["dt"] for r in done.rows if r["stage"] == "grid") == grid.dt[-1] == 1e-5
    assert any(r["verdict"] == "match" and r["dt"] == 1e-5 for r in done.rows)


def test_one_flat_row_is_not_a_stall_but_a_gain_under_the_threshold_is():
    grid = Grid.make(SPACE, 2)
    coarse = [grid.dt[i] for i in grid.coarse(grid.dt)]
    # one row no closer, then one closer by more than STALL_GAIN, then one more flat: no stall, the finest row runs
    worst = dict(zip(coarse, [3.0, 3.0, 3.0 / STALL_GAIN / 1.01, 3.0 / STALL_GAIN / 1.01, 0.5]))
    done = search(_judge(lambda dt: worst.get(dt, 5.0)), grid, budget=30)
    assert done.stalled_dt is None and min(r["dt"] for r in done.rows if r["stage"] == "grid") == 1e-5
    # the other way: a gain just under STALL_GAIN counts as none, and two such rows stall the grid
    worst = dict(zip(coarse, [3.0, 3.0 / STALL_GAIN * 1.01, 3.0 / STALL_GAIN ** 2 * 1.03, 0.5, 0.5]))
    done = search(_judge(lambda dt: worst.get(dt, 5.0)), grid, budget=30)
    assert done.stalled_dt == coarse[2] and not any(r["verdict"] == "match" for r in done.rows)


def test_more_ladder_points_passed_is_getting_closer_whatever_the_error():
    grid = Grid.make(SPACE, 2)
    coarse = [grid.dt[i] for i in grid.coarse(grid.dt)]
    points = dict(zip(coarse, [(), (1,), (1, 2), (1, 2, 3), (0, 1, 2, 3)]))

    def run_batch(batch, stage, bounds):  # the worst error stays; each row passes at one ladder point more
        return [{**p, "verdict": "match" if 0 in points.get(p["dt"], ()) else "late", "worst_ratio": 3.0,
                 "passes": points.get(p["dt"], ())} for p in batch]
    levels = [(0.05, 0.05), (0.1, 0.1), (0.2, 0.2), (0.3, 0.3)]
    done = search(run_batch, grid, budget=30, levels=levels, check_robust=False)
    assert done.stalled_dt is None and min(r["dt"] for r in done.rows if r["stage"] == "grid") == 1e-5


def test_the_search_record_says_where_the_grid_stalled():
    x = {"exhaustive": False, "lattice": 85, "lattice_run": 40, "levels": [0, 1, 2], "refine_depth": 2,
         "skipped_costlier": 5, "skipped_stalled": 30, "stalled_dt": 0.00125}
    text = _coverage(x)
    assert "30 finer than dt 0.00125 s, where the grid stalled" in text and "10 not reached" in text
    assert "stalled" not in _coverage({**x, "skipped_stalled": 0, "stalled_dt": None})
    assert math.isclose(STALL_GAIN, 1.5) and STALL_ROWS == 2
