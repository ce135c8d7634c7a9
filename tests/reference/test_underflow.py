"""A pull onto the wall too small for floating point is no accumulation (found by hypothesis, kept as a test)."""

from __future__ import annotations

import dataclasses

from chatterbench.reference.scene import load_scene
from chatterbench.reference.scene_parts import Gap, Initial
from chatterbench.reference.simulate import Options, simulate


def test_a_subnormal_pull_onto_the_wall_is_no_accumulation():
    # test_properties (feigin-pair, exhaustive) drew a start at t = 5e-324 on the lower wall, moving into it: the
    # harmonic force there is subnormal, (1 - R) |y''| underflowed to 0 and the sum of later flights divided by it
    # (ZeroDivisionError). Now: the impact happens and the run goes on
    base = load_scene("feigin-pair")
    scene = dataclasses.replace(
        base, gap=Gap(lower=-0.5, upper=0.5),
        forces=(dataclasses.replace(base.forces[0], amplitude=0.78125, omega=1.25),),
        initial=Initial(t=5e-324, x1=0.0, v1=0.0, y=-0.5, vy=-0.625), duration=5.026548245743669)
    result = simulate(scene, "exhaustive", Options(chatter="exhaustive", max_events=1000))
    assert result.log["kind"].iloc[0] == "impact" and result.log["t"].iloc[0] == 5e-324 and len(result.log) > 2
