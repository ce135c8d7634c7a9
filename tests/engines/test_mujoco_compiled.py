"""``mujoco_engine.compiled``: one compile per model structure, and the shared model is the compiled one byte for byte."""

import itertools

import mujoco
import numpy as np
import pytest

from chatterbench.engines.mujoco_engine import MujocoEngine, MujocoSettings, build, compiled
from chatterbench.engines.mujoco_engine.compiled import initial_state, shared_model, structure, variant
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.scene import load_scene

PRESCRIBED = ["mass1=inf", "prescribed.amplitude=0.05", "prescribed.omega=2.0", "initial.v1=0.1", "forces.0.on=coupling"]


def mjb(model: mujoco.MjModel) -> np.ndarray:
    """The model as MuJoCo saves it (MJB): every field, every name, every option."""
    buf = np.empty(mujoco.mj_sizeModel(model), np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return buf


@pytest.mark.parametrize("name", ["bouncing-ball", "feigin-pair"])
def test_a_shared_model_is_the_compiled_model_byte_for_byte(name):
    grid = itertools.product((1e-3, 3e-5), (0.03, 0.3), (0.0, 0.5, 0.9), ("euler", "implicitfast", "rk4"),
                             ("limit", "geom"), (0.99, 0.9))
    checked = 0
    for dt, w0_dt, r, integrator, gap_model, impedance in grid:
        scene = load_scene(name, [f"restitution={r}"])
        s = MujocoSettings(dt=dt, w0_dt=w0_dt, integrator=integrator, gap_model=gap_model, impedance=impedance)
        np.testing.assert_array_equal(mjb(shared_model(scene, s)), mjb(build(scene, s)))
        checked += 1
    assert checked == 144


def test_a_variant_with_a_wrong_contact_law_is_not_the_compiled_model():
    # the comparison above can fail: the geom contact's solref unscaled by d / d' (~0.7% off), or another timestep
    scene, s = load_scene("feigin-pair"), MujocoSettings(dt=1e-3, gap_model="geom")
    st = structure(scene, s)
    dt, k, b = compiled.contact(scene, s, st)
    assert st.factor != 1.0
    assert not np.array_equal(mjb(variant(st, (dt, k / st.factor, b / st.factor))), mjb(build(scene, s)))
    assert not np.array_equal(mjb(variant(st, (2 * dt, k, b))), mjb(build(scene, s)))
    np.testing.assert_array_equal(mjb(variant(st, (dt, k, b))), mjb(build(scene, s)))


def test_a_structure_is_shared_where_the_model_is_and_only_there():
    s = MujocoSettings(dt=1e-3)
    ball = load_scene("bouncing-ball")
    same = [load_scene("bouncing-ball", o) for o in (["initial.y=0.5"], ["duration=0.3"], ["initial.t=2.0"],
                                                     ["restitution=0.8"])]
    assert all(structure(scene, s) is structure(ball, s) for scene in same)
    assert structure(ball, MujocoSettings(dt=1e-4, w0_dt=0.3)) is structure(ball, s)  # dt and w0 dt: solref only
    other = [load_scene("bouncing-ball", ["mass2=2.0"]), load_scene("bouncing-ball", ["gap.lower=0.1"])]
    assert all(structure(scene, s) is not structure(ball, s) for scene in other)
    assert structure(ball, MujocoSettings(dt=1e-3, impedance=0.9)) is not structure(ball, s)
    # a fixed body 1's place is the model's: another x1 is another structure
    fixed = load_scene("feigin-pair", ["mass1=inf", "forces.0.on=coupling"])
    moved = load_scene("feigin-pair", ["mass1=inf", "forces.0.on=coupling", "initial.x1=0.5"])
    assert structure(fixed, s) is not structure(moved, s)


def test_settings_the_scene_cannot_run_with_are_refused_before_a_compile(monkeypatch):
    made = []
    original = compiled.spec_and_factor
    monkeypatch.setattr(compiled, "spec_and_factor", lambda *a: made.append(a) or original(*a))
    # R = 0.1: zeta 1.24, Euler's limit 0.70; the same w0 dt is stable for R = 0.5 (limit 1.55)
    with pytest.raises(SettingsError, match=r"mujoco\.w0_dt = 1\.4: must be in \(0, 0\.7046\]"):
        structure(load_scene("bouncing-ball", ["restitution=0.1", "mass2=1.2347"]), MujocoSettings(w0_dt=1.4))
    assert not made
    structure(load_scene("bouncing-ball", ["restitution=0.5", "mass2=1.2347"]), MujocoSettings(w0_dt=1.4))
    assert len(made) == 1


@pytest.mark.parametrize("overrides", [[], ["restitution=0.3", "initial.y=0.05", "initial.vy=-1.0", "initial.t=0.7"],
                                       PRESCRIBED])
def test_the_initial_state_is_a_fresh_mjdata_at_the_start(overrides):
    scene = load_scene("feigin-pair", overrides + ["initial.x1=0.02"] * ("mass1=inf" not in overrides))
    s = MujocoSettings(dt=1e-3)
    model = build(scene, s)
    data = mujoco.MjData(model)  # as the adapter set it up before: time, qpos, qvel, then mj_getState
    ini = scene.initial
    data.time = ini.t
    if scene.body1_infinite:
        data.qpos[0], data.qvel[0] = ini.y, ini.vy
    else:
        data.qpos[:], data.qvel[:] = [ini.x1, ini.y], [ini.v1, ini.vy]
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    want = np.empty(mujoco.mj_stateSize(model, full))
    mujoco.mj_getState(model, data, want, full)
    np.testing.assert_array_equal(initial_state(structure(scene, s), scene)[0], want)


def test_runs_that_differ_in_start_and_length_compile_one_model(monkeypatch):
    # before: every run compiled its model four times (validate in run_batch, validate in open, and the impedance
    # probe and the model in prepare): 60 strikes of a tune candidate, 240 compiles
    made = []
    original = compiled.spec_and_factor
    monkeypatch.setattr(compiled, "spec_and_factor", lambda *a: made.append(a) or original(*a))
    s = MujocoSettings(dt=1e-3)
    strikes = [(load_scene("bouncing-ball", ["mass2=1.2345", f"initial.y={0.1 + 0.05 * i}", f"initial.t={0.01 * i}",
                                             f"duration={0.2 + 0.01 * (i % 3)}"]), s) for i in range(12)]
    batch = MujocoEngine().run_batch(strikes)
    assert len(made) == 1 and all(t.status == "ok" for t in batch)
    alone = MujocoEngine().run(load_scene("bouncing-ball", ["mass2=1.2346"]), s)  # the single-run path: one build
    assert len(made) == 2 and alone.status == "ok"
    np.testing.assert_array_equal(MujocoEngine().run(*strikes[3]).y, batch[3].y)  # kept, and bit for bit
    assert len(made) == 2
