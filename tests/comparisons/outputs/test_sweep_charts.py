"""Sweep charts on small real sweeps: work-precision (error against cost) and stability maps."""

import itertools
import math

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.colors import to_rgba

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.outputs.figures import figure_bytes
from chatterbench.comparisons.pipeline.summary import ROW_COLUMNS, summarize
from chatterbench.comparisons.pipeline.vocabulary import combine as point_verdict
from chatterbench.comparisons.outputs.stability_map import stability_map_figure, verdict_grid
from chatterbench.comparisons.outputs.sweep_data import PASSING, VERDICT_ABBREV, VERDICT_COLOURS, ChartError
from chatterbench.comparisons.outputs.work_precision import work_precision_figure
from chatterbench.comparisons.outputs.work_precision_points import default_error, panel_metrics, pareto_front, work_precision_points
from chatterbench.reference import load_scene
from helpers import needs_engine

pytestmark = pytest.mark.slow  # the module fixtures run 57 comparisons (about 8 s)

DTS = (1e-2, 3e-3, 1e-3, 3e-4, 1e-4)  # [s] coarse enough to fail, fine enough to match
W0_DTS = (0.03, 0.1)
# PyBullet's restitution threshold [m/s], fixed for every point (a sweep's [set]): its default 0 never lets a stuck
# contact rest (it bounces at |y''| dt after the stick: buzz at every dt); 0.002 rests where the step's bounce
# stays under it (feigin-pair: match at 1e-3 and 1e-4, buzz at 3e-3), so its curve has passing points to rank
PYBULLET = {"pybullet.restitution_velocity_threshold": 0.002}


# [s] wall-clock seconds per step the rows are given in place of the measured cost (module's charts place labels by
# cost: a measured one moves them with the machine's load, and two MuJoCo settings of one dt swapped places run to run)
STEP_COST = {"mujoco": 2e-6, "pybullet": 5e-6}


def _cost(engine: str, dt: float, w0_dt: float = 0.0) -> float:
    """A fixed cost_per_sim_s [s/s] of the run: STEP_COST steps of dt, a stiffer MuJoCo contact a little dearer."""
    return STEP_COST[engine] / dt * (1.0 + w0_dt)


def _sweep(scene: str, fixed: list[str], grid: dict[str, tuple], dts=DTS, w0_dts=W0_DTS) -> pd.DataFrame:
    """Rows as a sweep writes them: one compare per (point, engine), summarized; each point's reference solved once
    and handed to its runs' compares (``solution=``: the same solution a compare would solve itself). The cost is
    ``_cost``'s, not the clock's, so the charts are the same on any machine."""
    rows = []
    names = list(grid)
    for values in [dict(zip(names, combo)) for combo in itertools.product(*grid.values())]:
        sc = load_scene(scene, fixed + [f"{k}={v}" for k, v in values.items()])
        ref = solve(sc)
        for dt in dts:
            for w in w0_dts:
                c = compare(sc, settings=settings_for(("mujoco",), dt, [f"mujoco.w0_dt={w}"]), solution=ref)
                rows.append({**summarize(c, "mujoco", {"dt": dt, **values, "mujoco.w0_dt": w}),
                             "cost_per_sim_s": _cost("mujoco", dt, w)})
            c = compare(sc, settings=settings_for(("pybullet",), dt, [f"{k}={v}" for k, v in PYBULLET.items()]), solution=ref)
            rows.append({**summarize(c, "pybullet", {"dt": dt, **values, **PYBULLET}), "cost_per_sim_s": _cost("pybullet", dt)})
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def feigin_rows():
    # a little over one forcing period: two sliding episodes, the first with an exit; R = 0.8
    # does not slide at all in that time (verdict none)
    return _sweep("feigin-pair", ["duration=7.0"], {"restitution": (0.3, 0.5, 0.8)})


@pytest.fixture(scope="module")
def ball_rows():
    # the ball sticks for good (Zeno point 1.35 s at R = 0.5): sticking errors, no exits
    return _sweep("bouncing-ball", ["duration=2.0"], {"mass2": (0.5, 2.0)}, dts=(1e-3, 3e-4, 1e-4), w0_dts=(0.03,))


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _lines(fig, prefix):
    return [ln for ax in fig.axes for ln in ax.get_lines() if str(ln.get_gid() or "").startswith(prefix)]


# -- the data the charts read ----------------------------------------------------------------

def test_fixture_is_a_sweep_dataset_with_failures_and_matches(feigin_rows):
    assert set(ROW_COLUMNS) <= set(feigin_rows.columns)
    v = set(feigin_rows["verdict"])
    # the charts must show both sides: matching runs and runs that fail for a reason
    assert {"match", "none"} <= v and v - set(PASSING) - {"none"}, v


def test_points_fold_scene_parameters_into_the_worst_case(feigin_rows):
    pts = work_precision_points(feigin_rows)
    # 5 dt x (2 MuJoCo w0_dt curves + 1 PyBullet curve)
    assert len(pts) == 15
    assert set(pts["curve"]) == {"mujoco (w0_dt=0.03)", "mujoco (w0_dt=0.1)", "pybullet"}
    for p in pts.itertuples():
        sub = feigin_rows[(feigin_rows["engine"] == p.engine) & (feigin_rows["dt"] == p.dt)]
        if p.settings:
            sub = sub[sub["mujoco.w0_dt"] == p.settings["mujoco.w0_dt"]]
        assert p.n_rows == 3  # one per restitution
        e = sub["exit_error_rel_max"].abs().max()  # the judge's relative error, as the chart draws it by default
        assert (math.isnan(p.exit_error_rel_max) and math.isnan(e)) or p.exit_error_rel_max == e
        assert p.lever == "dt" and p.lever_value == p.dt
        assert p.verdict == point_verdict(sub["verdict"])


# -- Pareto front ------------------------------------------------------------------------------

@pytest.mark.parametrize("metric", ["exit_error_rel_max", "stick_error_rel_max"])
def test_pareto_front_is_exactly_the_non_dominated_points(feigin_rows, metric):
    pts = work_precision_points(feigin_rows)
    front = pareto_front(pts, metric)
    ok = pts["verdict"].isin(PASSING) & np.isfinite(pts[metric]) & np.isfinite(pts["cost_per_sim_s"])
    cand = pts[ok]
    for i, p in pts.iterrows():
        if not ok[i]:
            assert not front[i]  # a failed run's error does not describe a working method
            continue
        dominated = ((cand["cost_per_sim_s"] <= p["cost_per_sim_s"]) & (cand[metric] <= p[metric])
                     & ((cand["cost_per_sim_s"] < p["cost_per_sim_s"]) | (cand[metric] < p[metric]))).any()
        assert front[i] == (not dominated), (p["curve"], p["dt"])
    # a real trade-off: more than one point, and not every candidate
    assert 1 < front.sum() < ok.sum()


def test_pareto_front_on_raw_rows_with_explicit_eligibility(feigin_rows):
    rows = feigin_rows.reset_index(drop=True)
    everyone = pd.Series(True, index=rows.index)
    front = pareto_front(rows, "exit_error_max", eligible=everyone)
    e, c = rows["exit_error_max"].to_numpy(), rows["cost_per_sim_s"].to_numpy()
    for i in np.flatnonzero(front):
        assert np.isfinite(e[i]) and np.isfinite(c[i])
        assert not np.any((c <= c[i]) & (e <= e[i]) & ((c < c[i]) | (e < e[i])))
    # the cheapest measured point and the most accurate one are always on the front
    finite = np.isfinite(e) & np.isfinite(c)
    assert front[np.flatnonzero(finite)[np.argmin(c[finite])]]
    assert front[np.flatnonzero(finite)[np.argmin(e[finite])]]


# -- work-precision figure -----------------------------------------------------------------------

def test_work_precision_figure_is_log_log_with_one_line_per_curve(feigin_rows):
    fig = work_precision_figure(feigin_rows)
    assert len(fig.axes) == 2  # exit time, sticking start
    pts = work_precision_points(feigin_rows)
    for ax, metric, tol in zip(fig.axes, ["exit_error_rel_max", "stick_error_rel_max"], (0.02, 0.05)):
        assert ax.get_gid() == metric  # the judge's relative errors, each with its tolerance drawn
        assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
        assert "fraction of the" in ax.get_ylabel() and "per simulated s" in ax.get_xlabel()
        (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == "tolerance"]
        assert list(line.get_ydata()) == [tol, tol]
        curves = {ln.get_gid()[len("curve:"):] for ln in ax.get_lines() if str(ln.get_gid()).startswith("curve:")}
        assert curves == {"mujoco (w0_dt=0.03)", "mujoco (w0_dt=0.1)", "pybullet"}
        # the ringed points are the front's, no more, no fewer
        rings = [ln for ln in ax.get_lines() if ln.get_gid() == "pareto-front"]
        fr = pts[pareto_front(pts, metric)]
        assert len(rings) == 1
        got = sorted(zip(rings[0].get_xdata(), rings[0].get_ydata()))
        assert got == sorted(zip(fr["cost_per_sim_s"], fr[metric]))
        # every failed point with a measured error is drawn hollow, marked by its class
        failed = pts[~pts["verdict"].isin(PASSING) & np.isfinite(pts[metric])]
        hollow = [ln for ln in ax.get_lines() if str(ln.get_gid()).startswith("failed:")]
        assert sum(len(ln.get_xdata()) for ln in hollow) == len(failed)
        assert all(ln.get_markerfacecolor() == "white" for ln in hollow)
        assert {ln.get_gid().split(":")[1] for ln in hollow} == set(failed["verdict"])


def test_one_line_per_engine_at_one_setting(feigin_rows):
    rows = feigin_rows[feigin_rows["mujoco.w0_dt"].isna() | (feigin_rows["mujoco.w0_dt"] == 0.1)]
    rows = rows.drop(columns="mujoco.w0_dt")
    fig = work_precision_figure(rows)
    gids = sorted(ln.get_gid() for ln in _lines(fig, "curve:") if ln.axes is fig.axes[0])
    assert gids == ["curve:mujoco", "curve:pybullet"]


def test_reference_star_and_failures_without_error(feigin_rows):
    fig = work_precision_figure(feigin_rows, reference_cost=1e-4, reference_error=1e-12)
    assert len(_lines(fig, "reference")) == 2  # one per panel
    # MuJoCo at dt = 1e-2 misses every sliding stretch: no exit measured, drawn on the top strip
    no_err = feigin_rows[~feigin_rows["verdict"].isin(PASSING + ("none",)) & feigin_rows["exit_error_max"].isna()]
    assert len(no_err)
    assert _lines(fig, "failed-no-error:")


def test_ball_has_no_exit_so_the_chart_draws_what_it_has_and_says_why(ball_rows):
    # before: an empty exit panel ("no exit time measured") beside the sticking start
    assert ball_rows["exit_error_rel_max"].isna().all()
    fig = work_precision_figure(ball_rows)
    assert figure_bytes(fig, "png")
    assert [ax.get_gid() for ax in fig.axes] == ["stick_error_rel_max", "restitution_error_max"]
    assert "no exit time measured: the reference never leaves the wall" in fig._suptitle.get_text().replace("\n", " ")
    for ax in fig.axes:
        assert {ln.get_gid() for ln in ax.get_lines() if str(ln.get_gid()).startswith("curve:")} == {
            "curve:mujoco", "curve:pybullet"}
    # in seconds, the same: sticking start, then the first impact
    fig = work_precision_figure(ball_rows, error="exit_error_max")
    assert [ax.get_gid() for ax in fig.axes] == ["stick_error_max", "first_impact_error_max"]


def test_a_panel_with_nothing_measured_says_why(feigin_rows):
    # R = 0.8: a little over one forcing period without sliding (verdict none where no engine fails)
    quiet = feigin_rows[(feigin_rows["restitution"] == 0.8) & (feigin_rows["verdict"] == "none")]
    assert len(quiet) > 5
    fig = work_precision_figure(quiet)
    (ax,) = fig.axes
    assert any("neither the reference nor the engines slide" in t.get_text().replace("\n", " ") for t in ax.texts)


def test_lever_labels_do_not_pile_up(feigin_rows):
    # before: a dt label per point, piled up where the curves of two settings coincide
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = work_precision_figure(feigin_rows)
    FigureCanvasAgg(fig).draw()
    for ax in fig.axes:
        labels = [t for t in ax.texts if t.get_text().startswith("dt=")]
        assert labels
        boxes = [t.get_window_extent() for t in labels]
        for i, a in enumerate(boxes):
            for b in boxes[i + 1:]:
                assert not a.overlaps(b), [t.get_text() for t in labels]


def test_points_are_labelled_by_each_engines_cost_lever():
    needs_engine("drake")  # the lever is asked of Drake's adapter
    # chart input only (an error-controlled engine's rows, as a sweep writes them): Drake's lever is its
    # integrator's accuracy, a dotted column; PyBullet's is dt. Both are asked of the engines' adapters.
    rows = []
    for acc, cost, err in ((1e-2, 0.01, 0.03), (1e-3, 0.03, 0.01), (1e-4, 0.1, 0.002)):
        rows.append({"scene": "feigin-pair", "engine": "drake", "dt": 1e-4, "drake.accuracy": acc, "verdict": "match",
                     "cost_per_sim_s": cost, "exit_error_rel_max": err / 2, "stick_error_rel_max": err})
    for dt, cost, err in ((1e-3, 0.02, 0.02), (1e-4, 0.2, 0.004)):
        rows.append({"scene": "feigin-pair", "engine": "pybullet", "dt": dt, "verdict": "match", "cost_per_sim_s": cost,
                     "exit_error_rel_max": err / 2, "stick_error_rel_max": err})
    rows = pd.DataFrame(rows)
    pts = work_precision_points(rows)
    drake = pts[pts["engine"] == "drake"]
    assert set(drake["lever"]) == {"accuracy"} and sorted(drake["lever_value"]) == [1e-4, 1e-3, 1e-2]
    assert set(drake["curve"]) == {"drake"}  # one curve through the accuracies, not one per accuracy
    assert set(pts[pts["engine"] == "pybullet"]["lever"]) == {"dt"}
    fig = work_precision_figure(rows)
    texts = {t.get_text() for t in fig.axes[0].texts}
    assert {"accuracy=0.01", "accuracy=0.001", "accuracy=0.0001", "dt=0.001", "dt=0.0001"} <= texts
    assert fig.axes[0].get_xlabel() == "cost: wall-clock s per simulated s"  # the x axis stays cost
    # Drake in discrete mode steps with dt: its lever is dt again
    discrete = rows.assign(**{"drake.mode": np.where(rows["engine"] == "drake", "discrete", None)})
    assert set(work_precision_points(discrete)["lever"]) == {"dt"}


# -- stability map -------------------------------------------------------------------------------

def _expected(rows, engine, x, y, xv, yv):
    sub = rows[(rows["engine"] == engine) & (rows[x] == xv) & (rows[y] == yv)]
    return point_verdict(sub["verdict"]) if len(sub) else None


@pytest.mark.parametrize("x, y, engine", [("dt", "restitution", None), ("mujoco.w0_dt", "restitution", "mujoco")])
def test_stability_cells_have_the_colour_of_their_rows_verdict(feigin_rows, x, y, engine):
    fig = stability_map_figure(feigin_rows, x, y, engine)
    engines = [engine] if engine else ["mujoco", "pybullet"]
    assert len(fig.axes) == len(engines)
    for ax, eng in zip(fig.axes, engines):
        grid = verdict_grid(feigin_rows, x, y, eng)
        (mesh,) = ax.collections
        rgba = mesh.cmap(mesh.norm(mesh.get_array())).reshape(grid.shape[0], grid.shape[1], 4)
        texts = {(round(t.get_position()[0], 12), round(t.get_position()[1], 12)): t.get_text() for t in ax.texts}
        for i, yv in enumerate(grid.index):
            for j, xv in enumerate(grid.columns):
                want = _expected(feigin_rows, eng, x, y, xv, yv)
                assert want is not None
                np.testing.assert_allclose(rgba[i, j], to_rgba(VERDICT_COLOURS[want]), err_msg=f"{eng} {xv} {yv}")
                assert texts[(round(float(xv), 12), round(float(yv), 12))] == VERDICT_ABBREV[want]
        # dt spans two decades: log axis; restitution 0.3..0.8 does not
        assert ax.get_xscale() == ("log" if x == "dt" else "linear")
        assert ax.get_yscale() == "linear"


def test_stability_map_refuses_unknown_parameters_and_other_engines_settings(feigin_rows):
    with pytest.raises(ChartError, match="did you mean 'restitution'"):
        stability_map_figure(feigin_rows, "dt", "restitutoin")
    with pytest.raises(ChartError, match="no rows of pybullet"):
        stability_map_figure(feigin_rows, "mujoco.w0_dt", "restitution", engine="pybullet")
    with pytest.raises(ChartError, match="did you mean 'mujoco'"):
        stability_map_figure(feigin_rows, "dt", "restitution", engine="mujoko")


# -- command line --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def dataset(feigin_rows, tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep")
    feigin_rows.to_parquet(d / "rows.parquet", index=False)
    feigin_rows.to_csv(d / "rows.csv", index=False)
    return d


def test_cli_draws_both_kinds_and_exits_0(dataset, tmp_path, capsys):
    out = tmp_path / "charts"
    assert main(["chart", str(dataset), "--kind", "work-precision", "--out", str(out)]) == 0
    assert main(["chart", str(dataset / "rows.csv"), "--kind", "stability", "--x", "dt", "--y", "restitution",
                 "--engine", "mujoco", "--out", str(out)]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["stability_dt_restitution_mujoco.png", "stability_dt_restitution_mujoco.svg",
                     "work_precision.png", "work_precision.svg"]
    assert (out / "work_precision.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "work_precision.svg").read_text().lstrip().startswith("<?xml")
    text = capsys.readouterr().out
    assert "Pareto" in text and "mujoco (w0_dt=0.1)" in text and "cells per verdict" in text


def test_cli_where_filters_the_rows(dataset, tmp_path, capsys):
    assert main(["chart", str(dataset), "--kind", "work-precision", "--where", "restitution=0.5",
                 "--out", str(tmp_path)]) == 0
    assert "15 points from 15 rows" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--kind", "stability", "--x", "dtt", "--y", "restitution"], "did you mean 'dt'"),
    (["--kind", "stability", "--x", "dt"], "needs --x KEY and --y KEY"),
    (["--kind", "work-precision", "--where", "restitution=0.4"], "no row has restitution = 0.4"),
    (["--kind", "work-precision", "--engine", "bullet"], "did you mean 'pybullet'"),
])
def test_cli_bad_input_exits_2_with_a_message(dataset, tmp_path, capsys, argv, message):
    assert main(["chart", str(dataset), *argv, "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())  # nothing written


def test_cli_missing_or_empty_dataset_exits_2(tmp_path, capsys, feigin_rows):
    assert main(["chart", str(tmp_path / "nope"), "--kind", "work-precision"]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["chart", str(tmp_path), "--kind", "work-precision"]) == 2
    assert "no rows.parquet" in capsys.readouterr().err
    feigin_rows.iloc[:0].to_parquet(tmp_path / "empty.parquet", index=False)
    assert main(["chart", str(tmp_path / "empty.parquet"), "--kind", "work-precision"]) == 2
    assert "no rows" in capsys.readouterr().err


# -- the reference's cost, engine-scoped filters, irregular and derived axes ----------------------

def test_reference_star_at_the_measured_reference_cost_by_default(feigin_rows):
    ref = feigin_rows["reference_cost_per_sim_s"]
    # every run timed the reference (Feigin's model) in the same process as its engine
    assert (ref > 0).all() and np.isfinite(ref).all()
    fig = work_precision_figure(feigin_rows)
    stars = _lines(fig, "reference")
    assert len(stars) == 2  # one per panel
    for star in stars:
        assert star.get_xdata()[0] == pytest.approx(ref.median(), rel=1e-12)
    # rows without the column (an older dataset): the band, no star
    assert not _lines(work_precision_figure(feigin_rows.drop(columns="reference_cost_per_sim_s")), "reference")


def test_rows_carry_the_mass_ratio_of_their_scene(feigin_rows, ball_rows):
    assert (feigin_rows["mass_ratio"] == 1.0).all()  # m2 / m1 = 1 / 1
    assert (ball_rows["mass_ratio"] == 0.0).all()  # the floor is infinitely heavy, whatever mass2 is


def test_cli_where_on_an_engine_setting_keeps_the_other_engines_rows(dataset, tmp_path, capsys):
    assert main(["chart", str(dataset), "--kind", "work-precision", "--where", "mujoco.w0_dt=0.1",
                 "--out", str(tmp_path)]) == 0
    # 15 MuJoCo rows at w0_dt = 0.1 (5 dt x 3 R) and all 15 PyBullet rows: 5 dt each
    assert "10 points from 30 rows" in capsys.readouterr().out


def _synthetic_rows() -> pd.DataFrame:
    """Chart input only (charts read rows, they run nothing): PyBullet rows over an irregular grid."""
    rows = []
    for thr, mass2, dt in itertools.product((0.0, 0.1, 0.5), (0.1, 1.0, 10.0), (1e-3, 1e-4)):
        verdict = "match" if thr == 0.0 else ("early" if thr == 0.5 else "spurious")
        rows.append({"point_id": f"{thr}-{mass2}-{dt}", "scene": "feigin-pair", "engine": "pybullet", "dt": dt,
                     "mass_ratio": mass2, "status": "ok", "verdict": verdict, "cost_per_sim_s": 1e-2,
                     "mass2": mass2, "pybullet.restitution_velocity_threshold": thr})
    return pd.DataFrame(rows)


def test_irregular_axis_gets_equal_cells_labelled_with_the_values():
    rows = _synthetic_rows()
    fig = stability_map_figure(rows, "pybullet.restitution_velocity_threshold", "mass_ratio")
    (ax,) = fig.axes
    # thresholds 0, 0.1, 0.5 (steps 0.1 and 0.4): equal cells, not a sliver for 0
    assert list(ax.get_xticks()) == [0.0, 1.0, 2.0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["0", "0.1", "0.5"]
    # mass ratio 0.1 .. 10 spans two decades: a log axis at the values
    assert ax.get_yscale() == "log" and list(ax.get_yticks()) == [0.1, 1.0, 10.0]
    texts = {(round(t.get_position()[0], 9), round(t.get_position()[1], 9)): t.get_text() for t in ax.texts}
    assert texts[(0.0, 1.0)] == VERDICT_ABBREV["match"] and texts[(2.0, 10.0)] == VERDICT_ABBREV["early"]
    # the map folds dt; mass2 is what the mass ratio is made of, not a second folded parameter
    assert "worst over dt (2)" in ax.get_title() and "mass2" not in ax.get_title()


def test_long_titles_wrap_inside_a_one_panel_map():
    fig = stability_map_figure(_synthetic_rows(), "pybullet.restitution_velocity_threshold", "mass_ratio")
    title = fig._suptitle.get_text()
    assert "\n" in title and title.replace("\n", " ") == (
        "feigin-pair: verdict over pybullet.restitution_velocity_threshold and mass_ratio")


# -- the slice a report draws: parameters held at their defaults -----------------------------------

def test_at_defaults_holds_what_a_map_does_not_draw_at_the_default(feigin_rows):
    from chatterbench.comparisons.outputs.sweep_data import at_defaults, default_values

    d = default_values(feigin_rows, "mujoco")
    assert d["mujoco.w0_dt"] == 0.03 and d["restitution"] == 0.5 and d["mass_ratio"] == 1.0
    sub, held = at_defaults(feigin_rows, "mujoco", ("dt", "restitution"))
    # w0_dt varies (0.03, 0.1) and is not drawn: held at MuJoCo's default
    assert held == {"mujoco.w0_dt": 0.03}
    assert (sub["engine"] == "mujoco").all() and (sub["mujoco.w0_dt"] == 0.03).all() and len(sub) == 15
    sub, held = at_defaults(feigin_rows, "mujoco", ("dt", "mujoco.w0_dt"))
    assert held == {"restitution": 0.5} and (sub["restitution"] == 0.5).all() and len(sub) == 10
    # PyBullet varies none of its settings here: nothing to hold on a dt x restitution map
    assert at_defaults(feigin_rows, "pybullet", ("dt", "restitution"))[1] == {}
    # a default the sweep did not run stays folded
    assert at_defaults(feigin_rows[feigin_rows["restitution"] != 0.5], "mujoco", ("dt", "mujoco.w0_dt"))[1] == {}


def test_report_sweep_section_draws_the_issue_maps_at_the_defaults(feigin_rows):
    from chatterbench.comparisons.outputs.report import SweepSection, sweep_figures

    figures, notes = sweep_figures(SweepSection(source="feigin", rows=feigin_rows))
    ids = [f.id for f in figures]
    assert ids == ["work-precision", "stability-mujoco-dt-restitution", "stability-mujoco-mujoco.w0_dt-restitution",
                   "stability-pybullet-dt-restitution"]
    caption = {f.id: f.caption for f in figures}
    assert caption["stability-mujoco-dt-restitution"].endswith("held at the defaults: mujoco.w0_dt = 0.03")
    assert "held" not in caption["stability-pybullet-dt-restitution"]
    assert all(f.png[:8] == b"\x89PNG\r\n\x1a\n" for f in figures) and not notes


def test_an_engine_with_two_levers_gets_one_curve_per_lever():
    needs_engine("drake")  # the lever is asked of Drake's adapter
    # one sweep of Drake in both modes (examples/sweeps/feigin-pair-drake.toml): continuous rows trade
    # accuracy, discrete rows dt. Before, the first row's lever (accuracy) was used for all rows and the
    # discrete rows (accuracy NaN) folded into one point labelled accuracy=nan.
    rows = []
    for acc, cost in ((1e-2, 0.003), (1e-4, 0.005)):
        rows.append({"scene": "feigin-pair", "engine": "drake", "dt": 1e-4, "drake.mode": "continuous",
                     "drake.accuracy": acc, "verdict": "early", "cost_per_sim_s": cost,
                     "exit_error_rel_max": 0.5, "stick_error_rel_max": 0.5})
    for dt, cost in ((1e-3, 0.03), (3e-4, 0.08), (1e-4, 0.2)):
        rows.append({"scene": "feigin-pair", "engine": "drake", "dt": dt, "drake.mode": "discrete",
                     "drake.accuracy": np.nan, "verdict": "early", "cost_per_sim_s": cost,
                     "exit_error_rel_max": 1e-4, "stick_error_rel_max": 0.2})
    pts = work_precision_points(pd.DataFrame(rows))
    by_curve = {c: g for c, g in pts.groupby("curve")}
    assert set(by_curve) == {"drake (mode=continuous)", "drake (mode=discrete)"}
    assert set(by_curve["drake (mode=continuous)"]["lever"]) == {"accuracy"}
    assert sorted(by_curve["drake (mode=continuous)"]["lever_value"]) == [1e-4, 1e-2]
    assert set(by_curve["drake (mode=discrete)"]["lever"]) == {"dt"}
    assert sorted(by_curve["drake (mode=discrete)"]["lever_value"]) == [1e-4, 3e-4, 1e-3]


def test_a_dataset_without_relative_errors_is_charted_in_seconds():
    # a sweep written before the relative errors existed (no *_rel_max columns): the chart and the
    # report's sweep section draw the errors in seconds instead of refusing the dataset
    rows = pd.DataFrame([{"scene": "feigin-pair", "engine": "pybullet", "dt": dt, "verdict": "match", "cost_per_sim_s": c,
                          "exit_error_max": e, "stick_error_max": 2 * e} for dt, c, e in ((1e-3, 0.02, 1e-3), (1e-4, 0.2, 1e-4))])
    assert default_error(rows) == "exit_error_max"
    assert panel_metrics(rows)[0] == ["exit_error_max", "stick_error_max"]
    fig = work_precision_figure(rows)
    assert len(fig.axes) >= 2
    assert default_error(rows.assign(exit_error_rel_max=0.01)) == "exit_error_rel_max"
