"""`tune`: the recommended settings really match when rerun through `compare`."""

import math

import pytest

from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.outputs.guide import guide_html, guide_markdown, tradeoff_figure
from chatterbench.comparisons.studies.tune import tune
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.reference import load_scene
from chatterbench.reference.errors import InputError


def test_tune_mujoco_feigin_pair_reruns_as_match():
    # two forcing periods keep it fast; the space is a slice of the default grid that
    # brackets the front at the default tolerances (w0 dt = 0.1: dt = 1e-3 sticks 12% of the
    # chatter late, 3e-4 within 4.4%: measured)
    scene = load_scene("feigin-pair", [f"duration={4 * math.pi}"])
    space = {"dt": (1e-3, 3e-4), "mujoco.w0_dt": (0.1,), "mujoco.integrator": ("euler",)}
    result = tune(scene, "mujoco", Tolerances(), space=space, workers=2, refine_steps=2)
    assert result.best is not None
    assert (result.table["stage"] == "refine").any()  # the front was refined, not brute-forced
    best = result.best
    # the cheapest match is no more expensive than every other match
    matches = result.table[result.table["verdict"] == "match"]
    assert best["cost_per_sim_s"] == matches["cost_per_sim_s"].min()
    rerun = compare(scene, engines=("mujoco",), dt=best["dt"],
                    overrides=[f"mujoco.w0_dt={best['mujoco.w0_dt']}", f"mujoco.integrator={best['mujoco.integrator']}"],
                    tol=Tolerances())
    assert (rerun.table["verdict"] == "match").all()
    text = guide_markdown(result)
    assert "Recommended" in text and "<mujoco" in text  # the MJCF snippet is in the guide
    assert tradeoff_figure(result).axes[0].get_xscale() == "log"
    page = guide_html(result)  # the same guide as an HTML section for the report
    assert "Recommended" in page and "data:image/png;base64," in page and "&lt;mujoco" in page


def test_tune_says_when_nothing_meets_the_tolerance():
    scene = load_scene("bouncing-ball")
    # a stiff contact at a coarse step sticks, but far later than 1e-5 of the chatter after
    # the Zeno point: no candidate can meet that, and the best reachable error is reported
    space = {"dt": (3e-4,), "mujoco.w0_dt": (0.1,), "mujoco.integrator": ("euler",)}
    result = tune(scene, "mujoco", tolerance=1e-5, space=space, workers=1, refine_steps=0)
    assert result.best is None and result.best_reachable is not None
    assert "No candidate met the tolerance" in guide_markdown(result)


def test_tune_refuses_bad_tolerance():
    with pytest.raises(InputError, match="tolerance"):
        tune(load_scene("bouncing-ball"), "mujoco", tolerance=1.5)
