"""The tune chart is a map of the searched region: dt x the main knob per slice, a cell per run, the answer circled."""

import pytest

from chatterbench.comparisons.outputs.tradeoff import tradeoff_figure
from chatterbench.comparisons.studies.tune import tune
from chatterbench.reference import load_scene


@pytest.fixture(scope="module")
def result():
    # PyBullet on the ball: dt 3e-3 .. 1e-3 x threshold 0 .. 3 m/s, in two slices (50 and 10 iterations), one level of
    # refinement and every pass's neighbourhood (the 3 m/s threshold sticks early: measured); the asked tolerances
    # alone (the map draws the asked verdicts; no frontier ladder): measured, the same 30 runs, 6 fragile passes, as
    # on dt 1e-3 .. 3e-4 before (whose finer runs resolve more impacts to strike: 12.1 s of CPU, now 7.7 s)
    space = {"dt": (3e-3, 1e-3), "pybullet.restitution_velocity_threshold": (0.0, 3.0),
             "pybullet.num_solver_iterations": (50, 10)}
    return tune(load_scene("bouncing-ball", ["duration=1.6"]), "pybullet", 0.05, space=space, workers=2, refine_steps=1,
                ladder=None)


def _on_lattice(result, s):
    grid, keys = result.extra["grid"], ["dt", "pybullet.restitution_velocity_threshold", "pybullet.num_solver_iterations"]
    return [r for _, r in result.table.iterrows() if (w := grid.place({k: r[k] for k in keys})) is not None and w[0] == s]


def test_one_panel_per_slice_and_a_cell_per_run(result):
    fig = tradeoff_figure(result)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == 2  # before: one cloud of points, cost against worst ratio
    for s, ax in enumerate(panels):
        cells = [p for p in ax.patches if p.get_gid() == "cell"]
        assert len(cells) == len(_on_lattice(result, s)) > 0
        assert ax.get_ylabel() == "restitution_velocity_threshold" and ax.get_xlabel().startswith("dt")


def test_answer_circled_and_fragile_passes_marked(result):
    fig = tradeoff_figure(result)
    lines = [ln for ax in fig.axes for ln in ax.lines if len(ln.get_xdata())]
    assert sum(ln.get_gid() == "chosen" for ln in lines) == 1
    fragile = sum(r["robust"] is False for s in range(2) for r in _on_lattice(result, s))
    assert sum(ln.get_gid() == "fragile" for ln in lines) == fragile
