"""Conformance of two engines: identical runs never disagree; a run with a wrong R is located and measured."""

import math

import pytest

from chatterbench.comparisons import compare, reference_trajectory
from chatterbench.comparisons.pipeline.conformance import (CONFORMANCE_COLUMNS, conformance, describe, parting,
                                                          same_model_pairs)
from chatterbench.engines.registry import unavailable_reason
from chatterbench.reference.scene import load_scene

DT = 1e-4  # [s] the exact reference sampled finely: its sticking starts are its Zeno points to a step


def _pair(scene_name, other_overrides):
    scene = load_scene(scene_name)
    exact = reference_trajectory(scene, dt=DT)
    other = reference_trajectory(load_scene(scene_name, other_overrides), dt=DT)
    return scene, compare(scene, engines=("mujoco", "pybullet"), trajectories={"mujoco": exact, "pybullet": other})


def test_identical_runs_never_disagree():
    _, result = _pair("feigin-pair", [])
    table = conformance(result, "mujoco", "pybullet")
    assert list(table.columns) == CONFORMANCE_COLUMNS
    assert len(table) == 13 and not table["disagree"].any()  # feigin-pair: 13 reference visits
    assert (table["stick_difference"].dropna() == 0.0).all() and (table["impact_count_difference"] == 0).all()
    assert math.isnan(parting(result, "mujoco", "pybullet").t_part)


def test_a_wrong_restitution_is_located_and_measured():
    _, result = _pair("bouncing-ball", ["restitution=0.55"])
    row = conformance(result, "mujoco", "pybullet").iloc[0]
    assert row["disagree"] and row["verdict"] == "match" and row["other_verdict"] != "match"
    # Zeno point t1 (1 + R) / (1 - R) with t1 = sqrt(2 / g): 1.3546 s for R = 0.5, 1.5593 s for 0.55.
    # The extraction marks sticking where the chatter left is a tenth of the stick tolerance, up to
    # 0.1 x 5% of the chatter (1.1 s for R = 0.55) before the Zeno point: 5.5 ms either way
    t1 = math.sqrt(2.0 / 9.81)
    slack = 0.1 * result.tolerances.stick * (t1 * 1.55 / 0.45 - t1)
    assert row["stick_difference"] == pytest.approx(t1 * (1.55 / 0.45 - 1.5 / 0.5), abs=slack)
    part = parting(result, "mujoco", "pybullet")
    assert part.t_part == pytest.approx(t1, abs=0.1)  # they part after the first rebound, not before it
    assert "1 of 1 episodes disagree" in describe(result, "mujoco", "pybullet")


def test_an_engine_not_in_the_comparison_is_a_key_error():
    _, result = _pair("bouncing-ball", [])
    with pytest.raises(KeyError, match="mujoco_warp"):
        conformance(result, "mujoco", "mujoco_warp")


@pytest.mark.skipif(bool(unavailable_reason("mujoco_warp")), reason=unavailable_reason("mujoco_warp") or "-")
def test_engines_on_one_model_are_the_pairs_their_adapters_declare():
    # MuJoCo Warp's adapter says it runs MuJoCo's model (same_model_as); no other pair among the built-in engines does
    assert same_model_pairs(("pybullet", "mujoco_warp", "mujoco")) == [("mujoco", "mujoco_warp")]
    assert same_model_pairs(("mujoco", "pybullet")) == [] and same_model_pairs(("mujoco_warp",)) == []
    assert same_model_pairs(("mujoco_warp", "no-such-engine")) == []


def test_the_sentence_gives_a_unit_only_to_a_number():
    # issue 33: the ball never exits, and the line read "|exit difference| none s"
    _, result = _pair("bouncing-ball", ["restitution=0.55"])
    text = describe(result, "mujoco", "pybullet")
    assert "|exit difference| none (no episode exits in both)," in text and "none s" not in text
    stick = float(text.split("largest |sticking difference| ", 1)[1].split(" s ", 1)[0])  # a number, then its unit
    assert stick > 0.1  # R = 0.55 sticks 0.2 s after R = 0.5 (Zeno points 1.5593 and 1.3546 s)
    assert " m/s." in text and not any(f"none {unit}" in text for unit in ("s", "m", "m/s"))
