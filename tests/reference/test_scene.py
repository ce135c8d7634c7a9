"""Scene validation: every refusal is a SceneError naming the field and what is allowed."""

from __future__ import annotations

import dataclasses
import math

import pytest

from chatterbench.reference import Force, Gap, Initial, Prescribed, Scene, SceneError, load_scene, scene_from_dict
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import split_assignment


def test_catalogue_scenes_load():
    for name in CATALOGUE:
        scene = load_scene(name)
        assert scene.name == name
        assert 0.0 <= scene.restitution < 1.0


def test_docstring_example():
    scene = load_scene("feigin-pair", overrides=["restitution=0.8"])
    # exact: plain decimal literals, no arithmetic
    assert (scene.mu, scene.gap.upper, scene.restitution) == (1.0, 0.1, 0.8)


# -- out-of-range values ---------------------------------------------------------------
# (override, words the message must contain: the field and the allowed range)
BAD_VALUES = [
    ("restitution=1.0", ["restitution", "[0, 1)"]),
    ("restitution=1.5", ["restitution", "[0, 1)"]),
    ("restitution=-0.1", ["restitution", "[0, 1)"]),
    ("mass1=0.0", ["mass1", "> 0"]),
    ("mass1=-1.0", ["mass1", "> 0"]),
    ("mass2=0.0", ["mass2", "> 0"]),
    ("mass2=-2.0", ["mass2", "> 0"]),
    ("gap.upper=-0.1", ["gap.upper", "> gap.lower"]),
    ("gap.upper=-0.2", ["gap.upper", "> gap.lower"]),
    ("initial.y=0.2", ["initial.y", "[-0.1, 0.1]"]),
    ("initial.y=-0.1000001", ["initial.y", "[-0.1, 0.1]"]),
    ("duration=0.0", ["duration", "> 0"]),
    ("forces.0.omega=0.0", ["forces[0]", "omega", "> 0"]),
]


@pytest.mark.parametrize("override,words", BAD_VALUES)
def test_out_of_range_values_are_refused(override, words):
    with pytest.raises(SceneError) as err:
        load_scene("feigin-pair", [override])
    for w in words:
        assert w in str(err.value)


def test_initial_y_below_one_sided_gap():
    with pytest.raises(SceneError, match=r"initial\.y = -0\.5: must lie in the gap, >= 0\.0"):
        load_scene("bouncing-ball", ["initial.y=-0.5"])


def test_lower_equal_upper_is_refused():
    with pytest.raises(SceneError, match=r"gap\.upper = 0\.0: must be > gap\.lower = 0\.0"):
        Gap(lower=0.0, upper=0.0)


# every numeric field of the feigin-pair, as a --set key
NUMERIC_KEYS = [
    "restitution", "mass2", "duration", "gravity",
    "gap.lower", "gap.upper",
    "initial.t", "initial.x1", "initial.v1", "initial.y", "initial.vy",
    "forces.0.amplitude", "forces.0.omega", "forces.0.phase",
]


@pytest.mark.parametrize("key", NUMERIC_KEYS)
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_non_finite_numbers_are_refused(key, value):
    with pytest.raises(SceneError) as err:
        load_scene("feigin-pair", [f"{key}={value}"])
    msg = str(err.value)
    field = key.split(".")[-1]
    assert field in msg
    assert "finite" in msg or "must" in msg


def test_non_finite_mass1():
    # nan is refused; +inf is the documented spelling of a fixed/prescribed body 1
    with pytest.raises(SceneError, match="mass1"):
        load_scene("feigin-pair", ["mass1=nan"])
    with pytest.raises(SceneError, match="mass1"):
        load_scene("feigin-pair", ["mass1=-inf"])
    assert load_scene("bouncing-ball", ["mass1=inf"]).body1_infinite


@pytest.mark.parametrize("section,key", [("spring", "stiffness"), ("spring", "rest"), ("damper", "damping")])
def test_non_finite_force_parameters(section, key):
    # impact-damper forces: 0 spring, 1 damper, 2 harmonic
    index = {"spring": 0, "damper": 1}[section]
    with pytest.raises(SceneError, match=rf"forces\[{index}\].*{key}.*finite"):
        load_scene("impact-damper", [f"forces.{index}.{key}=nan"])


def test_prescribed_non_finite_and_omega():
    with pytest.raises(SceneError, match=r"prescribed\.amplitude = nan: must be a finite number"):
        Prescribed(amplitude=math.nan)
    with pytest.raises(SceneError, match=r"prescribed\.omega = 0\.0: must be > 0"):
        Prescribed(omega=0.0)


def test_non_numbers_are_refused():
    with pytest.raises(SceneError, match=r"restitution = 'half': must be a number"):
        load_scene("feigin-pair", ['restitution="half"'])
    with pytest.raises(SceneError, match=r"initial\.y = True: must be a number"):
        Initial(y=True)


# -- unknown keys and names, with the nearest valid name --------------------------------
@pytest.mark.parametrize(
    "mutate,words",
    [
        (lambda d: d.update(restitutoin=0.5), ["restitutoin", "did you mean 'restitution'"]),
        (lambda d: d["gap"].update(uper=0.2), ["gap.uper", "did you mean 'upper'"]),
        (lambda d: d["initial"].update(vyy=0.0), ["initial.vyy", "did you mean 'vy'"]),
        (lambda d: d["forces"][0].update(amplitud=1.0), ["forces[0].amplitud", "did you mean 'amplitude'"]),
        (lambda d: d["forces"][0].update(kind="harmonik"), ["forces[0].kind", "did you mean 'harmonic'"]),
        (lambda d: d["forces"][0].update(on="body"), ["force on", "did you mean"]),
    ],
)
def test_unknown_keys_suggest_the_nearest(mutate, words):
    import copy

    data = copy.deepcopy(CATALOGUE["feigin-pair"])
    mutate(data)
    with pytest.raises(SceneError) as err:
        scene_from_dict(data)
    for w in words:
        assert w in str(err.value)


def test_unknown_override_key_suggests():
    with pytest.raises(SceneError, match=r"did you mean 'restitution'"):
        load_scene("feigin-pair", ["restitutio=0.5"])
    with pytest.raises(SceneError, match=r"initial\.vy.*did you mean 'vy'"):
        load_scene("feigin-pair", ["initial.vyy=0.5"])


def test_missing_required_field():
    data = dict(CATALOGUE["feigin-pair"])
    del data["mass2"]
    with pytest.raises(SceneError, match=r"mass2: missing"):
        scene_from_dict(data)


def test_unknown_scene_name():
    with pytest.raises(SceneError, match=r"not a built-in scene.*did you mean 'feigin-pair'"):
        load_scene("feigin-par")


def test_set_without_equals():
    with pytest.raises(SceneError, match=r"expected KEY=VALUE"):
        load_scene("feigin-pair", ["restitution0.8"])
    with pytest.raises(SceneError, match=r"expected KEY=VALUE"):
        split_assignment("duration")
    with pytest.raises(SceneError, match=r"empty key"):
        split_assignment("=3")


def test_malformed_toml(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("mass1 = [1.0,\nrestitution = \n")
    with pytest.raises(SceneError, match=r"broken\.toml.*not valid TOML"):
        load_scene(path)


def test_missing_toml_file(tmp_path):
    with pytest.raises(SceneError, match=r"cannot be read"):
        load_scene(tmp_path / "nowhere.toml")


def test_infinite_body_with_body1_force_is_refused():
    with pytest.raises(SceneError, match=r"no effect when mass1 = inf"):
        load_scene("feigin-pair", ["mass1=inf"])


def test_infinite_body_initial_state_must_match_its_motion():
    # a fixed body 1 sits wherever initial.x1 puts it, but cannot move
    with pytest.raises(SceneError, match=r"initial\.x1.*fixed.*v1 = 0\.0"):
        load_scene("bouncing-ball", ["initial.v1=0.5"])
    # a prescribed one must start on its prescribed path (1e-9 is the scene's own tolerance)
    with pytest.raises(SceneError, match=r"prescribed"):
        scene_from_dict({**PRESCRIBED, "initial": {**PRESCRIBED["initial"], "x1": 0.0}})


# -- round trip through TOML -----------------------------------------------------------
def _handwritten_toml(data: dict) -> str:
    """Minimal TOML writer for the scene layout (tables, one array of tables, scalars)."""

    def scalar(v):
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        return repr(float(v)) if isinstance(v, float) else repr(v)

    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list):
            continue
        else:
            lines.append(f"{k} = {scalar(v)}")
    for k, v in tables:
        lines.append(f"[{k}]")
        lines += [f"{kk} = {scalar(vv)}" for kk, vv in v.items()]
    for f in data.get("forces", []):
        lines.append("[[forces]]")
        lines += [f"{kk} = {scalar(vv)}" for kk, vv in f.items()]
    return "\n".join(lines) + "\n"


PRESCRIBED = {
    "name": "shaker",
    "mass1": "inf",
    "mass2": 0.2,
    "restitution": 0.7,
    "gap": {"lower": 0.0},
    "forces": [{"kind": "constant", "on": "body2", "value": -1.962}],
    "prescribed": {"amplitude": 0.01, "omega": 30.0, "phase": 0.25, "offset": 0.0},
    "initial": {"t": 0.0, "x1": 0.01 * math.sin(0.25), "v1": 0.3 * math.cos(0.25), "y": 0.05, "vy": 0.0},
    "duration": 1.0,
}


@pytest.mark.parametrize("source", [*CATALOGUE, "prescribed"])
def test_toml_round_trip(tmp_path, source):
    scene = scene_from_dict(PRESCRIBED) if source == "prescribed" else load_scene(source)
    data = scene.to_dict()
    text = _handwritten_toml(data)
    path = tmp_path / f"{scene.name}.toml"
    path.write_text(text)
    # exact equality: TOML floats round-trip the shortest repr, so nothing may change
    assert load_scene(path) == scene


def test_constructed_scene_equals_loaded():
    scene = Scene(
        name="bouncing-ball",
        mass1=math.inf,
        mass2=1.0,
        restitution=0.5,
        gap=Gap(lower=0.0),
        gravity=-9.81,  # an acceleration since issue 41: the ball falls at g whatever its mass
        initial=Initial(y=1.0),
        duration=2.0,
        description=CATALOGUE["bouncing-ball"]["description"],
    )
    assert scene == load_scene("bouncing-ball")
    # a scene built in code keeps its constant force a force (only a file's weight is read as gravity, weight.py)
    weighed = dataclasses.replace(scene, gravity=0.0, forces=(Force(kind="constant", on="body2", value=-9.81),))
    assert weighed != scene and weighed.forces and weighed.gravity == 0.0
