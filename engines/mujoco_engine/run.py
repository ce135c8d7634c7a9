"""Running MuJoCo: a whole trajectory in one ``mujoco.rollout`` call, compatible runs batched, blow-ups classified.

    >>> from chatterbench.engines.mujoco_engine.run import run
    >>> traj = run(load_scene("feigin-pair", ["duration=4"]), MujocoSettings(dt=1e-4))
    >>> traj.status, bool(traj.contact["lower"].any()), round(traj.contact_frequency)
    ('ok', True, 300)

Promises: one ``mujoco.rollout`` call runs the whole trajectory; ``run`` never raises from
inside MuJoCo for a user mistake (the settings are checked first); a blow-up is reported as
``status = "diverged"`` with the samples before it (autoreset is disabled so MuJoCo cannot
hide it by resetting the state); ``run_batch`` gives each run's trajectory bit for bit.
"""

from __future__ import annotations

import contextlib
import math
import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from chatterbench.reference.errors import check_integer
from chatterbench.reference.scene import Scene

from ..base import failed_trajectory, n_steps, sample_times
from ..restitution import contact_duration
from ..trajectory import Trajectory
from .model import build, build_spec, controls
from .settings import MujocoSettings

NAME = "mujoco"
MAXVAL = 1e10  # MuJoCo's mjMAXVAL: larger |qpos|, |qvel| count as a blow-up [m, m/s]


@contextlib.contextmanager
def _quiet_mujoco_log():
    """Silence MuJoCo's console and MUJOCO_LOG.TXT warnings while stepping: a blow-up is
    reported in the Trajectory (status, message with the warning names) instead."""
    saved = mujoco.MjLogConfig.get()
    quiet = mujoco.MjLogConfig.get()
    quiet.logto_console, quiet.logto_file = False, False
    quiet.set()
    try:
        yield
    finally:
        saved.set()


@dataclass
class _Prepared:
    """A compiled model with everything ``rollout`` needs, built before the clock starts."""

    model: mujoco.MjModel
    data: mujoco.MjData
    initial_state: np.ndarray  # (1, nstate)
    control: np.ndarray | None  # (1, nstep, ncontrol) or None
    control_spec: int
    nstep: int  # steps rolled out: n + 1 (the last gives the final sample's sensors)
    t: np.ndarray  # (n + 1,) sample times [s]


def _prepare(scene: Scene, s: MujocoSettings, n: int) -> _Prepared:
    model = build(scene, s)
    data = mujoco.MjData(model)
    ini = scene.initial
    data.time = ini.t
    if scene.body1_infinite:
        data.qpos[0], data.qvel[0] = ini.y, ini.vy
    else:
        data.qpos[:] = [ini.x1, ini.y]
        data.qvel[:] = [ini.v1, ini.vy]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state0, spec)

    t = sample_times(scene, s.dt)
    parts = []
    control_spec = 0
    if model.nu:
        parts.append(controls(scene, s, t))
        control_spec |= mujoco.mjtState.mjSTATE_CTRL
    if model.nmocap:  # mocap_pos comes after ctrl in mjtState order; held over step k at x1(t_{k})
        mpos = np.zeros((n + 1, 3))
        mpos[:, 0] = scene.prescribed.position(t)
        parts.append(mpos)
        control_spec |= mujoco.mjtState.mjSTATE_MOCAP_POS
    control = np.ascontiguousarray(np.concatenate(parts, axis=1)[None]) if parts else None
    return _Prepared(model, data, state0[None], control, int(control_spec) or int(mujoco.mjtState.mjSTATE_CTRL), n + 1, t)


def _rollout(p: _Prepared) -> tuple[np.ndarray, np.ndarray]:
    state, sensordata = mj_rollout.rollout(
        p.model, p.data, p.initial_state, p.control, control_spec=p.control_spec, nstep=p.nstep
    )
    return state[0], sensordata[0]


def _settings_record(scene: Scene, s: MujocoSettings) -> dict[str, Any]:
    """The settings as run, by MuJoCo's names: ours, and the solref / solimp they make."""
    zeta = s.zeta(scene.restitution)
    return {
        **dataclasses.asdict(s),
        "w0": s.w0,
        "zeta": zeta,
        "solref": [-s.w0**2, -2.0 * zeta * s.w0],
        "solimp": [s.impedance, s.impedance, 0.001, 0.5, 2.0],
        "mujoco_version": mujoco.__version__,
    }


def _failed(scene: Scene, record: dict[str, Any], status: str, message: str) -> Trajectory:
    return failed_trajectory(NAME, scene, status, message, record)


def run(scene: Scene, settings: MujocoSettings | None = None) -> Trajectory:
    """Simulate ``scene.duration`` seconds from ``scene.initial`` (see ``trajectory.py`` for shapes).

    Raises
    ------
    SettingsError
        Settings the scene cannot run with (checked before MuJoCo is called). Everything
        that goes wrong inside MuJoCo is returned as ``status = "error"`` instead.
    """
    s = settings or MujocoSettings()
    record = _settings_record(scene, s)
    n = n_steps(scene.duration, s.dt)
    build_spec(scene, s)  # settings errors surface here, as SettingsError, before MuJoCo runs
    try:
        p = _prepare(scene, s, n)
        with _quiet_mujoco_log():
            start = time.perf_counter()
            state, sensordata = _rollout(p)
            wall = time.perf_counter() - start
    except Exception as exc:  # an engine failure is a result, not a crash
        return _failed(scene, record, "error", f"{type(exc).__name__}: {exc}")
    return _trajectory(scene, s, p, state, sensordata, wall, record)


def _signature(p: _Prepared) -> tuple:
    """What must agree for runs to share one ``rollout`` call: sizes, steps, control layout."""
    return (p.model.signature, p.initial_state.shape[1], p.nstep, p.control_spec,
            None if p.control is None else p.control.shape[2])


def run_batch(jobs: list[tuple[Scene, MujocoSettings]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs, each group of compatible models in one ``rollout`` call.

    Runs whose compiled models share a size signature, step count and control layout (they
    may differ in anything rollout takes per model: restitution, masses, gap, initial
    state and time, forcing, w0 dt, solver options, integrator) go to ``mujoco.rollout`` as
    one batch (a list of models); the others run alone. Each trajectory is the one ``run``
    gives, bit for bit; its ``wall_time`` is its share of its batch's stepping time (batch
    wall / batch size) and ``settings["batch_size"]`` says how many shared the call.
    A batch in which MuJoCo raised a warning (a possible blow-up: the warnings are counted
    per MjData, not per run) is rerun one run at a time, so that a diverged run is
    classified alone. Raises SettingsError, like ``run``, before anything runs.
    """
    for scene, s in jobs:
        build_spec(scene, s)  # settings errors first, for every job
    out: list[Trajectory | None] = [None] * len(jobs)
    groups: dict[tuple, list[tuple[int, _Prepared]]] = {}
    for i, (scene, s) in enumerate(jobs):
        try:
            p = _prepare(scene, s, n_steps(scene.duration, s.dt))
        except Exception as exc:  # an engine failure is a result, not a crash
            out[i] = _failed(scene, _settings_record(scene, s), "error", f"{type(exc).__name__}: {exc}")
            continue
        groups.setdefault(_signature(p), []).append((i, p))
    for members in groups.values():
        if len(members) == 1:
            i, _ = members[0]
            out[i] = run(*jobs[i])
            continue
        ps = [p for _, p in members]
        data = mujoco.MjData(ps[0].model)
        try:
            with _quiet_mujoco_log():
                start = time.perf_counter()
                state, sensordata = mj_rollout.rollout(
                    [p.model for p in ps], data, np.concatenate([p.initial_state for p in ps]),
                    None if ps[0].control is None else np.concatenate([p.control for p in ps]),
                    control_spec=ps[0].control_spec, nstep=ps[0].nstep)
                wall = time.perf_counter() - start
        except Exception:  # rerun alone: each run's own failure is then its own result
            state = None
        if state is None or any(w.number > 0 for w in data.warning):
            for i, _ in members:
                out[i] = run(*jobs[i])
            continue
        for k, (i, p) in enumerate(members):
            scene, s = jobs[i]
            record = {**_settings_record(scene, s), "batch_size": len(members)}
            out[i] = _trajectory(scene, s, p, state[k], sensordata[k], wall / len(members), record)
    return out  # type: ignore[return-value]


def _trajectory(scene, s, p: _Prepared, state, sensordata, wall, record) -> Trajectory:
    model, n = p.model, p.nstep - 1
    nq = model.nq
    ini = scene.initial
    # sample 0 is the initial state; rollout row k is the state after step k + 1
    qpos = np.concatenate([p.initial_state[:, 1 : 1 + nq], state[:n, 1 : 1 + nq]])
    qvel = np.concatenate([p.initial_state[:, 1 + nq : 1 + 2 * nq], state[:n, 1 + nq : 1 + 2 * nq]])
    t = p.t
    # rows of sensordata are computed at the start of each step, i.e. at samples 0..n
    sens = sensordata[: n + 1]

    status, message = "ok", ""
    bad = ~(np.isfinite(qpos).all(axis=1) & np.isfinite(qvel).all(axis=1) & np.isfinite(sens).all(axis=1))
    bad |= (np.abs(qpos) > MAXVAL).any(axis=1) | (np.abs(qvel) > MAXVAL).any(axis=1)
    times = np.concatenate([[ini.t], state[:n, 0]])
    bad |= np.abs(times - t) > 1e-6 * max(s.dt, abs(t[-1]) * 1e-3)  # a reset would rewind time
    warned = [w for w in ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")
              if p.data.warning[int(getattr(mujoco.mjtWarning, w))].number > 0]
    if bad.any() or warned:
        first = int(np.argmax(bad)) if bad.any() else len(t)
        status = "diverged"
        message = (f"non-finite or huge state at t = {t[first]:.6g} s (sample {first}); "
                   f"MuJoCo warnings: {', '.join(warned) or 'none'}; w0_dt = {s.w0_dt}, integrator = {s.integrator}")
        keep = slice(0, first)
        qpos, qvel, sens, t = qpos[keep], qvel[keep], sens[keep], t[keep]

    if scene.body1_infinite:
        if scene.prescribed is not None:
            x1, v1 = scene.prescribed.position(t), scene.prescribed.velocity(t)
        else:
            x1, v1 = np.full(len(t), ini.x1), np.zeros(len(t))
        y, vy = qpos[:, 0], qvel[:, 0]
    else:
        x1, v1, y, vy = qpos[:, 0], qvel[:, 0], qpos[:, 1], qvel[:, 1]

    walls = scene.gap.walls
    if s.gap_model == "limit":
        f = np.maximum(sens[:, 0], 0.0)
        if len(walls) == 2:
            upper_side = y > 0.5 * (scene.gap.lower + scene.gap.upper)  # only the wall y is beyond can push
            force = {"lower": np.where(upper_side, 0.0, f), "upper": np.where(upper_side, f, 0.0)}
        else:
            force = {"lower": f}
    else:
        force = {w: np.maximum(sens[:, 3 * i], 0.0) for i, w in enumerate(walls)}
    zeta = s.zeta(scene.restitution)
    return Trajectory(
        engine=NAME, t=t, x1=x1, x2=x1 + y, v1=v1, v2=v1 + vy,
        contact={w: force[w] > 0.0 for w in walls}, normal_force=force,
        wall_time=wall, settings=record, status=status, message=message,
        contact_time=contact_duration(zeta, s.w0), contact_frequency=s.w0,
    )


def benchmark(scene: Scene, settings: MujocoSettings | None = None, steps: int = 200_000, repeats: int = 3) -> dict[str, Any]:
    """Steps per second of ``run`` (all adapter work: build, controls, rollout, arrays) and of the
    bare ``mujoco.rollout`` on the same model and controls, measured in the same call (best of
    ``repeats``; ``steps`` per repeat).

    Returns a dict with ``adapter_steps_per_s``, ``raw_steps_per_s``, ``ratio`` (adapter / raw),
    ``n_steps``, ``repeats``, ``scene``, ``mujoco_version``.
    """
    check_integer("steps", steps, lo=1)
    check_integer("repeats", repeats, lo=1)
    s = settings or MujocoSettings()
    short = dataclasses.replace(scene, duration=steps * s.dt)
    n = n_steps(short.duration, s.dt)
    p = _prepare(short, s, n)
    raw, adapter = math.inf, math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        _rollout(p)
        raw = min(raw, time.perf_counter() - start)
        start = time.perf_counter()
        traj = run(short, s)
        adapter = min(adapter, time.perf_counter() - start)
    return {
        "scene": scene.name,
        "n_steps": n,
        "repeats": repeats,
        "adapter_steps_per_s": n / adapter,
        "raw_steps_per_s": p.nstep / raw,
        "ratio": (n / adapter) / (p.nstep / raw),
        "status": traj.status,
        "mujoco_version": mujoco.__version__,
    }
