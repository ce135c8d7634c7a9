"""Running MuJoCo Warp: the adapter, many worlds stepped together on a warp device, each world one run, float32.

    >>> from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, MujocoWarpSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = MujocoWarpEngine().run(load_scene("bouncing-ball", ["duration=0.2"]), MujocoWarpSettings(dt=1e-3, device="cpu"))
    >>> traj.status, traj.engine, traj.settings["precision"], traj.settings["device"]
    ('ok', 'mujoco_warp', 'float32', 'cpu')

Each run is the MuJoCo engine's own model (``mujoco_engine.model.build``: the same MjSpec,
contact law, forces and precomputed controls), adapted by ``worlds.warp_model`` and put on
the device as one world. ``roll_batch`` puts compatible runs (same sizes, step count and
control layout, any per-world parameter: masses, R, gap, springs, forcing, initial state)
into one MuJoCo Warp model of many worlds; one ``mujoco_warp.step`` advances them all.
Per step, one small kernel records every world's state and sensors on the device and loads
the next step's controls (``ctrl``, and ``mocap_pos`` for a prescribed body), as
``mujoco.rollout`` does for MuJoCo C; every ``window.CHUNK`` samples the chunk comes back and
goes to the run's ``base.Recording`` as MuJoCo's do (``mujoco_common.take``: contact flags and
forces from the same sensors, blow-ups, a long run kept compact), so memory stays bounded.

Promises: sample k is the state after k steps and its contact force the one MuJoCo Warp
computed at the start of step k (MuJoCo's rollout convention, so the two engines'
trajectories line up sample by sample); the arrays are float32 values widened to float64;
MuJoCo C's blow-up checks hold (a state past ``MAXVAL`` or not finite, and its qacc check,
done on the device: an acceleration past ``base.MAXVAL`` drops the states after it);
``settings["precision"]`` and ``settings["device"]`` say what computed them; a run never
raises from inside MuJoCo Warp (``status = "error"`` / ``"diverged"``, as for MuJoCo); the
kernel compilation of a first run (tens of seconds on the CPU device, then cached by warp
under ``~/.cache/warp``) is not counted in ``wall_time`` but reported as
``settings["warmup_s"]``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from typing import Any, Sequence

import numpy as np

from chatterbench.reference.errors import check_integer
from chatterbench.reference.scene import Scene

from .. import mujoco_common
from ..base import MAXVAL, Diverged, EngineAdapter, Recording, n_steps, version_of
from ..mujoco_common import Prepared, prepare, rollout_controls, take, warning_note
from ..trajectory import Trajectory
from ..window import CHUNK
from .settings import MujocoWarpSettings
from .worlds import Incompatible, Worlds, device_name, put_worlds, warp_model, warp_modules


@functools.cache
def _record_kernel():
    """The per-step kernel: store the state after step k0 + j and the sensors of its start, check its
    acceleration, load the controls of the next step of the chunk."""
    wp, _ = warp_modules()
    maxval = wp.constant(wp.float32(MAXVAL))

    @wp.kernel
    def record(j: int, k0: int, qpos: wp.array2d(dtype=wp.float32), qvel: wp.array2d(dtype=wp.float32),
               qacc: wp.array2d(dtype=wp.float32), sensordata: wp.array2d(dtype=wp.float32),
               ctrl: wp.array2d(dtype=wp.float32), mocap_pos: wp.array2d(dtype=wp.vec3),
               ctrl_in: wp.array3d(dtype=wp.float32), mocap_in: wp.array3d(dtype=wp.vec3),
               qpos_out: wp.array3d(dtype=wp.float32), qvel_out: wp.array3d(dtype=wp.float32),
               sens_out: wp.array3d(dtype=wp.float32), bad_acc: wp.array(dtype=wp.int32)):
        w = wp.tid()
        for i in range(qpos.shape[1]):
            qpos_out[j, w, i] = qpos[w, i]
        for i in range(qvel.shape[1]):
            qvel_out[j, w, i] = qvel[w, i]
        for i in range(sensordata.shape[1]):
            sens_out[j, w, i] = sensordata[w, i]
        for i in range(qacc.shape[1]):
            # MuJoCo C's mj_checkAcc (mjWARN_BADQACC): an acceleration past mjMAXVAL or not finite
            if not (wp.abs(qacc[w, i]) <= maxval) and bad_acc[w] > k0 + j:
                bad_acc[w] = k0 + j
        if j + 1 < ctrl_in.shape[0]:
            for i in range(ctrl.shape[1]):
                ctrl[w, i] = ctrl_in[j + 1, w, i]
            for i in range(mocap_pos.shape[1]):
                mocap_pos[w, i] = mocap_in[j + 1, w, i]

    return record


def _inputs(ps: list[Prepared], k0: int, k1: int) -> tuple[np.ndarray, np.ndarray]:
    """Controls (k1 - k0, nworld, nu) and mocap positions (k1 - k0, nworld, nmocap, 3) of steps k0 .. k1 - 1."""
    model = ps[0].model
    ctrl = np.zeros((k1 - k0, len(ps), model.nu), np.float32)
    mocap = np.zeros((k1 - k0, len(ps), model.nmocap, 3), np.float32)
    for w, p in enumerate(ps):
        control = rollout_controls(p, k0, k1)  # MuJoCo's rollout input, (1, k1 - k0, nu + 3 nmocap)
        if control is not None:
            ctrl[:, w] = control[0, :, : model.nu]
            mocap[:, w] = control[0, :, model.nu :].reshape(k1 - k0, model.nmocap, 3)
    return ctrl, mocap


def _roll_worlds(worlds: Worlds, ps: list[Prepared], runs: list[Recording]) -> tuple[list[set[str]], float, float]:
    """Step every world ``nstep`` times from its initial state with its controls, ``window.CHUNK`` samples of all
    of them at a time, each chunk handed to its run (``mujoco_common.take``, as MuJoCo's are).

    Returns each run's MuJoCo warnings (an acceleration past MAXVAL: MuJoCo C's mjWARN_BADQACC, and the
    states after it dropped), the stepping wall time [s] and the kernels' loading (first time: compiling) time [s].
    """
    wp, mjw = warp_modules()
    p0, nw = ps[0], len(ps)
    mjm, nstep, s0 = p0.model, p0.nstep, p0.settings
    names: list[set[str]] = [set() for _ in ps]
    chunk = max(256, CHUNK // nw)
    with wp.ScopedDevice(worlds.device):
        start = time.perf_counter()
        mjw.step(worlds.model, mjw.put_data(mjm, p0.data))  # loads (the first time compiles) the kernels
        wp.synchronize()
        warmup = time.perf_counter() - start
        d = mjw.put_data(mjm, p0.data, nworld=nw)
        d.qpos.assign(np.stack([p.data.qpos for p in ps]).astype(np.float32))
        d.qvel.assign(np.stack([p.data.qvel for p in ps]).astype(np.float32))
        d.time.assign(np.array([p.data.time for p in ps], np.float32))
        out = [wp.zeros((min(chunk, nstep), nw, size), dtype=wp.float32) for size in (mjm.nq, mjm.nv, mjm.nsensordata)]
        bad_acc = wp.array(np.full(nw, nstep, np.int32), dtype=wp.int32)
        before = [p.initial_state[0] for p in ps]  # the state at each chunk's first sample, rollout's layout
        wall = 0.0
        for k0 in range(0, nstep, chunk):
            k1 = min(nstep, k0 + chunk)
            ctrl, mocap = _inputs(ps, k0, k1)
            ctrl_in, mocap_in = wp.array(ctrl, dtype=wp.float32), wp.array(mocap, dtype=wp.vec3)
            if mjm.nu:
                d.ctrl.assign(ctrl[0])
            if mjm.nmocap:
                d.mocap_pos.assign(mocap[0])
            record = wp.launch(_record_kernel(), dim=nw, record_cmd=True,
                               inputs=[0, k0, d.qpos, d.qvel, d.qacc, d.sensordata, d.ctrl, d.mocap_pos, ctrl_in,
                                       mocap_in, *out, bad_acc])
            wp.synchronize()
            start = time.perf_counter()
            for j in range(k1 - k0):
                mjw.step(worlds.model, d)
                record.set_param_at_index(0, j)
                record.launch()
            wp.synchronize()
            wall += time.perf_counter() - start
            qpos, qvel, sens = (a.numpy()[: k1 - k0].astype(np.float64) for a in out)
            bad = bad_acc.numpy()
            times = s0.dt * np.arange(k0 + 1, k1 + 1)
            for w, (p, r) in enumerate(zip(ps, runs)):
                # the rollout layout ``take`` reads: row j = time, qpos, qvel after step k0 + j
                state = np.concatenate([(p.scene.initial.t + times)[:, None], qpos[:, w], qvel[:, w]], axis=1)
                if bad[w] < k1 and not r.stopped:
                    state[int(bad[w]) - k0:, 1:] = np.nan
                    names[w].add("mjWARN_BADQACC")
                if not r.stopped:
                    take(r, p, k0, before[w], state, sens[:, w])
                before[w] = state[-1]
            if all(r.stopped for r in runs):
                break
    return names, wall, warmup


def _group(runs: list[Recording], ps: list[Prepared], device: str) -> list[Exception | None]:
    """Step the runs as the worlds of one MuJoCo Warp model (each alone when they cannot share one); each run's
    failure (None: none) for ``Recording.trajectory``."""
    models = [dataclasses.replace(p, model=warp_model(p.model)) for p in ps]
    try:
        worlds = put_worlds([p.model for p in models], device)
    except Incompatible:
        return [failure for r, p in zip(runs, ps) for failure in _group([r], [p], device)]
    try:
        names, wall, warmup = _roll_worlds(worlds, models, runs)
    except Exception as exc:  # noqa: BLE001  an engine failure is a result, not a crash
        return [exc] * len(runs)
    for r in runs:
        r.wall_time = wall / len(runs)
        r.record.update(batch_size=len(runs), warmup_s=warmup)
    return [Diverged(warning_note(warned, r.settings)) if warned else None for r, warned in zip(runs, names)]


def _signature(p: Prepared) -> tuple:
    """What must agree for runs to share one model: sizes, steps, controls (MuJoCo's ``run._signature``)."""
    return (p.model.signature, p.nstep, p.model.nu, p.model.nmocap)


def roll_batch(engine: EngineAdapter, jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs; each group of compatible runs as the worlds of one MuJoCo Warp model.

    Compatible: same model sizes, step count, controls layout and device, and no difference
    outside MuJoCo Warp's per-world fields (``worlds.put_worlds``); the others run apart.
    ``settings["batch_size"]`` says how many worlds shared the call and ``wall_time`` is the
    run's share of its batch's stepping time. Raises SettingsError, like ``run``, before
    anything runs (a device that is not there is such an error).
    """
    for scene, s in jobs:
        engine.validate(scene, engine.settings(s))  # settings errors first, for every job
    out: list[Trajectory | None] = [None] * len(jobs)
    groups: dict[tuple, list[tuple[int, Recording, Prepared]]] = {}
    for i, (scene, s) in enumerate(jobs):
        try:  # MuJoCo's model and initial state
            run = engine.open(scene, s)
            p = prepare(scene, run.settings, run.n)
        except Exception:  # noqa: BLE001  alone, its failure is its own result
            out[i] = engine.run(scene, s)
            continue
        groups.setdefault((run.record["device"], _signature(p)), []).append((i, run, p))
    for (dev, _), members in groups.items():
        failures = _group([r for _, r, _ in members], [p for _, _, p in members], dev)
        for (i, r, _), failure in zip(members, failures):
            out[i] = r.trajectory(failure)
    return out  # type: ignore[return-value]  # every job is in a group or failed


def device(s: MujocoWarpSettings) -> str:
    """The warp device of settings ``s``; a device that is not there is the user's SettingsError."""
    from ..settings import SettingsError

    try:
        return device_name(s.device)
    except RuntimeError as exc:
        raise SettingsError(str(exc)) from None


class MujocoWarpEngine(EngineAdapter):
    """MuJoCo Warp behind the engine contract (``base.EngineAdapter``): MuJoCo's soft contact in float32."""

    name = "mujoco_warp"
    package = "mujoco-warp"
    settings_type = MujocoWarpSettings
    compliant = True
    precision = "float32"
    batches = True
    bytes_per_step = 250.0  # per world: MuJoCo's samples (float64 on the host) and float32 copies on the device
    bench_step_cap = 2_000  # a step's cost is flat after the first few (launch-bound on the cpu device)
    same_model_as = "mujoco"  # MuJoCo's own MjSpec model (mujoco_common), stepped by warp in float32
    first_run_note = ("the first run on a machine compiles MuJoCo Warp's kernels (about a minute on the CPU; cached "
                      "under ~/.cache/warp), then steps at 1.5-3 ms a step on the CPU device")

    def simulate(self, run: Recording) -> None:
        """One run as a model of one world; ``Diverged`` for MuJoCo's acceleration warning."""
        (failure,) = _group([run], [prepare(run.scene, run.settings, run.n)], run.record["device"])
        if failure is not None:
            raise failure

    def run_batch(self, jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> list[Trajectory]:
        """Compatible runs as the worlds of one MuJoCo Warp model (``roll_batch``)."""
        return roll_batch(self, list(jobs))

    def bare_seconds(self, scene: Scene, settings: MujocoWarpSettings, traj: Trajectory) -> float:
        """Seconds of the bare ``mujoco_warp.step`` loop over the run, one world."""
        return world_steps_per_s(scene, settings, nworld=1, repeats=1)["seconds"]

    def validate(self, scene: Scene, settings: MujocoWarpSettings) -> None:
        """MuJoCo's MjSpec build refuses what the scene cannot run with; a device warp does not find is refused."""
        mujoco_common.build_spec(scene, settings)
        device(settings)

    def record(self, scene: Scene, settings: MujocoWarpSettings) -> dict[str, Any]:
        """MuJoCo's record, and what computed the run: precision, device, versions."""
        return {**mujoco_common.record(scene, settings), "precision": settings.precision, "device": device(settings),
                "mujoco_warp_version": version_of("mujoco-warp"), "warp_version": warp_modules()[0].__version__}

    def contact_scales(self, scene: Scene, settings: MujocoWarpSettings) -> tuple[float, float]:
        """MuJoCo's (``mujoco_common.contact_scales``): the same model."""
        return mujoco_common.contact_scales(scene, settings)

    def snippet(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> str:
        """The scene's model as MJCF (``mujoco_common.export_mjcf``), to load with ``mujoco_warp.put_model``."""
        return mujoco_common.export_mjcf(scene, settings or MujocoWarpSettings())


def world_steps_per_s(scene: Scene, settings: MujocoWarpSettings | None = None, nworld: int = 1,
                      repeats: int = 3) -> dict[str, Any]:
    """World-steps per second of the bare ``mujoco_warp.step`` loop: ``nworld`` copies of ``scene`` stepped
    ``n_steps(scene.duration, dt)`` times, best of ``repeats`` (kernels loaded before the clock starts).

    Returns ``device``, ``nworld``, ``steps``, ``seconds`` (best repeat), ``world_steps_per_s``, ``warmup_s``.
    """
    check_integer("nworld", nworld, lo=1)
    check_integer("repeats", repeats, lo=1)
    s = settings or MujocoWarpSettings()
    wp, mjw = warp_modules()
    dev = device(s)
    p = prepare(scene, s, n_steps(scene.duration, s.dt))
    model = warp_model(p.model)
    worlds = put_worlds([model], dev)
    with wp.ScopedDevice(dev):
        d = mjw.put_data(model, p.data, nworld=nworld)
        if model.nu:
            d.ctrl.assign(np.tile(rollout_controls(p, 0, 1)[0, :, : model.nu].astype(np.float32), (nworld, 1)))
        start = time.perf_counter()
        mjw.step(worlds.model, d)
        wp.synchronize()
        warmup, best = time.perf_counter() - start, math.inf
        for _ in range(repeats):
            start = time.perf_counter()
            for _ in range(p.nstep):
                mjw.step(worlds.model, d)
            wp.synchronize()
            best = min(best, time.perf_counter() - start)
    return {"device": dev, "nworld": nworld, "steps": p.nstep, "seconds": best,
            "world_steps_per_s": nworld * p.nstep / best, "warmup_s": warmup}
