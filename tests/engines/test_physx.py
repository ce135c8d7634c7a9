"""The PhysX adapter (SAPIEN 3) against Newton's impact law and the bouncing ball, with the real engine."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("sapien", reason="the physx extra is not installed: pip install \".[physx]\"")

from chatterbench.comparisons.pipeline.compare import compare  # noqa: E402
from chatterbench.engines.physx_engine import PhysxEngine, PhysxSettings  # noqa: E402

run = PhysxEngine().run  # one run, as the registry's adapter runs it
from chatterbench.engines.physx_engine.world import build, physx  # noqa: E402
from chatterbench.engines.registry import settings_for, make_settings  # noqa: E402
from chatterbench.engines.settings import SettingsError  # noqa: E402
from chatterbench.reference.scene import load_scene, scene_from_dict  # noqa: E402


def _single_impact(restitution: float, mass1: float, mass2: float = 1.0, y: float = 0.01):
    return scene_from_dict({"mass1": mass1, "mass2": mass2, "restitution": restitution, "gap": {"lower": 0.0},
                            "initial": {"y": y, "vy": -1.0}, "duration": 0.02})  # impact at 0.01 s, then flight apart


def _e(traj) -> float:
    """-vy after / vy before: free flight on both sides, no force."""
    return float(-traj.vy[-1] / traj.vy[0])


@pytest.mark.parametrize("restitution", [0.3, 0.8])
@pytest.mark.parametrize("mass1, mass2", [(1.0, 0.1), (1.0, 10.0), (math.inf, 1.0)])
def test_single_force_free_impact_gives_r(restitution, mass1, mass2):
    scene = _single_impact(restitution, mass1, mass2)
    traj = run(scene)
    assert traj.status == "ok", traj.message
    # the brief's 1 %; measured |e / R - 1| <= 2.4e-7 (float32 velocities)
    assert _e(traj) == pytest.approx(restitution, rel=0.01)
    assert traj.contact["lower"].sum() == 1  # one step's impulse
    if math.isfinite(mass1):  # contact impulses are equal and opposite: float32 rounding only
        momentum = mass1 * traj.v1 + mass2 * traj.v2
        assert np.max(np.abs(momentum - momentum[0])) <= 1e-6 * (mass1 + mass2)


def test_pgs_loses_restitution_where_tgs_keeps_it():
    # known numbers (measured): arriving exactly at a step's end (y = 0.01 m at 1 m/s, dt = 1e-4), PGS's
    # speculative contact first slows the ball to 0.8 m/s and the bounce then gives R of that: e = 0.8 R;
    # half a step later it gives R. TGS gives R at both.
    on_step, mid_step = _single_impact(0.5, math.inf), _single_impact(0.5, math.inf, y=0.00995)
    assert _e(run(on_step, PhysxSettings(enable_tgs=True))) == pytest.approx(0.5, abs=1e-5)
    assert _e(run(mid_step, PhysxSettings(enable_tgs=True))) == pytest.approx(0.5, abs=1e-5)
    assert _e(run(on_step, PhysxSettings(enable_tgs=False))) == pytest.approx(0.4, abs=1e-3)
    assert _e(run(mid_step, PhysxSettings(enable_tgs=False))) == pytest.approx(0.5, abs=1e-5)


def test_below_the_bounce_threshold_an_impact_is_plastic():
    # the threshold both ways: 1 m/s bounces under 0.5 m/s, is plastic under PhysX's own 2 m/s
    scene = _single_impact(0.5, math.inf)
    assert _e(run(scene, PhysxSettings(bounce_threshold=0.5))) == pytest.approx(0.5, abs=1e-5)
    assert abs(_e(run(scene, PhysxSettings(bounce_threshold=2.0)))) < 1e-6


def test_each_scene_keeps_the_settings_it_was_made_with():
    # SAPIEN's scene settings are process-wide and read when a system is made: a world made at 2 m/s keeps
    # it after another is made at 1e-3 m/s, and the process's own settings are put back
    before = physx.get_scene_config().bounce_threshold
    scene = _single_impact(0.5, math.inf)  # 1 m/s, 0.01 m from the wall: the impact in step 100
    plastic = build(scene, PhysxSettings(bounce_threshold=2.0))
    elastic = build(scene, PhysxSettings(bounce_threshold=1e-3))
    assert physx.get_scene_config().bounce_threshold == before
    for _ in range(200):  # one step of each in turn
        for world in (plastic, elastic):
            world.system.step()
    assert abs(float(plastic.body2.linear_velocity[0])) < 1e-6
    assert float(elastic.body2.linear_velocity[0]) == pytest.approx(0.5, abs=1e-5)


def test_bouncing_ball_early_at_physx_threshold_and_within_tolerance_at_the_adapters():
    # PhysX's own 2 m/s: the third impact (1.1 m/s) is plastic, the ball rests at 1.129 s instead of 1.355 s
    scene = load_scene("bouncing-ball", ["duration=1.6"])
    own = compare(scene, settings=settings_for(("physx",), dt=1e-3, overrides=["physx.bounce_threshold=2.0"]))
    assert own.table["verdict"].tolist() == ["early"]
    adapter = compare(scene, settings=settings_for(("physx",), dt=1e-3), solution=own.solution)
    assert adapter.table["verdict"].tolist()[0] in ("match", "rebound")


def test_pgs_never_lets_the_ball_rest():
    # PGS with a small threshold: the ball resting on the floor keeps making micro-bounces (endless, measured
    # 281 impacts in 2 s at dt = 1e-3), where TGS rests at the Zeno point (match, above)
    scene = load_scene("bouncing-ball")
    pgs = settings_for(("physx",), dt=1e-3, overrides=["physx.enable_tgs=false"])
    verdict = compare(scene, settings=pgs).table["verdict"].tolist()
    assert verdict == ["endless"]


@pytest.mark.parametrize("override, words", [
    ("bounce_threshold=0", "physx.bounce_threshold = 0: must be > 0"),
    ("enable_tgs=1", "physx.enable_tgs = 1: must be true or false"),
    ("solver_position_iterations=0", "physx.solver_position_iterations = 0: must be an integer in [1, 255]"),
    ("solver_velocity_iterations=2.5", "physx.solver_velocity_iterations = 2.5: must be an integer in [0, 255]"),
    ("sleep_threshold=-1", "physx.sleep_threshold = -1: must be >= 0"),
    ("contact_offset=0", "physx.contact_offset = 0: must be > 0"),
])
def test_bad_settings_are_refused_with_the_field_named(override, words):
    with pytest.raises(SettingsError) as info:
        make_settings("physx", overrides=[f"physx.{override}"])
    assert words in str(info.value)


def test_good_overrides_apply():
    s = make_settings("physx", 1e-3, ["physx.bounce_threshold=2.0", "physx.enable_tgs=false"])
    assert (s.dt, s.bounce_threshold, s.enable_tgs) == (1e-3, 2.0, False)


def test_feigin_pair_stays_in_its_gap():
    scene = load_scene("feigin-pair", ["duration=6.3"])
    traj = run(scene, PhysxSettings(dt=1e-3))
    assert traj.status == "ok", traj.message
    # rigid walls: never past a wall by more than float32 rounding and one step's closing (< 1e-4 of d = 0.1)
    assert traj.y.min() > scene.gap.lower - 1e-5 and traj.y.max() < scene.gap.upper + 1e-5
    assert traj.contact["lower"].any() and traj.contact["upper"].any()


def test_prescribed_body1_is_kinematic_and_bounces_the_ball_with_r():
    scene = load_scene("feigin-pair", ["mass1=inf", "prescribed.amplitude=0.05", "prescribed.omega=20.0",
                                       "initial.v1=1.0", "forces.0.on=coupling", "duration=0.5"])  # v1(0) = A w
    traj = run(scene, PhysxSettings(dt=1e-4))
    assert traj.status == "ok", traj.message
    np.testing.assert_array_equal(traj.x1, scene.prescribed.position(traj.t))  # the base fills in body 1
    hits = np.flatnonzero(traj.contact["lower"] | traj.contact["upper"])
    assert len(hits) == 3  # measured: 0.1279, 0.2766, 0.4182 s
    # the relative speed reverses with R; the kinematic wall moves at its secant speed over the step, the
    # recorded v1 is the prescribed one at the sample: measured e / R - 1 within -4e-4
    assert -traj.vy[hits] / traj.vy[hits - 1] == pytest.approx(np.full(3, 0.5), rel=2e-3)
    assert np.all(traj.y >= scene.gap.lower - 1e-5) and np.all(traj.y <= scene.gap.upper + 1e-5)


def test_wall_forces_are_the_contact_impulses_per_step_on_the_right_wall():
    traj = run(load_scene("bouncing-ball"), PhysxSettings(dt=1e-4))
    first = int(np.argmax(traj.contact["lower"]))
    v_in = -traj.v2[first - 1]
    # the first impact's impulse (1 + R) m v in one step, v the approach speed after the step's gravity v_in + g dt
    # (measured: equal to 3e-9 relative; float32 impulse)
    assert traj.normal_force["lower"][first] == pytest.approx(1.5 * (v_in + 9.81e-4) / 1e-4, rel=1e-6)
    tail = traj.t > 1.5  # resting past the Zeno point: the floor holds m g every step (measured 9.8100002 N)
    assert traj.contact["lower"][tail].all() and traj.normal_force["lower"][tail] == pytest.approx(9.81, rel=1e-6)
    pair = run(load_scene("feigin-pair", ["duration=6.3"]), PhysxSettings(dt=1e-3))
    # each wall's flag only where body 2 is at that wall (measured: within 4e-4 m of it, d = 0.1 m)
    assert pair.y[pair.contact["upper"]].min() > 0.09 and pair.y[pair.contact["lower"]].max() < -0.09


def test_one_position_iteration_keeps_a_resting_pair_at_rest():
    # SAPIEN's 10 TGS position iterations let a resting contact's relative speed creep up to the bounce
    # threshold: feigin-pair's second episode ends early with spurious bounces after it (measured, 2 periods
    # at dt = 1e-3); the adapter's 1 matches both episodes
    scene = load_scene("feigin-pair", ["duration=6.5"])
    ours = compare(scene, settings=settings_for(("physx",), dt=1e-3))
    sapiens = compare(scene, settings=settings_for(("physx",), dt=1e-3, overrides=["physx.solver_position_iterations=10"]),
                      solution=ours.solution)
    assert ours.table["verdict"].tolist() == ["match", "match"]
    assert sapiens.table["verdict"].tolist()[:2] == ["match", "early"] and "spurious" in sapiens.table["verdict"].tolist()
