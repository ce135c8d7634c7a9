"""The chatter ladder: what it draws is what the judge paired, visit by visit."""

from __future__ import annotations

import numpy as np
import pytest

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons import compare
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.outputs.ladder import MAX_VISITS, ladder_figure
from chatterbench.reference import load_scene


@pytest.fixture(scope="module")
def feigin():
    return compare(load_scene("feigin-pair", ["duration=9.5"]), settings=settings_for(("mujoco", "pybullet"), 1e-4))


def _points(ax, gid: str) -> np.ndarray:
    found = [c for c in ax.collections if c.get_gid() == gid]
    assert len(found) == 1, gid
    return found[0].get_offsets()


def test_one_point_per_resolved_engine_impact_and_the_whole_reference_ladder(feigin):
    fig = ladder_figure(feigin)
    visits = feigin.reference.head(MAX_VISITS)
    assert len(fig.axes) == len(visits) == 3
    strikes = feigin.exhaustive.log[feigin.exhaustive.log.kind == "impact"]
    for i, (ax, row) in enumerate(zip(fig.axes, visits.itertuples())):
        for engine in ("mujoco", "pybullet"):
            paired = feigin.impacts[(feigin.impacts.engine == engine) & (feigin.impacts.episode == i)]
            pts = _points(ax, f"resolved-{engine}")
            assert len(pts) == len(paired) > 3
            assert np.allclose(pts[:, 1], paired.v_minus.abs())  # speeds, not signed velocities
        line = next(ln for ln in ax.lines if ln.get_gid() == "reference")
        ladder = strikes[(strikes.wall == row.wall) & (strikes.t >= row.t_first_impact) & (strikes.t <= row.t_stick)]
        assert len(line.get_xdata()) == len(ladder) == row.n_impacts
        speeds = np.asarray(line.get_ydata())
        ratios = speeds[1:] / speeds[:-1]
        assert (ratios < 1).all()  # every rung lower ...
        # ... and geometric near the Zeno point, where flights are too short for the forcing to matter
        assert np.allclose(ratios[-10:], feigin.scene.restitution, rtol=1e-3)


def test_compare_out_writes_the_ladder(tmp_path):
    out = tmp_path / "cmp"
    assert main(["compare", "bouncing-ball", "--set", "duration=1.6", "--engines", "pybullet", "--out", str(out)]) == 0
    assert (out / "ladder.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "ladder.svg").read_text().lstrip().startswith("<?xml")


def test_a_run_without_chatter_says_so():
    c = compare(load_scene("feigin-pair", ["duration=0.5"]), settings=settings_for(("pybullet",), 1e-3))
    fig = ladder_figure(c)
    assert "no chatter in this run" in fig.axes[0].texts[0].get_text()


def test_a_visit_that_starts_at_rest_has_no_ladder():
    # spring-pair starts on its wall at rest: one "impact" at speed 0, no chatter; before, it took
    # the first panel (and a log axis with nothing positive on it)
    c = compare(load_scene("spring-pair", ["duration=4"]), engines=())
    assert c.reference.n_impacts.iloc[0] == 1
    fig = ladder_figure(c)
    assert [ax.get_title().split(" (")[0] for ax in fig.axes] == ["visit 2", "visit 3"]


def test_the_title_says_how_many_visits_are_shown_of_how_many():
    # 12.6 s: four visits with chatter (Zeno points 1.64, 5.37, 8.51, 11.66 s), the ladder draws the first three
    c = compare(load_scene("feigin-pair", ["duration=12.6"]), settings=settings_for(("pybullet",), 1e-4))
    n = int(((c.reference.n_impacts > 1) & (c.reference.chatter_duration > 0)).sum())
    assert n == 4
    fig = ladder_figure(c)
    assert len(fig.axes) == MAX_VISITS
    assert f"the first {MAX_VISITS} of {n} visits with chatter" in fig._suptitle.get_text()  # before: not said


def test_a_ladder_that_shows_every_visit_says_so(feigin):
    assert "all 3 visits with chatter" in ladder_figure(feigin)._suptitle.get_text()
