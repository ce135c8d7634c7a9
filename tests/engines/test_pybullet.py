"""The PyBullet adapter against Newton's impact law and the bouncing ball, with the real engine."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chatterbench.engines.base import sample_times
from chatterbench.engines.pybullet_engine import PybulletEngine, PybulletSettings, settings_snippet
from chatterbench.engines.settings import SettingsError, settings_with_overrides
from chatterbench.reference.catalogue import G
from chatterbench.reference.scene import load_scene, scene_from_dict

run = PybulletEngine().run  # one run, as the registry's adapter runs it


def _single_impact(restitution: float, mu: float):
    return scene_from_dict(
        {
            "mass1": 1.0,
            "mass2": mu,
            "restitution": restitution,
            "gap": {"lower": 0.0},
            "initial": {"y": 0.01, "vy": -1.0},
            "duration": 0.03,  # impact at 0.01 s, then 0.02 s of free flight apart
        }
    )


def _onsets(traj, wall: str = "lower") -> np.ndarray:
    """Times [s] of the samples where the wall's contact flag switches on."""
    c = traj.contact[wall]
    return traj.t[1:][c[1:] & ~c[:-1]]


def _rest_time(traj, speed: float = 2e-3) -> float:
    """Last time [s] body 2 moved faster than ``speed`` [m/s]; after it the ball lies still."""
    return float(traj.t[np.flatnonzero(np.abs(traj.v2) > speed)[-1]])


@pytest.mark.parametrize("restitution", [0.3, 0.5, 0.8])
@pytest.mark.parametrize("mu", [0.1, 1.0, 10.0])
def test_single_impact_follows_newton(restitution, mu):
    scene = _single_impact(restitution, mu)
    traj = run(scene)
    assert traj.status == "ok", traj.message
    # Free flight before and after: the first and last samples are the incoming and outgoing
    # relative speeds. 0.01 is the brief's tolerance; measured |error| < 1e-15.
    assert -traj.vy[-1] / traj.vy[0] == pytest.approx(restitution, abs=0.01)
    assert traj.contact["lower"].any()
    # Contact impulses are equal and opposite: only rounding (1e-16) may change m1 v1 + m2 v2.
    momentum = scene.mass1 * traj.v1 + scene.mass2 * traj.v2
    assert np.max(np.abs(momentum - momentum[0])) <= 1e-6 * abs(momentum[0])


def test_bouncing_ball_impact_times():
    scene = load_scene("bouncing-ball", ["duration=1.2"])
    settings = PybulletSettings(dt=1e-4)
    traj = run(scene, settings)
    assert traj.status == "ok", traj.message
    r = scene.restitution
    t1 = math.sqrt(2.0 * scene.initial.y / G)
    v1 = G * t1
    reference = [t1]
    for k in range(1, 3):
        reference.append(reference[-1] + 2.0 * r**k * v1 / G)  # flight k lasts 2 R^k v1 / g
    onsets = _onsets(traj)[:3]
    # A contact is seen one step after the crossing (0..1 dt), each impact penetrates up to
    # one step and so shifts later flights by about dt; 1 ms more absorbs the accumulated
    # error (measured: 0.08, 0.25, 0.39 ms).
    tol = 2.0 * settings.dt + 1e-3
    assert len(onsets) == 3
    np.testing.assert_allclose(onsets, reference, atol=tol, rtol=0)
    # The wall pushes with the impact impulse: (1 + R) m v1 in one step.
    assert traj.normal_force["lower"].max() == pytest.approx((1 + r) * scene.mass2 * v1 / settings.dt, rel=0.05)


def test_restitution_velocity_threshold_stops_the_ball_early():
    scene = load_scene("bouncing-ball", ["duration=1.6"])
    t1 = math.sqrt(2.0 * scene.initial.y / G)
    zeno = t1 * (1 + scene.restitution) / (1 - scene.restitution)
    sticky = run(scene, PybulletSettings(restitution_velocity_threshold=0.5))
    exact = run(scene, PybulletSettings())
    # Bounces slower than 0.5 m/s get R = 0: measured rest at 1.30 s, 55 ms before the
    # 1.355 s Zeno point; 20 ms margin is 200 steps, far above timing noise.
    assert _rest_time(sticky) < zeno - 0.02
    # With the default threshold 0 the bounces run on to the Zeno point (measured 1.358 s);
    # the 10 ms allowance covers the last bounces being shorter than one step.
    assert _rest_time(exact) > zeno - 0.01
    # The resting ball is held by the floor: mean normal force over the last 0.1 s is m g
    # (the engine alternates tiny bounces, so only the mean is m g; 5 % covers that).
    tail = sticky.t > sticky.t[-1] - 0.1
    assert sticky.normal_force["lower"][tail].mean() == pytest.approx(scene.mass2 * G, rel=0.05)


def test_feigin_pair_stays_in_its_gap():
    scene = load_scene("feigin-pair", [f"duration={4 * math.pi}"])
    settings = PybulletSettings()
    traj = run(scene, settings)
    assert traj.status == "ok", traj.message
    np.testing.assert_array_equal(traj.t, sample_times(scene, settings.dt))  # the one step-count rule
    # Penetration: a contact is found only once the sphere has crossed the wall, so the
    # depth is at most one step of approach, |vy| dt (plus dt^2 |y''| <= 1e-8 m).
    # Measured: 4.3e-5 m beyond each wall.
    allowed = np.max(np.abs(traj.vy)) * settings.dt + 1e-8
    assert traj.y.min() >= scene.gap.lower - allowed
    assert traj.y.max() <= scene.gap.upper + allowed
    assert traj.contact["lower"].any() and traj.contact["upper"].any()
    assert np.all(traj.normal_force["lower"] >= 0) and np.all(traj.normal_force["upper"] >= 0)
    # Far from a wall nothing may push: contact only within one step's travel of it.
    far = (traj.y > scene.gap.lower + allowed) & (traj.y < scene.gap.upper - allowed)
    assert not np.any(traj.contact["lower"][far] & (traj.normal_force["lower"][far] > 0))


def test_runs_one_after_another_are_identical():
    scene = load_scene("spring-pair", ["duration=0.2"])
    a, b = PybulletEngine().run(scene, PybulletSettings()), run(scene, PybulletSettings())
    # Each run has a DIRECT client of its own (the first's, reset); PyBullet is deterministic, so bit-identical.
    np.testing.assert_array_equal(a.y, b.y)
    assert PybulletEngine.name == "pybullet"


def _same_runs(a, b) -> None:
    np.testing.assert_array_equal(a.t, b.t)
    for x, y in ((a.y, b.y), (a.vy, b.vy), *((a.contact[w], b.contact[w]) for w in a.contact),
                 *((a.normal_force[w], b.normal_force[w]) for w in a.normal_force)):
        np.testing.assert_array_equal(x, y)


def test_a_reused_client_runs_bit_for_bit_as_a_new_one(monkeypatch):
    # a closed world's client is reset for the next world instead of a new connect (world.py): whatever the runs
    # before it set (other parameters, bodies, a fixed or a free body 1), a run is the run of a fresh client
    from chatterbench.engines.pybullet_engine import world

    odd = PybulletSettings(dt=3e-4, restitution_velocity_threshold=0.5, num_solver_iterations=10, use_split_impulse=True)
    runs = [("bouncing-ball", odd), ("feigin-pair", PybulletSettings(dt=1e-3)), ("spring-pair", odd),
            ("impact-damper", PybulletSettings(dt=5e-4)), ("bouncing-ball", PybulletSettings(dt=1e-3))]
    scenes = {name: load_scene(name, ["duration=1.2"]) for name, _ in runs}
    monkeypatch.setattr(world, "_idle", [])
    monkeypatch.setattr(world, "IDLE_CLIENTS", 0)  # every world its own new client
    fresh = [PybulletEngine().run(scenes[name], s) for name, s in runs]
    monkeypatch.setattr(world, "IDLE_CLIENTS", 1)
    clients, real_build = [], world.build

    def build(scene, s):
        built = real_build(scene, s)
        clients.append(built.client)
        return built

    monkeypatch.setattr("chatterbench.engines.pybullet_engine.run.build", build)
    reused = [PybulletEngine().run(scenes[name], s) for name, s in runs]
    assert len(clients) == len(runs) and len(set(clients)) == 1  # one client, reused by every run after the first
    for (name, _), a, b in zip(runs, fresh, reused):
        assert a.status == b.status == "ok", name
        _same_runs(a, b)


def test_a_world_with_the_bodies_kept_runs_bit_for_bit_as_a_new_one(monkeypatch):
    # a closed world whose bodies are the next scene's (world.Bodies: walls, masses, R and settings alike) keeps them
    # and is set to the next scene's start (world.py): whatever the run before it left (body 2 pressed on a wall,
    # contact points and their impulses, warm starting on), a run is a fresh client's; another R is another body
    from chatterbench.engines.pybullet_engine import world

    warm = PybulletSettings(dt=1e-3, warm_starting_factor=0.85)
    runs = [("feigin-pair", ["duration=2.5"]),  # ends sliding on the lower wall (Feigin's first episode: 1.60-3.14 s)
            ("feigin-pair", ["initial.t=2.0", "initial.y=-0.0995", "initial.vy=-0.2", "duration=0.3"]),  # a strike there
            ("bouncing-ball", ["duration=2.0"]),  # ends resting on the floor
            ("feigin-pair", ["initial.t=2.4", "initial.y=-0.1", "duration=0.4"]),  # starts pressed on the lower wall
            ("bouncing-ball", ["initial.y=0.002", "initial.vy=-0.3", "duration=0.2"]),  # a strike on that floor
            ("feigin-pair", ["initial.y=0.0995", "initial.vy=0.4", "duration=0.3"]),  # a strike on the upper wall
            ("feigin-pair", ["initial.y=0.0995", "initial.vy=0.4", "duration=0.3", "restitution=0.8"])]  # made anew
    scenes = [load_scene(name, items) for name, items in runs]
    monkeypatch.setattr(world, "_idle", [])
    monkeypatch.setattr(world, "IDLE_CLIENTS", 0)  # every world its own new client
    fresh = [PybulletEngine().run(scene, warm) for scene in scenes]
    monkeypatch.setattr(world, "IDLE_CLIENTS", 2)  # the ball's bodies and the pair's, each kept
    made, real_make = [], world._make
    monkeypatch.setattr(world, "_make", lambda *args: made.append(args[0].name) or real_make(*args))
    kept = [PybulletEngine().run(scene, warm) for scene in scenes]
    assert made == ["feigin-pair", "bouncing-ball", "feigin-pair"]  # made once each, and for R = 0.8; the rest kept
    for scene, a, b in zip(scenes, fresh, kept):
        assert a.status == b.status == "ok", scene.initial
        _same_runs(a, b)
    for k in (0, 2):  # the runs before restored ones end on the lower wall, pushed by it
        assert abs(fresh[k].y[-1] - scenes[k].gap.lower) < 1e-5 and fresh[k].contact["lower"][-3:].any()


def test_a_world_left_in_the_middle_of_a_step_is_not_kept(monkeypatch):
    # a step cut short after its forces were applied (a Ctrl-C in a notebook, an engine error) leaves those forces for
    # the next stepSimulation: kept, the bodies gave the next run of the same scene a first step pushed by them
    from chatterbench.engines.pybullet_engine import run as stepping, world

    s = PybulletSettings(dt=1e-3)
    scene = load_scene("feigin-pair", ["duration=1", "initial.t=1.2"])  # forced: external forces on body 1 each step
    monkeypatch.setattr(world, "_idle", [])
    monkeypatch.setattr(world, "IDLE_CLIENTS", 0)
    fresh = PybulletEngine().run(scene, s)
    monkeypatch.setattr(world, "IDLE_CLIENTS", 2)
    real = stepping.p

    class Cut:  # pybullet whose 300th stepSimulation is interrupted before it steps
        calls = 0

        def __getattr__(self, name):
            return getattr(real, name)

        def stepSimulation(self, *args):
            Cut.calls += 1
            if Cut.calls == 300:
                raise KeyboardInterrupt
            return real.stepSimulation(*args)

    monkeypatch.setattr(stepping, "p", Cut())
    with pytest.raises(KeyboardInterrupt):
        PybulletEngine().run(scene, s)
    monkeypatch.setattr(stepping, "p", real)
    after = PybulletEngine().run(scene, s)
    assert after.status == "ok"
    _same_runs(fresh, after)


def test_a_world_whose_run_blew_up_is_not_kept(monkeypatch):
    # found in review: a run driven to NaN (1e200 N on body 2, joint speeds unclamped) left bodies that resetJointState
    # does not mend; kept, the next run of the same bodies passed through the wall (y down to -0.94 m) and said "ok"
    from chatterbench.engines.pybullet_engine import world

    s = PybulletSettings(dt=1e-3, max_joint_velocity=1e300)
    plain = load_scene("feigin-pair", ["duration=3"])
    data = plain.to_dict()
    data["forces"] = [*data["forces"], {"kind": "constant", "on": "body2", "value": 1e200}]
    blown = scene_from_dict(data)
    monkeypatch.setattr(world, "_idle", [])
    monkeypatch.setattr(world, "IDLE_CLIENTS", 0)
    fresh = PybulletEngine().run(plain, s)
    monkeypatch.setattr(world, "IDLE_CLIENTS", 2)
    assert PybulletEngine().run(blown, s).status == "diverged"
    after = PybulletEngine().run(plain, s)
    assert after.status == "ok" and after.y.min() > plain.gap.lower - 1e-3
    _same_runs(fresh, after)


def test_settings_snippet_is_python():
    snippet = settings_snippet(PybulletSettings(), restitution=0.5)
    compile(snippet, "<snippet>", "exec")
    assert "restitutionVelocityThreshold=0.0" in snippet and "contactERP=0.0" in snippet


@pytest.mark.parametrize(
    "overrides, field",
    [
        (["pybullet.restitution_velocity_threshold=-0.1"], "pybullet.restitution_velocity_threshold = -0.1"),
        (["pybullet.contact_erp=1.5"], "pybullet.contact_erp = 1.5"),
        (["pybullet.num_solver_iterations=0"], "pybullet.num_solver_iterations = 0"),
    ],
)
def test_bad_settings_are_refused_with_the_field_named(overrides, field):
    # PyBullet's own keys; dt and misspelt keys: tests/engines/test_contract.py, for every engine
    with pytest.raises(SettingsError) as info:
        settings_with_overrides(PybulletSettings(), overrides, prefix="pybullet")
    assert field in str(info.value)


def test_good_override_applies():
    s = settings_with_overrides(PybulletSettings(), ["pybullet.restitution_velocity_threshold=0.5", "mujoco.x=1"], prefix="pybullet")
    assert s.restitution_velocity_threshold == 0.5 and s.dt == 1e-4
