"""Stepping MuJoCo: ``mujoco.rollout`` chunk by chunk into the base's recording, compatible runs batched.

    >>> from chatterbench.engines.mujoco_engine import MujocoEngine, MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = MujocoEngine().run(load_scene("feigin-pair", ["duration=4"]), MujocoSettings(dt=1e-4))
    >>> traj.status, bool(traj.contact["lower"].any()), round(traj.contact_frequency)
    ('ok', True, 300)

Promises: ``mujoco.rollout`` runs the trajectory in chunks of ``window.CHUNK`` steps (the full
physics state and the solver's warm start carried from one to the next: the samples are those
of one call, bit for bit), each chunk's samples go to the run's ``base.Recording``
(``mujoco_common.take``); autoreset is disabled so MuJoCo cannot hide a blow-up by resetting
the state, and MuJoCo's own blow-up warnings make the run ``diverged`` (``base.Diverged``);
``run_batch`` gives each run's trajectory bit for bit. MuJoCo's own ``rollout`` call over a
whole run would hold every step's full state and sensor data (about 190 B a step); chunks
hold ``CHUNK`` steps of it at a time.
"""

from __future__ import annotations

import time
from typing import Any, Sequence

import numpy as np
from mujoco import rollout as mj_rollout

from chatterbench.reference.scene import Scene

from ..base import Diverged, EngineAdapter, Recording, n_steps
from ..mujoco_common import Prepared, prepare, quiet_log, rollout_controls, take, warned, warning_note
from ..trajectory import Trajectory
from ..window import CHUNK


def _roll(ps: list[Prepared], runs: list[Recording]) -> tuple[list[set[str]], float]:
    """Roll ``ps`` out, ``CHUNK`` steps of each in turn, each from where its last chunk ended, into ``runs``.

    Each run has its own MjData: a chunk starts from the full physics state the last one ended
    in and its solver warm start (``initial_warmstart``), so the samples are bit for bit those of
    one call, and MuJoCo's warnings are each run's own. A run that goes bad stops there.
    Returns each run's MuJoCo warnings and the stepping wall time [s].
    """
    states = [p.initial_state for p in ps]
    warm: list[np.ndarray | None] = [None] * len(ps)  # None: MjData's own (zero) warm start, as one call starts
    names: list[set[str]] = [set() for _ in ps]
    nstep, wall = ps[0].nstep, 0.0
    for k0 in range(0, nstep, CHUNK):
        k1 = min(nstep, k0 + CHUNK)
        for b, (p, r) in enumerate(zip(ps, runs)):
            if r.stopped:
                continue
            control = rollout_controls(p, k0, k1)
            start = time.perf_counter()
            state, sensordata = mj_rollout.rollout(p.model, p.data, states[b], control, control_spec=p.control_spec,
                                                   nstep=k1 - k0, initial_warmstart=warm[b])
            wall += time.perf_counter() - start
            names[b] |= warned(p.data)
            take(r, p, k0, states[b][0], state[0], sensordata[0])
            states[b], warm[b] = state[:, -1].copy(), p.data.qacc_warmstart[None].copy()
        if all(r.stopped for r in runs):
            break
    return names, wall


def simulate(run: Recording) -> None:
    """One run: the model, its rollout chunk by chunk; ``Diverged`` when MuJoCo warned of a blow-up."""
    p = prepare(run.scene, run.settings, run.n)
    with quiet_log():
        (names,), wall = _roll([p], [run])
    run.wall_time += wall
    if names:
        raise Diverged(warning_note(names, run.settings))


def _signature(p: Prepared) -> tuple:
    """What must agree for runs to share one ``rollout`` call: sizes, steps, control layout."""
    return (p.model.signature, p.initial_state.shape[1], p.nstep, p.control_spec, p.model.nu, p.model.nmocap)


def roll_batch(engine: EngineAdapter, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs; compatible models roll out together, chunk by chunk.

    Runs whose compiled models share a size signature, step count and control layout (they
    may differ in anything rollout takes per model: restitution, masses, gap, initial
    state and time, forcing, w0 dt, solver options, integrator) go through ``_roll`` as one
    group, a chunk of each in turn (so that at most a chunk of each is in memory); the others
    run alone. Each trajectory is the one ``run`` gives, bit for bit (every run has its own
    MjData); its ``wall_time`` is its share of its group's stepping time (group wall / group
    size) and ``settings["batch_size"]`` says how many shared it. A group in which MuJoCo
    warned or a state blew up is rerun one run at a time, so that a diverged run is
    classified alone; a group of one already is that run. Raises SettingsError, like ``run``,
    before anything runs.
    """
    for scene, s in jobs:
        engine.validate(scene, engine.settings(s))  # settings errors first, for every job
    out: list[Trajectory | None] = [None] * len(jobs)
    runs: list[Recording | None] = [None] * len(jobs)
    groups: dict[tuple, list[tuple[int, Prepared]]] = {}
    for i, (scene, s) in enumerate(jobs):
        try:
            runs[i] = run = engine.open(scene, s)
            p = prepare(scene, run.settings, run.n)
            groups.setdefault(_signature(p), []).append((i, p))
        except Exception:  # noqa: BLE001  run alone, its failure is then its own result
            out[i] = engine.run(scene, s)
    for members in groups.values():
        idx = [i for i, _ in members]
        group = [runs[i] for i in idx]
        try:
            with quiet_log():
                names, wall = _roll([p for _, p in members], group)
        except Exception:  # noqa: BLE001  rerun alone: each run's own failure is then its own result
            names, wall = None, 0.0
        if names is not None and len(idx) == 1:  # a group of one is the run alone, rolled as run() rolls it
            group[0].wall_time = wall
            out[idx[0]] = group[0].trajectory(Diverged(warning_note(names[0], group[0].settings)) if names[0] else None)
            continue
        if names is None or any(names) or any(r.stopped for r in group):
            for i in idx:  # a possible blow-up is run and classified alone, as one call
                out[i] = engine.run(*jobs[i])
            continue
        for r in group:
            r.wall_time, r.record["batch_size"] = wall / len(group), len(group)
        for i, r in zip(idx, group):
            out[i] = r.trajectory()
    return out  # type: ignore[return-value]


def bare_seconds(scene: Scene, s: Any) -> float:
    """Seconds of one bare ``mujoco.rollout`` call over the run, its controls made beforehand."""
    p = prepare(scene, s, n_steps(scene.duration, s.dt))
    control = rollout_controls(p, 0, p.nstep)
    start = time.perf_counter()
    mj_rollout.rollout(p.model, p.data, p.initial_state, control, control_spec=p.control_spec, nstep=p.nstep)
    return time.perf_counter() - start
