"""The grid stops where it stalls: finer dt rows that got no closer are left, and a converging search is not cut.

Before: the coarse grid ran every dt row down to 1/1000 of the scene's tightest timing tolerance while any ladder
point had no answer, however the runs fared. In the kept atlas (840d18b) DART's feigin-pair rows failed ``early``
with the same worst error (20x its tolerance) from dt 3.06 ms down to 35 us, and 313 of the case's 314 s of CPU
went to them; Drake's spring-pair grid spent 1,066 s, 595 s of it on its finest row. Stand-in judges here, so that
only the search runs (the atlas's cases run the engines).
"""

from __future__ import annotations

import math

from chatterbench.comparisons.studies.tune.answer import _coverage
from chatterbench.comparisons.studies.tune.grid import DT_RATIO, Grid, round_dt
from chatterbench.comparisons.studies.tune.search import search
from chatterbench.comparisons.studies.tune.stall import STALL_GAIN, STALL_ROWS, STALL_STEP

# five coarse rows 2.44x apart, as tune.space makes them (DT_RATIO ** 4), 17 dts x 5 knob values at depth 2
SPACE = {"dt": tuple(round_dt(1e-2 / DT_RATIO ** (4 * k)) for k in range(5)), "e.w": (1.0, 2.0)}


def _coarse(grid: Grid) -> list[float]:
    return [grid.dt[i] for i in grid.coarse(grid.dt)]


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
    coarse = _coarse(grid)
    done = search(_judge(lambda dt: 3.0), grid, budget=30)  # the same error at every dt: the contact model's
    assert not done.exhaustive
    assert done.stalled_dt == coarse[STALL_ROWS]  # the first row, then STALL_ROWS rows no closer
    assert min(r["dt"] for r in done.rows) >= coarse[STALL_ROWS]  # neither the grid, its refinement nor the reserve
    finer = sum(1 for d in grid.dt if d < coarse[STALL_ROWS]) * len(grid.knob_values)
    assert done.stalled == finer > 0
    assert {r["stage"] for r in done.rows} >= {"grid", "refine 1"}  # the budget went to refining what is left


def test_the_refinement_around_the_best_stops_at_the_stalled_row_too():
    grid = Grid.make(SPACE, 2)
    coarse = _coarse(grid)
    # each row a little closer, never by STALL_GAIN: the best reachable runs are the stalled row's, and refining
    # around them would step half a row finer
    worst = dict(zip(coarse, [3.0, 2.5, 2.1, 0.5, 0.5]))
    done = search(_judge(lambda dt: worst.get(dt, 2.9 if dt > coarse[2] else 2.2)), grid, budget=30)
    assert done.stalled_dt == coarse[2]
    refined = [r["dt"] for r in done.rows if r["stage"].startswith("refine")]
    assert coarse[2] in refined and min(refined) == coarse[2]  # around the best, at its row and coarser only
    assert not any(r["verdict"] == "match" for r in done.rows)  # the rows that would pass are past the stall


def test_a_first_order_error_is_followed_to_the_finest_row_and_passes_there():
    grid = Grid.make(SPACE, 2)
    finest = grid.dt[-1]
    # the step's own error: 2.44x smaller a coarse row, within tolerance only at the finest dt
    done = search(_judge(lambda dt: dt / finest), grid, budget=30)
    assert done.stalled_dt is None and done.stalled == 0
    assert min(r["dt"] for r in done.rows if r["stage"] == "grid") == finest
    assert any(r["verdict"] == "match" and r["dt"] == finest for r in done.rows)


def test_one_flat_row_is_not_a_stall_but_a_gain_under_the_threshold_is():
    grid = Grid.make(SPACE, 2)
    coarse = _coarse(grid)
    # one row no closer, then one closer by more than STALL_GAIN, then one more flat: no stall, the finest row runs
    worst = dict(zip(coarse, [3.0, 3.0, 3.0 / STALL_GAIN / 1.01, 3.0 / STALL_GAIN / 1.01, 0.5]))
    done = search(_judge(lambda dt: worst.get(dt, 5.0)), grid, budget=30)
    assert done.stalled_dt is None and min(r["dt"] for r in done.rows if r["stage"] == "grid") == coarse[-1]
    # the other way: a gain just under STALL_GAIN counts as none, and two such rows stall the grid
    worst = dict(zip(coarse, [3.0, 3.0 / STALL_GAIN * 1.01, 3.0 / STALL_GAIN ** 2 * 1.03, 0.5, 0.5]))
    done = search(_judge(lambda dt: worst.get(dt, 5.0)), grid, budget=30)
    assert done.stalled_dt == coarse[2] and not any(r["verdict"] == "match" for r in done.rows)


def test_rows_that_measure_nothing_do_not_count_toward_a_stall():
    grid = Grid.make(SPACE, 2)
    coarse = _coarse(grid)
    # the coarse rows unresolved or unstable (no finite error, no match), then a first-order error that passes at the
    # finest row: before, three such rows stalled the grid at the third and the pass was never run
    worst = dict(zip(coarse, [math.inf, math.inf, math.inf, 2.0, 0.8]))
    done = search(_judge(lambda dt: worst.get(dt, math.inf)), grid, budget=30)
    assert done.stalled_dt is None
    assert any(r["verdict"] == "match" and r["dt"] == coarse[-1] for r in done.rows)


def _passing(robust_below: float):
    """A stand-in judge of two ladder points (0: asked, 1: loose) and a flat error: every lattice run passes at the
    loose point only (worst 0.9 at the asked); a neighbour (stage ``neighbourhood``) passes there only at
    ``robust_below`` [s] or finer, so a lattice pass coarser than that is fragile."""
    def run_batch(batch, stage, bounds):
        return [{**p, "verdict": "late", "passes": (1,) if stage != "neighbourhood" or p["dt"] <= robust_below else (),
                 "worst_ratio": 3.0, "n_match": 0} for p in batch]
    return run_batch


LEVELS = [(0.05, 0.05), (0.2, 0.3)]  # the asked point, which nothing passes, and a loose one


def test_fragile_passes_keep_the_grid_going_and_robust_ones_let_it_stall():
    grid = Grid.make(SPACE, 2)
    coarse = _coarse(grid)
    # before: the same passes, matches and error on every row read as no closer, and the grid stalled at the third
    # row with no robust answer, though every setting at the finest row is robust. A pass that could still be an
    # answer (no cheaper robust one at its point) is getting closer: it may turn robust finer
    done = search(_passing(coarse[-1] * 1.3), grid, budget=60, levels=LEVELS, asked=0)
    assert done.stalled_dt is None
    assert any(r["robust_at"] == (1,) and r["dt"] == coarse[-1] for r in done.rows)
    # the other way: robust at the loose point from the first row, and rows that only pass there again (dearer: no
    # answer) stall the grid, though the asked point has no answer
    done = search(_passing(1.0), grid, budget=60, levels=LEVELS, asked=0)
    assert done.stalled_dt == coarse[STALL_ROWS]
    assert any(r["robust_at"] == (1,) and r["dt"] == coarse[0] for r in done.rows)
    assert min(r["dt"] for r in done.rows if "phase" not in r and r["stage"] != "neighbourhood") >= coarse[STALL_ROWS]


def test_a_step_that_matches_more_episodes_gets_closer():
    grid = Grid.make(SPACE, 2)
    coarse = _coarse(grid)
    matches = dict(zip(coarse, [0, 0, 1, 1, 2]))  # the error flat, a matching episode more every other row

    def run_batch(batch, stage, bounds):
        return [{**p, "verdict": "late", "worst_ratio": 3.0, "n_match": matches.get(p["dt"], 0)} for p in batch]
    done = search(run_batch, grid, budget=30)
    assert done.stalled_dt is None and min(r["dt"] for r in done.rows if r["stage"] == "grid") == coarse[-1]
    flat = search(_judge(lambda dt: 3.0), grid, budget=30)  # the other way: no more matches, the same error
    assert flat.stalled_dt == coarse[STALL_ROWS]


def test_a_row_that_answers_a_ladder_point_gets_closer():
    grid = Grid.make(SPACE, 2)
    coarse = _coarse(grid)

    def run_batch(batch, stage, bounds):
        # the asked point (0) passes from the fourth row on (its neighbours too); the loose one (1) from the third,
        # robustly; the error over the asked tolerance 3.0, 3.0, 2.5, then 0.9
        rows = []
        for p in batch:
            asked = p["dt"] <= coarse[3] * 1.3
            worst = 0.9 if asked else 2.5 if p["dt"] <= coarse[2] * 1.3 else 3.0
            loose = p["dt"] <= coarse[2] * 1.3
            rows.append({**p, "verdict": "match" if asked else "late", "worst_ratio": worst, "n_match": int(asked),
                         "passes": tuple(q for q, ok in ((0, asked), (1, loose)) if ok)})
        return rows
    # before: the third row's run became the loose point's answer after its neighbourhood ran, so it could no longer
    # be "an answer still to come" there, and the grid stalled at it: the asked point was never answered
    done = search(run_batch, grid, budget=60, levels=LEVELS, asked=0)
    assert done.stalled_dt is None
    assert any(r["robust_at"] and 0 in r["robust_at"] and r["dt"] == coarse[3] for r in done.rows)


CLOSE = {"dt": tuple(round_dt(1e-2 / 1.2 ** k) for k in range(12)), "e.w": (1.0, 2.0)}  # rows 1.2x apart


def test_rows_closer_than_a_step_are_walked_in_steps_of_the_same_span():
    # before: a space of dts 1.2x apart (or refine_steps 0, 1.25x) asked each row for a 1.5x gain, which a
    # first-order error (1.2x a row) never makes: the grid stalled at its third row and the finest never ran
    grid = Grid.make(CLOSE, 0)
    assert len(grid.dt) == 12 and grid.depth == 0
    done = search(_judge(lambda dt: dt / grid.dt[-1]), grid, budget=36)
    assert done.stalled_dt is None
    assert any(r["verdict"] == "match" and r["dt"] == grid.dt[-1] for r in done.rows)
    # the other way: a flat error stalls after the first row and two steps of at least STALL_STEP of dt
    done = search(_judge(lambda dt: 3.0), grid, budget=36)
    first_step_end = next(d for d in grid.dt if grid.dt[0] / d >= STALL_STEP / 1.01)
    second_step_end = next(d for d in grid.dt if first_step_end / d >= STALL_STEP / 1.01)
    assert done.stalled_dt == second_step_end == grid.dt[10]
    assert min(r["dt"] for r in done.rows) == second_step_end


def test_the_search_record_says_where_the_grid_stalled():
    x = {"exhaustive": False, "lattice": 85, "lattice_run": 40, "levels": [0, 1, 2], "refine_depth": 2,
         "skipped_costlier": 5, "skipped_stalled": 30, "stalled_dt": 0.00125}
    text = _coverage(x)
    assert "30 finer than dt 0.00125 s, where the grid stalled (2 steps of 2.44x of dt in a row got no closer" in text and "10 not reached" in text
    assert "stalled" not in _coverage({**x, "skipped_stalled": 0, "stalled_dt": None})
