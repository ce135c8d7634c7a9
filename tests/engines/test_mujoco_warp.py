"""MuJoCo Warp on warp's CPU device: a batch of bouncing balls judged, and its conformance with MuJoCo C measured.

The first test to step MuJoCo Warp on a machine compiles its kernels (about a minute on
the CPU device, cached by warp under ~/.cache/warp afterwards): one module-scoped batch
does it once and every test reads that batch.
"""

import dataclasses

import numpy as np
import pytest

from chatterbench.comparisons import compare
from chatterbench.comparisons.pipeline.conformance import conformance, parting
from chatterbench.engines.mujoco_engine import MujocoSettings
from chatterbench.engines.mujoco_engine import MujocoEngine
from chatterbench.engines.registry import make_settings, settings_for
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.scene import load_scene

pytest.importorskip("mujoco_warp", reason="the warp extra is not installed: pip install \".[warp]\"")

from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, MujocoWarpSettings, world_steps_per_s  # noqa: E402

run, run_batch, mujoco_batch = MujocoWarpEngine().run, MujocoWarpEngine().run_batch, MujocoEngine().run_batch
from chatterbench.engines.mujoco_warp_engine import kernels, rigs  # noqa: E402
from chatterbench.engines.mujoco_warp_engine.worlds import device_name  # noqa: E402

DT = 1e-3  # [s] short runs: 2000 steps of the bouncing ball
# a few worlds in one batch: the scene as built in, a bouncier ball, a lower drop, the built-in
# ball run with a wrong R (0.55 for 0.5: the known-wrong run the judge must catch), and the
# built-in ball with a stiff contact (w0 dt = 1), where the two executors part
OVERRIDES = ([], ["restitution=0.8"], ["initial.y=0.5"], ["restitution=0.55"], [])
STIFF = 4
WARP = MujocoWarpSettings(dt=DT, device="cpu")


@pytest.fixture(scope="module")
def batch():
    scenes = [load_scene("bouncing-ball", o) for o in OVERRIDES]
    w0_dts = [1.0 if i == STIFF else WARP.w0_dt for i in range(len(scenes))]
    warp = run_batch([(s, dataclasses.replace(WARP, w0_dt=w)) for s, w in zip(scenes, w0_dts)])
    c = mujoco_batch([(s, MujocoSettings(dt=DT, w0_dt=w)) for s, w in zip(scenes, w0_dts)])
    return scenes, warp, c


@pytest.mark.slow
def test_a_batch_is_one_model_of_many_worlds_each_the_run_alone(batch):
    scenes, warp, _ = batch
    assert [t.status for t in warp] == ["ok"] * len(scenes)
    assert {t.settings["batch_size"] for t in warp} == {len(scenes)}  # R and the drop height are per-world fields
    alone = run(scenes[1], WARP)
    # the same float32 kernels on the same inputs, world 1 of 4 or world 0 of 1: bit for bit
    np.testing.assert_array_equal(alone.y, warp[1].y)
    np.testing.assert_array_equal(alone.normal_force["lower"], warp[1].normal_force["lower"])


@pytest.mark.slow
def test_every_row_says_what_computed_it(batch):
    _, warp, _ = batch
    for t in warp:
        assert t.engine == "mujoco_warp"
        assert t.settings["precision"] == "float32" and t.settings["device"] == "cpu"
        assert t.settings["mujoco_warp_version"] and t.settings["warmup_s"] >= 0.0
        assert t.contact_frequency == pytest.approx(t.settings["w0_dt"] / DT)  # MuJoCo's contact law, run by warp


@pytest.mark.slow
def test_float32_follows_float64_closely_but_not_exactly(batch):
    _, warp, c = batch
    for w, m in list(zip(warp, c))[:STIFF]:
        dy = np.abs(w.y - m.y)
        # float32 rounding (~6e-8 relative per operation) over 2000 steps and ~8 soft impacts,
        # measured up to ~2e-5 m on a 1 m drop: 1e-3 m is 1% of the bounce heights that matter
        assert dy.max() < 1e-3
        assert dy.max() > 0.0  # float32 is not float64: no test pretends they are equal
        # contact flags and forces as the MuJoCo engine reports them: the same impacts, to a sample
        onsets = [np.flatnonzero(t.contact["lower"][1:] & ~t.contact["lower"][:-1]) for t in (w, m)]
        assert len(onsets[0]) == len(onsets[1]) and np.abs(onsets[0] - onsets[1]).max() <= 1


@pytest.mark.slow
def test_its_runs_are_judged_and_the_conformance_says_where_they_differ(batch):
    scenes, warp, c = batch
    scene = scenes[0]
    result = compare(scene, settings=settings_for(("mujoco", "mujoco_warp"), DT),
                     trajectories={"mujoco": c[0], "mujoco_warp": warp[0]})
    verdicts = result.table.set_index("engine")["verdict"]
    assert verdicts["mujoco_warp"] == verdicts["mujoco"]  # at dt = 1e-3 float32 does not change the verdict
    table = conformance(result, "mujoco", "mujoco_warp")
    assert len(table) == 1 and not table["disagree"].any()
    # the difference is measured, not assumed zero: sticking starts differ by a few float32 roundings
    assert 0.0 < abs(table["stick_difference"].iloc[0]) < 0.01 * scene.duration
    assert parting(result).y_difference_max > 0.0


@pytest.mark.slow
def test_a_wrong_restitution_in_warp_is_caught_by_judge_and_conformance(batch):
    scenes, warp, c = batch
    wrong = dataclasses.replace(warp[3], engine="mujoco_warp")  # R = 0.55 run, judged as the R = 0.5 scene
    result = compare(scenes[0], settings=settings_for(("mujoco", "mujoco_warp"), DT),
                     trajectories={"mujoco": c[0], "mujoco_warp": wrong})
    table = conformance(result, "mujoco", "mujoco_warp")
    assert table["disagree"].all()
    # R 10% high: a longer chatter (Zeno point 1.56 s for 1.35 s) that the soft contact at this dt
    # does not finish within the run, with fewer impacts: MuJoCo C sticks, the wrong run does not
    row = table.iloc[0]
    assert row["t_stick"] > 0 and np.isnan(row["other_t_stick"]) and row["impact_count_difference"] < 0


def test_settings_refuse_what_mujoco_warp_lacks():
    with pytest.raises(SettingsError, match=r"mujoco_warp\.precision = 'float64': must be one of float32"):
        MujocoWarpSettings(precision="float64")
    with pytest.raises(SettingsError, match=r"mujoco_warp\.solver = 'PGS': must be one of Newton, CG"):
        make_settings("mujoco_warp", overrides=["mujoco_warp.solver='PGS'"])
    with pytest.raises(SettingsError, match=r"mujoco_warp\.w0_dt = 5\.0: must be in \(0, "):
        MujocoWarpSettings(w0_dt=5.0)
    with pytest.raises(SettingsError, match=r"mujoco_warp\.device = 'gpu': must be one of auto, cpu, cuda"):
        MujocoWarpSettings(device="gpu")


def test_cuda_without_a_gpu_is_refused_before_running():
    if device_name("auto") == "cuda":
        pytest.skip("this machine has a CUDA device")
    with pytest.raises(SettingsError, match="no CUDA device"):
        run(load_scene("bouncing-ball", ["duration=0.01"]), MujocoWarpSettings(dt=DT, device="cuda"))


@pytest.mark.slow
def test_where_the_executors_differ_the_conformance_says_where_and_by_how_much(batch):
    # measured, not assumed: with a stiff contact (w0 dt = 1, 3 steps per contact) at dt = 1e-3
    # MuJoCo C never sticks before the end (missed), MuJoCo Warp does (late), after 186 contact
    # onsets to MuJoCo C's 5; they agree in flight and part after the first impact (0.45 s)
    scenes, warp, c = batch
    result = compare(scenes[STIFF], settings=settings_for(("mujoco", "mujoco_warp"), DT),
                     trajectories={"mujoco": c[STIFF], "mujoco_warp": warp[STIFF]})
    table = conformance(result, "mujoco", "mujoco_warp")
    assert table["disagree"].all()
    part = parting(result)
    assert 0.45 < part.t_part < 2.0 and part.y_difference_max > part.threshold


@pytest.mark.slow
def test_a_blow_up_is_judged_diverged_not_raised():
    # w0 dt = 2.5 is past the Euler stability limit (~1.55 for R = 0.5): the damper's free mass,
    # pressed on a wall, blows up (MuJoCo C: qacc past 1e10 at t = 0.226 s, status "diverged").
    # MuJoCo Warp's acceleration stalls near 3e8 in float32 while the state runs off, so neither
    # MuJoCo's qacc nor its state bound trips; the judge's energy bound catches it
    scene = load_scene("impact-damper", ["duration=0.4"])
    s = MujocoWarpSettings(dt=DT, w0_dt=2.5, allow_unstable=True, device="cpu")
    traj = run(scene, s)
    assert traj.status in ("ok", "diverged") and np.abs(traj.vy).max() > 1e3  # ran, and ran away
    result = compare(scene, engines=("mujoco_warp",), trajectories={"mujoco_warp": traj})
    assert set(result.table["verdict"]) == {"diverged"}
    assert result.runs["mujoco_warp"].t_diverged < 0.3  # before the state left any sane range


def test_world_steps_per_second_is_measured_on_the_device_found():
    scene = load_scene("bouncing-ball", ["duration=0.02"])  # 20 steps, 21 with the last sample's sensors
    plain = world_steps_per_s(scene, WARP, nworld=8, repeats=1, captured=False)
    assert plain["device"] == "cpu" and plain["nworld"] == 8 and plain["steps"] == 21 and not plain["captured"]
    assert plain["world_steps_per_s"] == pytest.approx(8 * 21 / plain["seconds"])
    captured = world_steps_per_s(scene, WARP, nworld=8, repeats=1)  # whole graphs of STEPS_PER_GRAPH steps
    if captured["captured"]:
        whole = -(-21 // kernels.STEPS_PER_GRAPH) * kernels.STEPS_PER_GRAPH  # 24: six graphs of 4 steps
        assert captured["steps"] == whole and captured["world_steps_per_s"] == pytest.approx(8 * whole / captured["seconds"])


# -- one device model for many worlds, captured steps, blocks within the host's memory ------------------------
from chatterbench.engines.mujoco_common import prepare  # noqa: E402
from chatterbench.engines.mujoco_engine import build  # noqa: E402
from chatterbench.engines.mujoco_warp_engine import batch as warp_batch, kernels  # noqa: E402
from chatterbench.engines.mujoco_warp_engine.worlds import _same, put_worlds, warp_model, warp_modules  # noqa: E402

# one group (the same sizes and step count): R, w0 dt, dt (with the duration, so that the steps agree), the start
VARIED = [(["restitution=0.5"], 1e-3, 0.03), (["restitution=0.8", "initial.y=0.5"], 1e-3, 0.03),
          (["restitution=0.3", "initial.vy=-1.0", "initial.t=0.3"], 1e-3, 0.1),
          (["duration=0.15", "initial.y=0.7"], 5e-4, 0.3)]


def _varied():
    return [(load_scene("bouncing-ball", ["duration=0.3"] + o), MujocoWarpSettings(dt=dt, w0_dt=w, device="cpu"))
            for o, dt, w in VARIED]


def test_one_device_model_holds_each_world_as_its_own_compiled_model():
    jobs = _varied()
    ps = [prepare(scene, s, 300) for scene, s in jobs]
    assert len({id(p.structure) for p in ps}) == 1  # one compile for all four
    worlds = put_worlds(ps, "cpu")
    assert set(worlds.varying) == {"opt.timestep", "jnt_solref"}
    wp, mjw = warp_modules()

    def row(model, w):
        return [a.numpy()[w % a.shape[0]] for a in (model.opt.timestep, model.jnt_solref)]

    for w, (scene, s) in enumerate(jobs):
        with wp.ScopedDevice("cpu"):
            own = mjw.put_model(warp_model(build(scene, s)))  # the run's own model, put on the device alone
        for mine, theirs in zip(row(worlds.model, w), row(own, 0)):
            np.testing.assert_array_equal(mine, theirs)  # float32 rows, bit for bit
        assert _same(worlds.model.body_mass, own.body_mass) and _same(worlds.model.jnt_range, own.jnt_range)
    # the comparison can fail: world 1's row is not world 0's model
    assert not np.array_equal(row(worlds.model, 1)[1], row(worlds.model, 0)[1])


def test_a_batch_is_each_run_alone_and_float32_of_mujoco_c():
    # the must-show: a batched study's runs bit for bit as one at a time (MuJoCo Warp with MuJoCo Warp), and
    # within float32 of MuJoCo C run on the same settings
    jobs = _varied()
    batch = MujocoWarpEngine().run_batch(jobs)
    assert {t.settings["batch_size"] for t in batch} == {len(jobs)} and all(t.status == "ok" for t in batch)
    for (scene, s), traj in zip(jobs, batch):
        alone = run(scene, s)
        for k in ("t", "x1", "x2", "v1", "v2"):
            np.testing.assert_array_equal(getattr(alone, k), getattr(traj, k))
        np.testing.assert_array_equal(alone.normal_force["lower"], traj.normal_force["lower"])
        c = MujocoEngine().run(scene, MujocoSettings(dt=s.dt, w0_dt=s.w0_dt))
        dy = np.abs(c.y - traj.y).max()
        # float32 rounding (~6e-8 relative per operation) over 300 steps and a few soft impacts on a drop of
        # at most 0.7 m: measured below 1e-5 m; 1e-4 m holds with margin, and float32 is not float64 (> 0)
        assert 0.0 < dy < 1e-4


def test_captured_steps_are_the_launched_steps_bit_for_bit(monkeypatch):
    if not kernels.graphs("cpu"):
        pytest.skip("this warp cannot capture a graph on the CPU device (warp < 1.17)")
    scene, s = load_scene("feigin-pair", ["duration=0.5"]), MujocoWarpSettings(dt=1e-3, device="cpu")
    rigs.drop_all()  # a rig kept by an earlier test would lend its capture (capture_s 0)
    captured = run(scene, s)
    monkeypatch.setattr(kernels, "graphs", lambda device: False)  # every step launched from Python instead
    launched = run(scene, s)
    assert captured.settings["capture_s"] > 0.0 and launched.settings["capture_s"] == 0.0
    for k in ("t", "x1", "x2", "v1", "v2"):
        np.testing.assert_array_equal(getattr(captured, k), getattr(launched, k))


@pytest.mark.parametrize("name", ["bouncing-ball", "feigin-pair", "impact-damper", "spring-pair"])
def test_a_run_in_a_kept_rig_is_the_run_in_a_fresh_one_bit_for_bit(name):
    # a tune's runs one after another in a worker: the second, at another dt (1,500 steps, not 1,200: a world's chunk
    # arrays hold both; both past rigs.SHORT_STEPS, so one world each) and another w0 dt (its contact rows), steps in
    # the first's rig (its captured steps reused, its data reset), and gives the bits of a fresh rig: walls, springs,
    # a driven body 1 (controls, mocap)
    scene = load_scene(name, ["duration=0.3"])
    first, second = dataclasses.replace(WARP, dt=2.5e-4, w0_dt=0.1), dataclasses.replace(WARP, dt=2e-4, w0_dt=0.3)
    assert 0.3 / first.dt > rigs.SHORT_STEPS
    rigs.drop_all()
    run(scene, first)
    (rig,) = rigs.idle()
    _spoil(rig.data)  # whatever a run leaves in its data (forces applied, warm starts) must not reach the next
    kept = run(scene, second)
    rigs.drop_all()
    fresh = run(scene, second)
    if kernels.graphs("cpu"):
        assert kept.settings["capture_s"] == 0.0 < fresh.settings["capture_s"]  # reused, not captured again
    assert kept.status == fresh.status == "ok"
    for k in ("t", "x1", "x2", "v1", "v2"):
        np.testing.assert_array_equal(getattr(kept, k), getattr(fresh, k))
    for wall in fresh.normal_force:
        np.testing.assert_array_equal(kept.normal_force[wall], fresh.normal_force[wall])
    # the comparison can fail: the first run's bits are not the second's
    assert not np.array_equal(run(scene, first).x2, kept.x2)


def _spoil(data) -> None:
    """Every array of a ``mujoco_warp.Data`` filled with 7 (nested dataclasses too)."""
    for f in dataclasses.fields(data):
        value = getattr(data, f.name)
        if dataclasses.is_dataclass(value):
            _spoil(value)
        elif hasattr(value, "fill_"):
            value.fill_(7)


def test_a_block_of_fewer_worlds_than_its_rig_steps_each_run_as_alone():
    # 5 worlds step in a rig of 8 (the others copies of the last, unread), after a block of 7 used it
    scene = load_scene("bouncing-ball", ["duration=0.3"])
    jobs = [(scene, dataclasses.replace(WARP, w0_dt=w)) for w in (0.1, 0.2, 0.3, 0.15, 0.25, 0.12, 0.22)]
    rigs.drop_all()
    run_batch(jobs)
    five = run_batch(jobs[:5])
    assert {t.settings["batch_size"] for t in five} == {5} and rigs.world_slots(5) == rigs.world_slots(7) == 8
    if kernels.graphs("cpu"):
        assert five[0].settings["capture_s"] == 0.0
    for (sc, st), traj in zip(jobs, five):
        rigs.drop_all()
        alone = run(sc, st)
        for k in ("t", "x1", "x2", "v1", "v2"):
            np.testing.assert_array_equal(getattr(alone, k), getattr(traj, k))


def test_short_blocks_of_two_to_sixteen_worlds_share_one_rig_and_each_runs_as_alone():
    # a tune's strikes come in blocks of 2 to 12 worlds of a few hundred steps: each size once took a rig of its
    # own (2, 8, 16 worlds), each rig a first capture; a short block (rigs.SHORT_STEPS) now steps 16 worlds, and a
    # run alone keeps a rig of one world (16 would triple its steps once its rig is kept)
    scene = load_scene("bouncing-ball", ["duration=1.0"])
    jobs = [(scene, dataclasses.replace(WARP, w0_dt=0.1 + 0.015 * i)) for i in range(12)]
    assert 0.0 < 1.0 / WARP.dt <= rigs.SHORT_STEPS
    rigs.drop_all()
    run_batch(jobs[:2])
    twelve = run_batch(jobs)
    assert [r.slots for r in rigs.idle()] == [16]  # one rig served both blocks
    if kernels.graphs("cpu"):
        assert twelve[0].settings["capture_s"] == 0.0
    for k in (0, 11):
        rigs.drop_all()
        alone = run(*jobs[k])
        assert [r.slots for r in rigs.idle()] == [1]
        for name in ("t", "x1", "x2", "v1", "v2"):
            np.testing.assert_array_equal(getattr(alone, name), getattr(twelve[k], name))
    # a long block keeps its own size: 20,000 steps of 2 worlds step 2
    assert rigs.world_slots(2, nstep=20_000) == 2 and rigs.world_slots(2, nstep=rigs.SHORT_STEPS) == 16


def test_a_block_of_one_world_in_a_rig_of_sixteen_is_its_run_alone(monkeypatch):
    # the first short-block rule put one world in a rig of 16 and assigned its states and controls as one row
    # to 16 worlds' arrays (rigs._padded left a single row as it was): its run went wrong from step 513
    scene = load_scene("bouncing-ball", ["duration=1.0"])  # 1,000 steps: past 512
    job = (scene, dataclasses.replace(WARP, w0_dt=0.3))
    rigs.drop_all()
    alone = run(*job)
    rigs.drop_all()
    monkeypatch.setattr(rigs, "world_slots", lambda nworld, nstep=None: 16)
    (one,) = run_batch([job])
    assert [r.slots for r in rigs.idle()] == [16] and one.settings["batch_size"] == 1
    for name in ("t", "x1", "x2", "v1", "v2"):
        np.testing.assert_array_equal(getattr(alone, name), getattr(one, name))
    rigs.drop_all()


def test_a_batch_larger_than_the_host_budget_goes_in_blocks_with_the_same_runs():
    jobs = [(load_scene("bouncing-ball", ["duration=0.3", f"initial.y={0.3 + 0.1 * i}"]), WARP) for i in range(5)]
    whole = MujocoWarpEngine().run_batch(jobs)
    small = MujocoWarpEngine()
    small.host_bytes = 2 * 301 * 49 + 2 * warp_batch.WORLD_BYTES + 2 * 304 * 176  # two worlds of 300 steps a block
    blocks = list(warp_batch.iter_blocks(small, jobs, small.host_bytes))
    assert [[i for i, _ in block] for block in blocks] == [[0, 1], [2, 3], [4]]  # each block handed on when done
    assert [t.settings["batch_size"] for block in blocks for _, t in block] == [2, 2, 2, 2, 1]
    for (_, traj), ref in zip([x for block in blocks for x in block], whole):
        np.testing.assert_array_equal(traj.y, ref.y)
    assert [i for i, _ in small.iter_batch(jobs)] == [0, 1, 2, 3, 4]


@pytest.mark.parametrize("nworld, samples", [(1, 21), (1, 400_001), (64, 2_001), (4_096, 6_285), (65_536, 501),
                                             (262_144, 6_285)])
def test_a_block_and_its_chunk_fit_the_host_budget(nworld, samples):
    plan = warp_batch.block_plan(nworld, samples, walls=2, row_floats=5)
    kept = samples * (40 + 9 * 2) + warp_batch.WORLD_BYTES
    assert plan.worlds * (kept + plan.chunk * (warp_batch.STEP_BYTES + 4 * 5)) <= warp_batch.HOST_BYTES
    assert plan.chunk % kernels.STEPS_PER_GRAPH == 0 and 1 <= plan.worlds <= nworld
    assert plan.chunk >= min(samples, warp_batch.FEW_STEPS)  # a short run in one chunk, a long one in long chunks


def test_the_first_run_note_names_the_device():
    assert isinstance(MujocoWarpEngine.first_run_note, str)  # the contract's fact, on the class
    assert f"for device {device_name('auto')} " in MujocoWarpEngine().first_run_note


def test_the_kernels_load_is_timed_and_said():
    traj = run(load_scene("bouncing-ball", ["duration=0.01"]), WARP)
    assert traj.settings["kernels"] in ("compiled", "cached") and traj.settings["warmup_s"] >= 0.0
    load = kernels.KernelLoad("cuda", 84.2, True, "/root/.cache/warp/1.19.0")
    assert load.describe() == ("MuJoCo Warp compiled its kernels for device cuda in 84.2 s "
                               "(cache: /root/.cache/warp/1.19.0)")


def test_a_batch_refuses_any_jobs_bad_settings_before_running_one(monkeypatch):
    ran = []
    monkeypatch.setattr(warp_batch, "run_block", lambda *a: ran.append(a) or [None] * len(a[0]))
    ok = (load_scene("bouncing-ball", ["duration=0.01"]), WARP)
    unstable = (load_scene("bouncing-ball", ["duration=0.01", "restitution=0.1"]), dataclasses.replace(WARP, w0_dt=1.4))
    with pytest.raises(SettingsError, match=r"mujoco_warp\.w0_dt = 1\.4: must be in \(0, 0\.7046\]"):
        MujocoWarpEngine().run_batch([ok, unstable])
    if device_name("auto") != "cuda":
        with pytest.raises(SettingsError, match="no CUDA device"):
            MujocoWarpEngine().run_batch([ok, (ok[0], dataclasses.replace(WARP, device="cuda"))])
    assert not ran


def test_runs_of_different_lengths_share_a_batch_each_read_to_its_own_end():
    # a strike study's or a plate map's runs end at different times: one batch steps the longest, each world is read
    # to its own end, bit for bit the run alone
    jobs = [(load_scene("feigin-pair", [f"duration={d}", f"initial.vy={v}"]), WARP)
            for d, v in ((0.05, -0.3), (0.3, 0.4), (0.137, -0.2), (0.3, 0.1))]
    batch = MujocoWarpEngine().run_batch(jobs)
    assert [len(t.t) for t in batch] == [51, 301, 138, 301] and {t.settings["batch_size"] for t in batch} == {4}
    for (scene, s), traj in zip(jobs, batch):
        alone = run(scene, s)
        assert traj.status == alone.status == "ok"
        for k in ("t", "x1", "x2", "v1", "v2"):
            np.testing.assert_array_equal(getattr(alone, k), getattr(traj, k))
    assert batch[0].wall_time < batch[1].wall_time  # each charged its share of the steps


def test_runs_of_two_integrators_go_as_a_block_per_integrator_each_the_run_alone():
    # a tune pass's candidates differ in the integrator, a field MuJoCo Warp shares between worlds: the runs of each
    # compiled structure share one model (before: every run of such a batch went alone, batch size 1)
    scene = load_scene("bouncing-ball", ["duration=0.3"])
    jobs = [(scene, dataclasses.replace(WARP, dt=dt, integrator=i, w0_dt=w))
            for dt, i, w in ((1e-3, "euler", 0.1), (1e-3, "implicitfast", 0.1), (5e-4, "euler", 0.3),
                             (5e-4, "implicitfast", 0.3), (2e-4, "euler", 0.2))]
    batch = MujocoWarpEngine().run_batch(jobs)
    assert [t.settings["batch_size"] for t in batch] == [3, 2, 3, 2, 3]
    for (sc, s), traj in zip(jobs, batch):
        alone = run(sc, s)
        for k in ("t", "x1", "x2", "v1", "v2"):
            np.testing.assert_array_equal(getattr(alone, k), getattr(traj, k))
    # each world says what computed it (a soft constraint contact with no joint damping steps alike in both)
    assert [t.settings["integrator"] for t in batch] == [s.integrator for _, s in jobs]
