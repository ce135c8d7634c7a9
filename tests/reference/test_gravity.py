"""Gravity as an acceleration (issue 41 item 4): the scene's ``gravity``, its weights in the force model, the
reference's fall against the closed form, and a file's weight given as a force read as gravity (``weight.py``)."""

from __future__ import annotations

import math

import pytest

from chatterbench.reference import SceneError, load_scene, scene_from_dict, simulate
from chatterbench.reference.forces import ForceModel, relative_acceleration
from chatterbench.reference.weight import weights_as_gravity

# the old built-in ball as a file wrote it: the 1 kg ball's weight as a constant force of -9.81 N on body 2
OLD_BALL = """name = "old-ball"
mass1 = "inf"
mass2 = {mass2!r}
restitution = 0.5
duration = 2.0
[gap]
lower = 0.0
[initial]
y = 1.0
[[forces]]
kind = "constant"
on = "body2"
value = {value!r}
"""


def _first_impact(scene) -> float:
    log = simulate(scene, "feigin").log
    return float(log[log.kind == "impact"].t.iloc[0])


@pytest.mark.parametrize("mass2", [0.2, 1.0, 5.0])
@pytest.mark.parametrize("g", [-9.81, -1.62])
def test_the_reference_falls_at_g_whatever_the_mass(mass2, g):
    # from rest at h = 1 m: t1 = sqrt(2 h / |g|); 1e-12 s: event times are found to 1e-14 relative (roots.py)
    scene = load_scene("bouncing-ball", [f"mass2={mass2}", f"gravity={g}"])
    assert _first_impact(scene) == pytest.approx(math.sqrt(2.0 / -g), abs=1e-12)
    assert relative_acceleration(scene, 0.0, 0.0, 0.0, 0.5, 0.0) == pytest.approx(g, rel=1e-15)


def test_a_constant_force_does_not_follow_the_mass():
    # the other way: the same -9.81 N on a 0.2 kg ball is 49.05 m/s^2, first impact at sqrt(2 / 49.05) = 0.2019 s
    scene = load_scene("bouncing-ball", ["mass2=0.2", "gravity=0.0"])
    scene = load_scene({**scene.to_dict(), "forces": [{"kind": "constant", "on": "body2", "value": -9.81}]})
    assert _first_impact(scene) == pytest.approx(math.sqrt(2.0 * 0.2 / 9.81), abs=1e-12)


def test_gravity_pulls_a_finite_body_1_too():
    # both bodies fall at g: y'' = 0, the ball thrown down at 2 m/s meets the floor at y0 / 2 = 0.5 s, not earlier
    scene = load_scene("bouncing-ball", ["mass1=3.0", "initial.vy=-2.0"])
    model = ForceModel.from_scene(scene)
    assert (model.body1.constant, model.body2.constant, model.coupling.constant) == (3.0 * -9.81, -9.81, 0.0)
    assert _first_impact(scene) == pytest.approx(0.5, abs=1e-12)
    # an infinite body 1 is kinematic: no weight on it
    assert ForceModel.from_scene(load_scene("bouncing-ball")).body1.constant == 0.0


@pytest.mark.parametrize("value,words", [
    ("nan", ["gravity", "finite", "m/s^2"]), ("inf", ["gravity", "finite"]), ('"down"', ["gravity", "a number"]),
    ("true", ["gravity", "a number"]),
])
def test_a_bad_gravity_is_refused_by_name(value, words):
    with pytest.raises(SceneError) as err:
        load_scene("bouncing-ball", [f"gravity={value}"])
    assert all(w in str(err.value) for w in words), str(err.value)


def test_a_weight_that_overflows_is_refused():
    words = r"gravity = -1e\+300: the weight of the 1e\+10 kg body overflows; keep \|gravity\| below 1e\+298 m/s\^2"
    with pytest.raises(SceneError, match=words):
        load_scene("bouncing-ball", ["mass2=1e10", "gravity=-1e300"])


@pytest.mark.parametrize("mass2,value,g", [(1.0, -9.81, -9.81), (0.2, -0.2 * 9.81, -9.81), (2.0, -19.6133, -9.80665),
                                          (0.5, 4.905, 9.81)])
def test_a_files_weight_is_read_as_gravity(tmp_path, mass2, value, g):
    path = tmp_path / "old-ball.toml"
    path.write_text(OLD_BALL.format(mass2=mass2, value=value))
    scene = load_scene(path)
    assert scene.gravity == g and scene.forces == ()
    assert scene.notes == (f"forces[0]: constant {value:.10g} N on body2 (mass2 {mass2:.10g} kg) read as gravity = "
                           f"{g:.10g} m/s^2 (the force now follows the mass)",)
    # the overrides come after: the lighter ball falls at g, not at 9.81 N / 0.2 kg
    if g < 0:
        assert _first_impact(load_scene(path, ["mass2=0.2"])) == pytest.approx(math.sqrt(2.0 / -g), abs=1e-12)


@pytest.mark.parametrize("value", [-9.81 * (1 + 1e-8), -9.0, -9.81 * 2])
def test_a_constant_force_that_is_not_the_weight_stays_a_force(tmp_path, value):
    path = tmp_path / "pushed.toml"
    path.write_text(OLD_BALL.format(mass2=1.0, value=value))
    scene = load_scene(path)
    assert scene.gravity == 0.0 and scene.forces[0].value == value and scene.notes == ()


def test_a_file_that_gives_gravity_keeps_its_constant_forces(tmp_path):
    # gravity = 0 written on purpose: the force is a push on the ball alone (examples/scenes/ball-free-floor.toml)
    path = tmp_path / "pushed.toml"
    path.write_text(OLD_BALL.format(mass2=1.0, value=-9.81).replace("duration = 2.0\n", "duration = 2.0\ngravity = 0.0\n"))
    scene = load_scene(path)
    assert scene.gravity == 0.0 and scene.forces[0].value == -9.81 and scene.notes == ()


def test_a_finite_body_1_needs_its_own_weight():
    body = {"mass1": 2.0, "mass2": 0.5, "restitution": 0.5, "gap": {"lower": 0.0}, "initial": {"y": 1.0}}
    ball_only = [{"kind": "spring", "on": "body1", "stiffness": 10.0}, {"kind": "constant", "on": "body2", "value": -4.905}]
    data, notes = weights_as_gravity({**body, "forces": ball_only}, scene_from_dict)
    assert notes == () and data["forces"] == ball_only and "gravity" not in data  # body 1 would fall too: a force
    both = [*ball_only, {"kind": "constant", "on": "body1", "value": -19.62}]
    data, notes = weights_as_gravity({**body, "forces": both}, scene_from_dict)
    assert data["gravity"] == -9.81 and data["forces"] == ball_only[:1]
    assert [n.split(":")[0] for n in notes] == ["forces[1]", "forces[2]"]
    assert "on body1 (mass1 2 kg)" in notes[1]


def test_only_files_are_read_so():
    # a scene given as data (a built-in, a dict, a trajectory file's scene_data) is taken as it is
    data = {"mass1": "inf", "mass2": 1.0, "restitution": 0.5, "gap": {"lower": 0.0}, "initial": {"y": 1.0},
            "forces": [{"kind": "constant", "on": "body2", "value": -9.81}]}
    scene = load_scene(data)
    assert scene.gravity == 0.0 and len(scene.forces) == 1 and scene.notes == ()
