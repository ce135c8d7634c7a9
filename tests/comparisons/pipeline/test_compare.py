"""`compare`: the reference and both engines, episode by episode, with verdicts that say why."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.pipeline.compare import COLUMNS, compare
from chatterbench.reference import load_scene

from shared_engine_runs import engine_run


@pytest.fixture(scope="module")
def feigin_both(tmp_path_factory):
    # the engines' runs, registry.run_engine's as compare makes them, are test_judge.py's and test_window.py's too
    # (shared_engine_runs.py); a comparison that runs its engines itself: the tests below
    scene = load_scene("feigin-pair")
    runs = {engine: engine_run(tmp_path_factory, engine, scene, 1e-4) for engine in ("mujoco", "pybullet")}
    return compare(scene, settings=settings_for(("mujoco", "pybullet"), 1e-4), trajectories=runs)


@pytest.mark.slow
def test_feigin_pair_both_engines_slide_on_both_walls_every_half_period(feigin_both):
    table = feigin_both.table
    assert list(table.columns) == COLUMNS
    T = 2 * math.pi
    for engine in ("mujoco", "pybullet"):
        sub = table[table["engine"] == engine]
        # one sliding episode per half period, alternating walls, as the reference has
        assert len(sub) == len(feigin_both.reference) == 13
        assert list(sub["wall"]) == ["lower", "upper"] * 6 + ["lower"]
        # both stick within the tolerance (5% of each visit's chatter) ...
        assert (sub["stick_error_rel"].abs() <= 0.05).all(), sub[["wall", "stick_error_rel"]]
        exits = sub.dropna(subset=["t_exit"])
        # ... and let go at pi (lower) and 0 (upper) mod 2 pi, where the contact force falls to
        # zero: MuJoCo's force falls linearly and is interpolated to within 2 steps; PyBullet
        # rests with one impulse every third step, so its last one is up to 3 steps early
        steps = 2 if engine == "mujoco" else 3
        phase = np.where(exits["wall"] == "lower", math.pi, 0.0)
        off = np.mod(exits["t_exit"] - phase + T / 2, T) - T / 2
        assert np.abs(off).max() <= steps * 1e-4
        assert np.abs(exits["exit_error_steps"]).max() <= steps
    # PyBullet applies R at every impact: its resolved impacts follow R, and it sticks and exits on time; but at its
    # default threshold 0 its resting contact is that one impulse every third step: open one step in three (a third
    # of the rest, 1 / (3 dt) = 3,333 contact onsets per second), the force alternating between 0 and three times
    # the load (a swing of 2): every episode is buzz (persistence tolerance: open 1% of the rest)
    pb = table[table["engine"] == "pybullet"]
    assert (pb["verdict"] == "buzz").all() and (pb["restitution_error"].abs() < 0.05).all()
    assert (pb["open_fraction"] - 1 / 3).abs().max() < 0.005 and (pb["onset_rate"] * 3e-4 - 1).abs().max() < 0.005
    assert (pb["force_swing"] >= 1.99).all()
    # MuJoCo's soft contact lasts ~10 ms (w0 = 300 rad/s): longer than the flights of the last
    # resolved bounces, so the pressing force eats into their rebound and they come back 10-13%
    # below R, beyond the 5% tolerance: timing right, impacts wrong
    mj = table[table["engine"] == "mujoco"]
    assert (mj["verdict"] == "rebound").all()
    assert (mj["restitution_error"] < -0.05).all()
    pairs = feigin_both.impacts[feigin_both.impacts["engine"] == "mujoco"]
    # its fast impacts follow R to within the tolerance: measured <= 3.3% where the body crosses the
    # wall's surface (<= 1.03% at release: the contact lets go below the surface and the pressing
    # still slows the body on its way out)
    fast = pairs[pairs["v_minus"] > 0.1]
    assert len(fast) >= 20 and (fast["restitution_error"].abs() < 0.04).all()


def test_pybullet_velocity_threshold_sticks_the_ball_early():
    # restitutionVelocityThreshold = 0.5 m/s kills the bounces below 0.5 m/s: the ball stops
    # at the 5th impact (1.299 s), 56 ms before the Zeno point 1.3546 s (tolerance 40 ms)
    c = compare(load_scene("bouncing-ball"), settings=settings_for(("pybullet",), 1e-4, ["pybullet.restitution_velocity_threshold=0.5"]))
    row = c.table.iloc[0]
    assert row["verdict"] == "early"
    assert row["stick_error_zeno"] < -0.04


@pytest.mark.parametrize("w0_dt", [2.5, 5.0])
def test_mujoco_w0_dt_far_past_stability_is_caught(w0_dt):
    # past Euler's stability limit (1.55 at R = 0.5) the contact gains energy and blows up:
    # it must be reported as diverged or penetrated, never as a match
    c = compare(load_scene("feigin-pair", ["duration=8"]), settings=settings_for(("mujoco",), 1e-4, [f"mujoco.w0_dt={w0_dt}", "mujoco.allow_unstable=true"]))
    assert set(c.table["verdict"]) <= {"diverged", "penetrated"}
    assert len(c.table) >= 1


def test_another_bounded_trajectory_is_not_called_diverged():
    # feigin-pair at R = 0.8 never slides; PyBullet with a velocity threshold of 0.1 m/s makes
    # the slow strikes inelastic and sticks (a spurious episode), after which the forcing
    # takes it 21% above the reference's largest relative kinetic energy: another trajectory,
    # not a numerical blow-up (every sample finite, energy bounded)
    scene = load_scene("feigin-pair", {"duration": 18.84955592153876, "restitution": 0.8, "mass2": 0.5})
    c = compare(scene, settings=settings_for(("pybullet",), 1e-3, ["pybullet.restitution_velocity_threshold=0.1"]))
    assert c.runs["pybullet"].status == "ok"
    assert "diverged" not in set(c.table["verdict"])
    assert "spurious" in set(c.table["verdict"])


def test_an_engine_fault_is_classified_and_the_other_engine_kept(monkeypatch):
    monkeypatch.setenv("CHATTERBENCH_FAULT", "raise:mujoco")  # the test-only fault hook, engines/faults.py
    c = compare(load_scene("bouncing-ball"), settings=settings_for(("mujoco", "pybullet"), 1e-4))
    assert c.runs["mujoco"].status == "error" and "InjectedFault" in c.runs["mujoco"].trajectory.message
    assert set(c.table.loc[c.table["engine"] == "mujoco", "verdict"]) == {"error"}
    # the other engine's run is complete and judged as usual
    assert c.runs["pybullet"].status == "ok"
    pyb = c.table[c.table["engine"] == "pybullet"]
    assert len(pyb) == 1 and pyb["verdict"].iloc[0] not in ("error", "crashed", "timeout")


def test_compare_cli_writes_tables_logs_provenance_and_figures(tmp_path, capsys):
    out = tmp_path / "cmp"
    code = main(["compare", "bouncing-ball", "--engines", "mujoco", "--dt", "1e-4", "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "verdict" in printed and "summary" in printed
    for name in ("episodes.csv", "episodes.parquet", "impacts.csv", "impacts_mujoco.csv", "reference_episodes.csv",
                 "events_reference_feigin.csv",
                 "events_reference_exhaustive.csv", "events_mujoco.csv", "provenance.json", "timeseries.png", "timeseries.svg"):
        assert (out / name).stat().st_size > 0, name
    table = pd.read_parquet(out / "episodes.parquet")
    assert pd.read_csv(out / "episodes.csv")["verdict"].tolist() == table["verdict"].tolist()
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["engines"]["mujoco"]["version"] and prov["engines"]["mujoco"]["settings"]["dt"] == 1e-4
    assert (out / "timeseries.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_cli_refuses_unknown_engine(capsys):
    assert main(["compare", "bouncing-ball", "--engines", "mujoko"]) == 2
    assert "did you mean 'mujoco'" in capsys.readouterr().err
