"""Stepping MuJoCo: the adapter, a whole run as ``mujoco.rollout`` chunk by chunk into the base's recording, batches.

    >>> from chatterbench.engines.mujoco_engine import MujocoEngine, MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = MujocoEngine().run(load_scene("feigin-pair", ["duration=4"]), MujocoSettings(dt=1e-4))
    >>> traj.status, bool(traj.contact["lower"].any()), round(traj.contact_frequency)
    ('ok', True, 300)

MuJoCo's model holds the scene's forces itself (springs as joint stiffness, time-dependent forces
as precomputed controls: ``model.py``), so the adapter runs whole runs (``samples``, a generator
the base drives, times and records: ``wholerun.py``) rather than steps the base would push
forces into.

Promises: ``mujoco.rollout`` runs the trajectory in chunks of ``window.CHUNK`` steps (the full
physics state and the solver's warm start carried from one to the next: the samples are those
of one call, bit for bit), each chunk's samples yielded to the base (``mujoco_common.take``);
autoreset is disabled so MuJoCo cannot hide a blow-up by resetting
the state, and MuJoCo's own blow-up warnings make the run ``diverged`` (``base.Diverged``);
``run_batch`` gives each run's trajectory bit for bit. MuJoCo's own ``rollout`` call over a
whole run would hold every step's full state and sensor data (about 190 B a step); chunks
hold ``CHUNK`` steps of it at a time.
"""

from __future__ import annotations

import time
from typing import Any, Iterator, Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from chatterbench.reference.scene import Scene

from .. import mujoco_common
from ..api import Diverged, EngineAdapter, Recording, Samples
from ..base import n_steps
from ..mujoco_common import Prepared, prepare, quiet_log, rollout_controls, take, warned, warning_note
from ..trajectory import Trajectory
from ..wholerun import record_many
from ..window import CHUNK
from .compiled import structure
from .settings import MujocoSettings, stability_limit


def _rollout(p: Prepared, data: mujoco.MjData) -> Iterator[Samples]:
    """Roll ``p`` out ``CHUNK`` steps at a time, each chunk from where the last one ended, yielding its samples.

    A chunk starts from the full physics state the last one ended in and its solver warm start
    (``initial_warmstart``; zero at a run's start, as a fresh MjData has it), so the samples are
    bit for bit those of one call. Runs may share ``data`` (rollout sets the whole physics state
    and the warm start at each call, and this run's are read back before anything else steps it);
    its warnings are cleared before each call, so each run's are its own. Stops when the base
    says the run was cut; raises ``Diverged`` at the end when MuJoCo warned of a blow-up.
    """
    state, warm = p.initial_state, np.zeros((1, p.structure.model.nv))
    names: set[str] = set()
    for k0 in range(0, p.nstep, CHUNK):
        k1 = min(p.nstep, k0 + CHUNK)
        control = rollout_controls(p, k0, k1)
        data.warning.number[:] = 0
        with quiet_log():
            rolled, sensordata = mj_rollout.rollout(p.model, data, state, control, control_spec=p.control_spec,
                                                    nstep=k1 - k0, initial_warmstart=warm)
        names |= warned(data)
        chunk = take(p, k0, state[0], rolled[0], sensordata[0])
        state, warm = rolled[:, -1].copy(), data.qacc_warmstart[None].copy()
        if (yield chunk) is False:
            break
    if names:
        raise Diverged(warning_note(names, p.settings))


def _signature(p: Prepared) -> tuple:
    """What must agree for runs to share one ``rollout`` call: sizes, steps, control layout."""
    m = p.structure.model
    return (m.signature, p.initial_state.shape[1], p.nstep, p.control_spec, m.nu, m.nmocap)


def roll_batch(engine: EngineAdapter, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
    """Run many (scene, settings) pairs; compatible models roll out together, chunk by chunk.

    Runs whose compiled models share a size signature, step count and control layout (they
    may differ in anything rollout takes per model: restitution, masses, gap, initial
    state and time, forcing, w0 dt, solver options, integrator) go through ``_roll`` as one
    group, a chunk of each in turn (so that at most a chunk of each is in memory); the others
    run alone. Runs that differ only in start, length and contact law share one compiled model
    (``compiled.shared_model``: one compile for a batch of strikes). Each trajectory is the one
    ``run`` gives, bit for bit (its full physics state, warm start and warnings are its own at
    every call: ``_rollout``); its ``wall_time`` is the time the base measured in its own chunks
    (``wholerun.record_many``) and ``settings["batch_size"]`` says how many shared it. A group in which MuJoCo
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
        data = mujoco.MjData(members[0][1].structure.model)  # one for all: same sizes (``_signature``)
        failures = record_many(group, [_rollout(p, data) for _, p in members])
        alone = [f is not None and not isinstance(f, Diverged) for f in failures]  # an exception of MuJoCo's
        if len(idx) == 1 and not alone[0]:  # a group of one is the run alone, rolled as run() rolls it
            out[idx[0]] = group[0].trajectory(failures[0])
            continue
        if any(f is not None for f in failures) or any(r.stopped for r in group):
            for i in idx:  # a possible blow-up is run and classified alone, as one call
                out[i] = engine.run(*jobs[i])
            continue
        for r in group:
            r.record["batch_size"] = len(group)
        for i, r in zip(idx, group):
            out[i] = r.trajectory()
    return out  # type: ignore[return-value]


class MujocoEngine(EngineAdapter):
    """MuJoCo behind the engine contract (``base.EngineAdapter``): soft contact, float64, ``dt`` the cost lever."""

    name = "mujoco"
    package = "mujoco"
    settings_type = MujocoSettings
    compliant = True  # solref's spring-damper: a contact time scale 1 / w0
    batches = True
    bytes_per_step = 100.0  # measured 69 B/step (feigin-pair, compact, 4.0e6 -> 1.2e7 steps: 545,060 -> 1,079,520 KiB)
    exports = ("model.xml", "run.py")  # the full MJCF, and a runner that needs only mujoco
    export_kind = "an MJCF model"

    def samples(self, run: Recording) -> Iterator[Samples | None]:
        """One run: the model (set up), its rollout chunk by chunk (``_rollout``); ``Diverged`` when MuJoCo warned of
        a blow-up."""
        p = prepare(run.scene, run.settings, run.n)
        data = mujoco.MjData(p.structure.model)
        yield None
        yield from _rollout(p, data)

    def run_batch(self, jobs: Sequence[tuple[Scene, MujocoSettings]]) -> list[Trajectory]:
        """Compatible runs rolled out together, each bit for bit as alone (``roll_batch``)."""
        return roll_batch(self, list(jobs))

    def validate(self, scene: Scene, settings: MujocoSettings) -> None:
        """Settings the scene cannot run with are refused by the MjSpec build (``model.build_spec``), compiled once
        for every run that shares its structure (``compiled.structure``)."""
        structure(scene, settings)

    def record(self, scene: Scene, settings: MujocoSettings) -> dict[str, Any]:
        """w0, zeta and the solref / solimp they make, MuJoCo's version (``mujoco_common.record``)."""
        return mujoco_common.record(scene, settings)

    def contact_scales(self, scene: Scene, settings: MujocoSettings) -> tuple[float, float]:
        """One bounce's duration and w0 (``mujoco_common.contact_scales``)."""
        return mujoco_common.contact_scales(scene, settings)

    def snippet(self, scene: Scene, settings: MujocoSettings | None = None) -> str:
        """The MJCF a user pastes: ``<option>``, the gap as a joint limit or a geom pair (``snippet.mjcf_snippet``)."""
        from .snippet import mjcf_snippet

        return mjcf_snippet(scene, settings)

    def export(self, scene: Scene, settings: MujocoSettings, command: str | None = None) -> dict[str, str]:
        """``model.xml`` (``export.model_xml``) and ``run.py``, which loads it with plain MuJoCo (``export.runner_script``)."""
        from .export import model_xml, runner_script

        model, runner = self.exports
        return {model: model_xml(scene, settings, command=command),
                runner: runner_script(scene, settings, model_file=model, command=command)}

    def measurement(self) -> str:
        """One impact's e measured in the user's MJCF (``snippet.measurement``)."""
        from .snippet import measurement

        return measurement()

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us; w0 dt from soft (0.03) to 0.9 of the integrator's stability limit for the
        scene's R (the stiffest stable contact); the two integrators of one force evaluation per step; solimp's
        impedance d (``MujocoSettings.impedance``) from 0.9 to MuJoCo's largest. Defaults first."""
        base = MujocoSettings()
        zeta = base.zeta(scene.restitution) if scene.restitution > 0 else 1.0
        stiffest = 0.9 * min(stability_limit(name, zeta) for name in ("euler", "implicitfast"))
        w0_dts = [base.w0_dt] + [w for w in (0.1, 0.3) if w < stiffest] + [round(stiffest, 3)]
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5), "mujoco.w0_dt": tuple(w0_dts),
                "mujoco.integrator": (base.integrator, "implicitfast"), "mujoco.impedance": (base.impedance, 0.9, 0.9999)}


def rollout_steps_per_s(jobs: Sequence[tuple[Scene, MujocoSettings]], threads: int = 1, repeats: int = 1) -> dict[str, Any]:
    """Steps per second of bare ``mujoco.rollout`` over the runs ``jobs`` in one call: each run's compiled model,
    initial state and controls made beforehand (``mujoco_common.prepare``), nothing recorded, on ``threads`` threads
    (a ``mujoco.rollout.Rollout`` pool; 1: the calling thread), best of ``repeats``. The runs must share a size
    signature and step count (ValueError). Returns ``runs``, ``steps`` (per run), ``threads``, ``seconds``,
    ``steps_per_s`` (all runs' steps per second)."""
    ps = [prepare(scene, s, n_steps(scene.duration, s.dt)) for scene, s in jobs]
    if len({_signature(p) for p in ps}) != 1:
        raise ValueError("rollout_steps_per_s: the runs must share sizes, steps and controls")
    p0 = ps[0]
    state0 = np.concatenate([p.initial_state for p in ps])
    controls = [rollout_controls(p, 0, p.nstep) for p in ps]
    control = np.concatenate(controls) if controls[0] is not None else None
    warm = np.zeros((len(ps), p0.structure.model.nv))
    datas = [mujoco.MjData(p0.model) for _ in range(max(1, threads))]
    best = float("inf")
    with mj_rollout.Rollout(nthread=threads if threads > 1 else 0) as pool:
        for _ in range(repeats):
            start = time.perf_counter()
            pool.rollout([p.model for p in ps], datas if threads > 1 else datas[0], state0, control,
                         control_spec=p0.control_spec, nstep=p0.nstep, initial_warmstart=warm)
            best = min(best, time.perf_counter() - start)
    return {"runs": len(ps), "steps": p0.nstep, "threads": threads, "seconds": best,
            "steps_per_s": len(ps) * p0.nstep / best}
