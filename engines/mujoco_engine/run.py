"""Running MuJoCo: ``mujoco.rollout`` chunk by chunk into a recorder, compatible runs batched, blow-ups classified.

    >>> from chatterbench.engines.mujoco_engine.run import run
    >>> traj = run(load_scene("feigin-pair", ["duration=4"]), MujocoSettings(dt=1e-4))
    >>> traj.status, bool(traj.contact["lower"].any()), round(traj.contact_frequency)
    ('ok', True, 300)

Promises: ``mujoco.rollout`` runs the trajectory in chunks of ``window.CHUNK`` steps (the full
physics state carried from one to the next: the samples are those of one call, bit for bit),
each chunk's samples go to a ``window.Recorder`` (a long run comes back compact); ``run`` never raises from
inside MuJoCo for a user mistake (the settings are checked first); a blow-up is reported as
``status = "diverged"`` with the samples before it (autoreset is disabled so MuJoCo cannot
hide it by resetting the state); ``run_batch`` gives each run's trajectory bit for bit.
MuJoCo's own ``rollout`` call over a whole run would hold every step's full state and sensor
data (about 190 B a step); chunks hold ``CHUNK`` steps of it at a time.
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

from ..base import failed_trajectory, n_steps
from ..restitution import contact_duration
from ..trajectory import Trajectory
from ..window import CHUNK, Recorder
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
class Prepared:
    """A compiled model with everything ``rollout`` needs, built before the clock starts."""

    scene: Scene
    settings: MujocoSettings
    model: mujoco.MjModel
    data: mujoco.MjData
    initial_state: np.ndarray  # (1, nstate)
    control_spec: int
    nstep: int  # steps rolled out: n + 1 (the last gives the final sample's sensors)


def prepare(scene: Scene, s: MujocoSettings, n: int) -> Prepared:
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
    control_spec = 0
    if model.nu:
        control_spec |= mujoco.mjtState.mjSTATE_CTRL
    if model.nmocap:
        control_spec |= mujoco.mjtState.mjSTATE_MOCAP_POS
    return Prepared(scene, s, model, data, state0[None], int(control_spec) or int(mujoco.mjtState.mjSTATE_CTRL), n + 1)


def rollout_controls(p: Prepared, k0: int, k1: int) -> np.ndarray | None:
    """Rollout's control input for steps k0 .. k1 - 1, shape (1, k1 - k0, ncontrol), or None (no controls)."""
    t = p.scene.initial.t + p.settings.dt * np.arange(k0, k1)  # = sample_times(scene, dt)[k0:k1], bit for bit
    parts = []
    if p.model.nu:
        parts.append(controls(p.scene, p.settings, t))
    if p.model.nmocap:  # mocap_pos comes after ctrl in mjtState order; held over step k at x1(t_{k})
        mpos = np.zeros((len(t), 3))
        mpos[:, 0] = p.scene.prescribed.position(t)
        parts.append(mpos)
    return np.ascontiguousarray(np.concatenate(parts, axis=1)[None]) if parts else None


def settings_record(scene: Scene, s: MujocoSettings) -> dict[str, Any]:
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


def failed_run(scene: Scene, record: dict[str, Any], status: str, message: str, engine: str = NAME) -> Trajectory:
    """The trajectory of a run that failed before its first step (``base.failed_trajectory``), named ``engine``."""
    return failed_trajectory(engine, scene, status, message, record)


_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")


class RunRecord:
    """One run's samples as its chunks come out of ``rollout``: checked, converted, handed to its recorder."""

    def __init__(self, p: Prepared, compact_above: float | None, engine: str = NAME) -> None:
        self.p, self.engine = p, engine  # engine: the name the trajectory carries (mujoco_warp records with this class too)
        self.recorder = Recorder(p.scene, p.nstep, compact_above)
        self.bad_at = -1  # the first non-finite, huge or rewound sample (-1: none yet)
        self.warned: set[str] = set()
        t_end = p.scene.initial.t + p.settings.dt * (p.nstep - 1)
        self.time_slack = 1e-6 * max(p.settings.dt, abs(t_end) * 1e-3)  # [s] a reset would rewind time

    def take(self, k0: int, before: np.ndarray, state: np.ndarray, sensordata: np.ndarray) -> None:
        """Samples k0 .. k0 + c - 1 from ``before`` (the state at sample k0), ``state`` (c rows: after each
        step) and ``sensordata`` (c rows, computed at the start of each step, i.e. at the samples)."""
        if self.bad_at >= 0:
            return
        p, scene, s = self.p, self.p.scene, self.p.settings
        nq = p.model.nq
        c = len(state)
        rows = np.concatenate([before[None], state[:c - 1]])  # the state at samples k0 .. k0 + c - 1
        qpos, qvel, sens = rows[:, 1:1 + nq], rows[:, 1 + nq:1 + 2 * nq], sensordata
        t = scene.initial.t + s.dt * np.arange(k0, k0 + c)  # = sample_times(scene, dt)[k0:k0 + c]
        bad = ~(np.isfinite(qpos).all(axis=1) & np.isfinite(qvel).all(axis=1) & np.isfinite(sens).all(axis=1))
        bad |= (np.abs(qpos) > MAXVAL).any(axis=1) | (np.abs(qvel) > MAXVAL).any(axis=1)
        bad |= np.abs(rows[:, 0] - t) > self.time_slack
        if bad.any():
            m = int(np.argmax(bad))
            self.bad_at = k0 + m
            qpos, qvel, sens, t = qpos[:m], qvel[:m], sens[:m], t[:m]
        if scene.body1_infinite:
            if scene.prescribed is not None:
                x1, v1 = scene.prescribed.position(t), scene.prescribed.velocity(t)
            else:
                x1, v1 = np.full(len(t), scene.initial.x1), np.zeros(len(t))
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
        self.recorder.add(t, x1, v1, x1 + y, v1 + vy, {w: force[w] > 0.0 for w in walls}, force)

    def note_warnings(self, data: mujoco.MjData) -> None:
        self.warned |= {w for w in _WARNINGS if data.warning[int(getattr(mujoco.mjtWarning, w))].number > 0}

    def trajectory(self, wall: float, record: dict[str, Any]) -> Trajectory:
        s = self.p.settings
        status, message = "ok", ""
        if self.bad_at >= 0 or self.warned:
            status = "diverged"
            at = self.bad_at if self.bad_at >= 0 else self.p.nstep - 1
            message = (f"non-finite or huge state at t = {self.p.scene.initial.t + s.dt * at:.6g} s (sample {at}); "
                       f"MuJoCo warnings: {', '.join(sorted(self.warned, key=_WARNINGS.index)) or 'none'}; "
                       f"w0_dt = {s.w0_dt}, integrator = {s.integrator}")
        zeta = s.zeta(self.p.scene.restitution)
        return self.recorder.trajectory(self.engine, wall, settings=record, status=status, message=message,
                                        contact_time=contact_duration(zeta, s.w0), contact_frequency=s.w0)


def _roll(ps: list[Prepared], compact_above: float | None) -> tuple[list[RunRecord], float]:
    """Roll ``ps`` out, ``CHUNK`` steps of each in turn, each from where its last chunk ended.

    Each run has its own MjData: a chunk starts from the full physics state the last one ended
    in and its solver warm start (``initial_warmstart``), so the samples are bit for bit those of
    one call, and MuJoCo's warnings are each run's own. A run that goes bad stops there.
    Returns each run and the stepping wall time.
    """
    runs = [RunRecord(p, compact_above) for p in ps]
    states = [p.initial_state for p in ps]
    warm: list[np.ndarray | None] = [None] * len(ps)  # None: MjData's own (zero) warm start, as one call starts
    nstep, wall = ps[0].nstep, 0.0
    for k0 in range(0, nstep, CHUNK):
        k1 = min(nstep, k0 + CHUNK)
        for b, (p, r) in enumerate(zip(ps, runs)):
            if r.bad_at >= 0:
                continue
            control = rollout_controls(p, k0, k1)
            start = time.perf_counter()
            state, sensordata = mj_rollout.rollout(p.model, p.data, states[b], control, control_spec=p.control_spec,
                                                   nstep=k1 - k0, initial_warmstart=warm[b])
            wall += time.perf_counter() - start
            r.note_warnings(p.data)
            r.take(k0, states[b][0], state[0], sensordata[0])
            states[b], warm[b] = state[:, -1].copy(), p.data.qacc_warmstart[None].copy()
        if all(r.bad_at >= 0 for r in runs):
            break
    return runs, wall


def run(scene: Scene, settings: MujocoSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """Simulate ``scene.duration`` seconds from ``scene.initial`` (see ``trajectory.py`` for shapes).

    ``compact_above``: hand on a compact trajectory when the run has more samples than this
    (default ``window.COMPACT_ABOVE``; ``math.inf``: always full).

    Raises
    ------
    SettingsError
        Settings the scene cannot run with (checked before MuJoCo is called). Everything
        that goes wrong inside MuJoCo is returned as ``status = "error"`` instead.
    """
    s = settings or MujocoSettings()
    record = settings_record(scene, s)
    n = n_steps(scene.duration, s.dt)
    build_spec(scene, s)  # settings errors surface here, as SettingsError, before MuJoCo runs
    try:
        p = prepare(scene, s, n)
        with _quiet_mujoco_log():
            (one,), wall = _roll([p], compact_above)
    except Exception as exc:  # an engine failure is a result, not a crash
        return failed_run(scene, record, "error", f"{type(exc).__name__}: {exc}")
    return one.trajectory(wall, record)


def _signature(p: Prepared) -> tuple:
    """What must agree for runs to share one ``rollout`` call: sizes, steps, control layout."""
    return (p.model.signature, p.initial_state.shape[1], p.nstep, p.control_spec, p.model.nu, p.model.nmocap)


def run_batch(jobs: list[tuple[Scene, MujocoSettings]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs; compatible models roll out together, chunk by chunk.

    Runs whose compiled models share a size signature, step count and control layout (they
    may differ in anything rollout takes per model: restitution, masses, gap, initial
    state and time, forcing, w0 dt, solver options, integrator) go through ``_roll`` as one
    group, a chunk of each in turn (so that at most a chunk of each is in memory); the others
    run alone. Each trajectory is the one ``run`` gives, bit for bit (every run has its own
    MjData); its ``wall_time`` is its share of its group's stepping time (group wall / group
    size) and ``settings["batch_size"]`` says how many shared it. A group in which MuJoCo
    warned (a possible blow-up) is rerun one run at a time, so that a diverged run is
    classified alone; a group of one already is that run, and is not rolled twice. Raises
    SettingsError, like ``run``, before anything runs.
    """
    for scene, s in jobs:
        build_spec(scene, s)  # settings errors first, for every job
    out: list[Trajectory | None] = [None] * len(jobs)
    groups: dict[tuple, list[tuple[int, Prepared]]] = {}
    for i, (scene, s) in enumerate(jobs):
        try:
            p = prepare(scene, s, n_steps(scene.duration, s.dt))
        except Exception as exc:  # an engine failure is a result, not a crash
            out[i] = failed_run(scene, settings_record(scene, s), "error", f"{type(exc).__name__}: {exc}")
            continue
        groups.setdefault(_signature(p), []).append((i, p))
    for members in groups.values():
        try:
            with _quiet_mujoco_log():
                runs, wall = _roll([p for _, p in members], None)
        except Exception:  # rerun alone: each run's own failure is then its own result
            runs = None
        if runs is not None and len(members) == 1:  # a group of one is the run alone, rolled as run() rolls it
            (i, _), (r,) = members[0], runs
            out[i] = r.trajectory(wall, settings_record(*jobs[i]))
            continue
        if runs is None or any(r.warned or r.bad_at >= 0 for r in runs):
            for i, _ in members:  # a possible blow-up is run and classified alone, as one call
                out[i] = run(*jobs[i])
            continue
        for (i, _), r in zip(members, runs):
            scene, s = jobs[i]
            out[i] = r.trajectory(wall / len(members), {**settings_record(scene, s), "batch_size": len(members)})
    return out  # type: ignore[return-value]


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
    p = prepare(short, s, n)
    control = rollout_controls(p, 0, p.nstep)  # the bare engine: the whole run in one call, controls made beforehand
    raw, adapter = math.inf, math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        mj_rollout.rollout(p.model, p.data, p.initial_state, control, control_spec=p.control_spec, nstep=p.nstep)
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
