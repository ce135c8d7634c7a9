"""The Newton adapters (``newton_xpbd``, ``newton_semi``) against Newton's impact law, with the real engine.

A force-free impact is judged by e = -vy after / vy before (free flight on both sides), at 3 speeds and 8 impact
phases (where in a step the ball reaches the wall). Newton's kernels load once per test process (the fixture), from
warp's cache after the first compile on a machine.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("newton", reason="the newton extra is not installed: pip install \".[newton]\"")

from chatterbench.engines.newton_engine import NewtonSemiEngine, NewtonXpbdEngine, SemiSettings, XpbdSettings  # noqa: E402
from chatterbench.engines.newton_engine.penalty import (  # noqa: E402
    contact_duration, damping_ratio_for, restitution_of)
from chatterbench.engines.newton_engine.world import load_kernels  # noqa: E402
from chatterbench.engines.restitution import damping_ratio_from_restitution, restitution_from_damping_ratio  # noqa: E402
from chatterbench.engines.settings import SettingsError  # noqa: E402
from chatterbench.reference.scene import scene_from_dict  # noqa: E402

DT = 1e-4  # [s] the adapters' default step
SPEEDS = (0.1, 1.0, 10.0)  # [m/s] approach speeds
PHASES = tuple(k / 8 for k in range(8))  # where in a step the ball reaches the wall [steps]
XPBD, SEMI = NewtonXpbdEngine(), NewtonSemiEngine()


@pytest.fixture(scope="module", autouse=True)
def kernels():
    """Both solvers' kernels loaded once for this module's runs (compiled the first time on a machine)."""
    return load_kernels("xpbd", "cpu"), load_kernels("semi", "cpu")


def _impact(v: float, phase: float, after: int, restitution: float = 0.5, mass1: float = math.inf,
            mass2: float = 1.0, dt: float = DT, gravity: float = 0.0):
    """Body 2 closing at ``v`` [m/s] from (20 + phase) steps away, no force, ``after`` steps after the impact."""
    return scene_from_dict({"mass1": mass1, "mass2": mass2, "restitution": restitution, "gap": {"lower": 0.0},
                            "gravity": gravity, "initial": {"y": v * dt * (20 + phase), "vy": -v},
                            "duration": dt * (20 + after)})


def _e(traj) -> float:
    assert traj.status == "ok", traj.message
    return float(-traj.vy[-1] / traj.vy[0])


@pytest.mark.parametrize("v", SPEEDS)
def test_xpbd_gives_r_at_every_speed_and_phase(v):
    # XPBD's restitution pass sets the normal speed to -R times the approach speed: R to float32 rounding
    # (measured |e - R| <= 3e-8 at 0.1, 1 and 10 m/s and all 8 phases); 1e-6 leaves room for rounding only
    for phase in PHASES:
        assert _e(XPBD.run(_impact(v, phase, after=20))) == pytest.approx(0.5, abs=1e-6), phase


@pytest.mark.parametrize("restitution", [0.0, 0.2, 0.8, 0.95])
def test_xpbd_gives_each_r_and_keeps_momentum(restitution):
    traj = XPBD.run(_impact(1.0, 0.3, after=20, restitution=restitution, mass1=1.0, mass2=0.5))
    assert _e(traj) == pytest.approx(restitution, abs=1e-6)
    momentum = 1.0 * traj.v1 + 0.5 * traj.v2  # the walls' push and its reaction: float32 rounding only
    assert np.max(np.abs(momentum - momentum[0])) <= 1e-6


def test_xpbd_restitution_does_not_act_below_twice_g_dt():
    # Newton's threshold 2 |g| dt (restitution_kernels.build_restitution_manifolds), g the model's gravity: at
    # dt = 5 ms it is 0.098 m/s. A 0.069 m/s approach (0.02 m/s, then one step's g dt) is plastic with gravity in
    # the model, and bounces with R when gravity is applied as a force; a 0.249 m/s one bounces either way.
    dt, g = 5e-3, -9.81
    assert XpbdSettings(dt=dt).threshold(g) == pytest.approx(0.0981)
    for v, bounces in ((0.02, False), (0.2, True)):
        scene = _impact(v, 0.5, after=2, dt=dt, gravity=g)
        scene = scene_from_dict({**_as_dict(scene), "initial": {"y": v * dt * 0.5, "vy": -v}})
        v_in = v - g * dt  # the approach speed after the step's gravity
        rebound = -0.5 * -v_in
        with_g = XPBD.run(scene, XpbdSettings(dt=dt)).vy[1]
        as_force = XPBD.run(scene, XpbdSettings(dt=dt, gravity_in_model=False)).vy[1]
        assert as_force == pytest.approx(rebound, rel=1e-5)
        if bounces:
            assert with_g == pytest.approx(rebound, rel=1e-5)
        else:
            assert with_g <= 0.0  # no rebound: the position solve leaves it closing, then at rest


def test_xpbd_without_its_threshold_a_resting_ball_never_rests():
    # the threshold's reason: with gravity as a force, a ball on the floor meets it at g dt every step and is sent
    # back, forever (measured: 3.27 mm/s upward after every step at dt = 1 ms, never 0); with gravity in the model
    # its speed is 0
    scene = scene_from_dict({"mass1": math.inf, "mass2": 1.0, "restitution": 0.5, "gap": {"lower": 0.0},
                             "gravity": -9.81, "initial": {"y": 0.0, "vy": 0.0}, "duration": 0.05})
    rests = XPBD.run(scene, XpbdSettings(dt=1e-3))
    jitters = XPBD.run(scene, XpbdSettings(dt=1e-3, gravity_in_model=False))
    assert np.all(rests.vy[-10:] == 0.0)
    assert np.all(np.abs(jitters.vy[-10:]) > 1e-3)


@pytest.mark.parametrize("v", SPEEDS)
def test_semi_gives_r_within_its_phase_error(v):
    # the penalty contact's e depends on where in a step it starts: at w0 dt = 0.03 measured 0.4865 .. 0.5022 at
    # all 3 speeds (the law is linear: the speed scales out), so 0.02
    es = [_e(SEMI.run(_impact(v, phase, after=300))) for phase in PHASES]
    assert max(abs(e - 0.5) for e in es) <= 0.02, es


def test_semi_phase_error_grows_with_w0_dt():
    # what the penalty contact cannot do: resolve a bounce of few steps. Measured spread of e over the 8 phases:
    # 0.016 at w0 dt = 0.03, 0.17 at 0.3, 0.87 at 1 (e above 1 at some phases): about 0.5 w0 dt
    def spread(w0_dt):
        es = [_e(SEMI.run(_impact(1.0, phase, after=300), SemiSettings(w0_dt=w0_dt))) for phase in PHASES]
        return max(es) - min(es)

    assert spread(0.03) < 0.02 and spread(0.3) > 0.1


def test_semi_a_wrong_kd_gives_the_e_it_should_and_is_caught():
    # known answer both ways: twice the damping rebounds with restitution_of(2 zeta) = 0.325, which the e test above
    # would reject (|e - R| > 0.15), and the measurement finds that number
    zeta2 = 2.0 * SemiSettings().zeta(0.5)
    es = [_e(SEMI.run(_impact(1.0, phase, after=300), SemiSettings(kd_scale=2.0))) for phase in PHASES]
    assert all(abs(e - restitution_of(zeta2)) <= 0.02 for e in es), es
    assert all(abs(e - 0.5) > 0.15 for e in es)


def test_semi_keeps_momentum_and_its_contact_lasts_its_time_scale():
    scene = _impact(1.0, 0.5, after=300, mass1=1.0, mass2=0.5)
    traj = SEMI.run(scene)
    assert _e(traj) == pytest.approx(0.5, abs=0.02)
    momentum = 1.0 * traj.v1 + 0.5 * traj.v2
    assert np.max(np.abs(momentum - momentum[0])) <= 1e-5  # equal and opposite forces, float32 rounding
    # the steps with a push span the contact's duration, to one step each end
    assert traj.contact["lower"].sum() * DT == pytest.approx(traj.contact_time, abs=2 * DT)
    assert traj.contact_frequency == pytest.approx(0.03 / DT)


@pytest.mark.parametrize("zeta", [0.1, 0.5, 1.0, 3.0])
def test_the_penalty_law_rebounds_as_penalty_py_says(zeta):
    # the compression-damped oscillator integrated finely (RK4, 1e5 steps a bounce) against the closed form
    w0, v0, x, v = 1.0, 1.0, 0.0, 1.0
    h = contact_duration(zeta, w0) / 100_000

    def acc(x, v):
        return -w0 * w0 * x - (2.0 * zeta * w0 * v if v > 0.0 else 0.0)

    while x >= 0.0:
        k1x, k1v = v, acc(x, v)
        k2x, k2v = v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v)
        k3x, k3v = v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v)
        k4x, k4v = v + h * k3v, acc(x + h * k3x, v + h * k3v)
        x, v = x + h * (k1x + 2 * k2x + 2 * k3x + k4x) / 6, v + h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6
    assert -v / v0 == pytest.approx(restitution_of(zeta), abs=1e-4)  # the kink at v = 0 costs RK4 its order


def test_the_penalty_law_is_not_the_force_only_laws():
    # known answer both ways: Newton's damper is off while separating, so e(zeta) is the square root of the force-only
    # law's; the force-only law's damping (MuJoCo's) would give Newton 0.707 for R = 0.5
    for r in (0.1, 0.5, 0.9):
        assert restitution_of(damping_ratio_for(r)) == pytest.approx(r, abs=1e-10)
        assert restitution_of(damping_ratio_for(r)) ** 2 == pytest.approx(
            restitution_from_damping_ratio(damping_ratio_for(r)), abs=1e-10)
    assert restitution_of(damping_ratio_from_restitution(0.5)) == pytest.approx(math.sqrt(0.5), abs=1e-9)
    assert restitution_of(math.inf) == 0.0 and math.isinf(damping_ratio_for(0.0))


@pytest.mark.parametrize("engine, kwargs, field", [
    ("xpbd", {"dt": 0.0}, "newton_xpbd.dt"),
    ("xpbd", {"iterations": 0}, "newton_xpbd.iterations"),
    ("xpbd", {"rigid_contact_relaxation": 1.5}, "newton_xpbd.rigid_contact_relaxation"),
    ("xpbd", {"gravity_in_model": "yes"}, "newton_xpbd.gravity_in_model"),
    ("xpbd", {"device": "gpu"}, "newton_xpbd.device"),
    ("semi", {"w0_dt": 0.0}, "newton_semi.w0_dt"),
    ("semi", {"kd_scale": -1.0}, "newton_semi.kd_scale"),
    ("semi", {"dt": math.nan}, "newton_semi.dt"),
])
def test_bad_settings_are_refused_by_name(engine, kwargs, field):
    with pytest.raises(SettingsError, match=field.replace(".", r"\.")):
        (XpbdSettings if engine == "xpbd" else SemiSettings)(**kwargs)


def test_an_overshooting_damper_is_refused_before_the_run():
    # zeta w0 dt > 1: the explicit damper reverses the approach within a step
    with pytest.raises(SettingsError, match="zeta w0 dt"):
        SEMI.run(_impact(1.0, 0.0, after=10, restitution=0.01), SemiSettings(w0_dt=0.5, kd_scale=10.0))


def _as_dict(scene) -> dict:
    return {"mass1": scene.mass1, "mass2": scene.mass2, "restitution": scene.restitution, "gap": {"lower": 0.0},
            "gravity": scene.gravity, "duration": scene.duration}


def test_xpbd_floors_speeds_below_1e_4_to_zero():
    # Newton 1.8's XPBD zeroes every body's velocity below 1e-4 m/s whenever it applies constraint deltas (kernels.
    # apply_body_deltas, "this improves gradient stability"; the contact and joint solves do, every step). Known answer
    # both ways: a body pushed from rest by 0.5 N on 1 kg (5e-5 m/s a step at dt = 1e-4) keeps speed 0 and creeps by
    # f dt^2 / m a step; 2 N (2e-4 m/s a step) accelerates as Newton's second law says. The semi-implicit solver has no
    # floor. This is why feigin-pair's body 1, pushed by sin(t) from rest, never starts in XPBD (docs: engines.md).
    def pushed(engine, settings, force):
        scene = scene_from_dict({"mass1": math.inf, "mass2": 1.0, "restitution": 0.5, "gap": {"lower": -1.0},
                                 "forces": [{"kind": "constant", "on": "body2", "value": force}],
                                 "initial": {"y": 0.0, "vy": 0.0}, "duration": 0.01})
        return engine.run(scene, settings)

    slow = pushed(XPBD, XpbdSettings(), 0.5)
    assert np.all(slow.vy == 0.0)
    assert slow.y[-1] == pytest.approx(100 * 0.5 * DT * DT, rel=1e-3)  # f dt^2 / m per step, 100 steps
    fast = pushed(XPBD, XpbdSettings(), 2.0)
    assert fast.vy[-1] == pytest.approx(2.0 * 0.01, rel=1e-4)
    semi = pushed(SEMI, SemiSettings(), 0.5)
    assert semi.vy[-1] == pytest.approx(0.5 * 0.01, rel=1e-4)
    # the floor is in model units: a model in millimetres (length_unit 1000) floors 1e-7 m/s, and the push accelerates
    mm = pushed(XPBD, XpbdSettings(length_unit=1000.0), 0.5)
    assert mm.vy[-1] == pytest.approx(0.5 * 0.01, rel=1e-4)


def test_xpbd_in_millimetres_is_the_same_bounce():
    # length_unit scales lengths, speeds and forces into the model and back: one impact gives R as in metres
    for v in SPEEDS:
        assert _e(XPBD.run(_impact(v, 0.3, after=20), XpbdSettings(length_unit=1000.0))) == pytest.approx(0.5, abs=1e-6)


def test_the_captured_step_is_the_launched_step():
    # the adapter replays one step captured as a warp graph; Newton's XPBD alternates its buffers by a Python-side
    # counter, so the graph is checked against the step launched kernel by kernel: the same run bit for bit
    from chatterbench.engines.newton_engine.world import build

    scene = _impact(1.0, 0.3, after=30, mass1=1.0, mass2=0.5)
    for engine, settings in ((XPBD, XpbdSettings()), (SEMI, SemiSettings())):
        runs = []
        for capture in (True, False):
            w = build(scene, settings, engine.solver, capture=capture)
            states = []
            for _ in range(60):
                w.push(0.1, -0.2)
                w.launch()
                states.append(w.state())
            runs.append(np.array(states))
        assert np.array_equal(runs[0], runs[1]), engine.name


def test_a_prescribed_box_drives_both_solvers():
    # Feigin's section-4 example as a box with prescribed motion x1 = sin t and a free mass inside: body 1 is a
    # kinematic link moved each step; the mass is thrown against each wall in turn and pressed to the upper one
    # around t = 2 s (y'' = sin t > 0 there), as the other engines do (pybullet: y(2 s) = 0.1002 m)
    scene = scene_from_dict({"name": "shaker", "mass1": "inf", "mass2": 1.0, "restitution": 0.5,
                             "gap": {"lower": -0.1, "upper": 0.1}, "prescribed": {"amplitude": 1.0, "omega": 1.0},
                             "initial": {"x1": 0.0, "v1": 1.0}, "duration": 6.5})
    for engine, settings in ((XPBD, XpbdSettings(dt=1e-3)), (SEMI, SemiSettings(dt=1e-3))):
        traj = engine.run(scene, settings)
        assert traj.status == "ok", traj.message
        assert traj.contact["lower"].any() and traj.contact["upper"].any()
        assert traj.x1[-1] == pytest.approx(math.sin(traj.t[-1]), abs=1e-12)  # the base's, from the formula
        assert traj.y[2000] == pytest.approx(0.1, abs=2e-3)  # on the upper wall (semi: 1 mm into its spring)
