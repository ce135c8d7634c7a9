"""Runs as worlds: compatible runs grouped, each group in blocks that fit the host's memory, each block stepped at once.

    >>> from chatterbench.engines.mujoco_warp_engine.batch import block_plan
    >>> plan = block_plan(nworld=65_536, samples=6_285, walls=2, row_floats=5)
    >>> plan.worlds, plan.chunk     # feigin-pair over 2 pi s at dt = 1e-3: 65,536 worlds in 19 blocks of 3,450
    (3450, 1148)

``iter_blocks(engine, jobs)`` is the adapter's batch: every job is checked and prepared first
(``mujoco_common.prepare``: its compiled structure, no compile of its own, no MjData;
``SettingsError`` before anything runs), and the jobs that can share one MuJoCo Warp model
(same device, sizes and control layout; any lengths: a block steps its longest run, each world
read to its own end) are grouped; each group goes in blocks of ``BlockPlan.worlds`` worlds
(``block_plan``: every world's recorded samples and the chunk read back within
``HOST_BYTES``), and each block is one model of that many worlds (``worlds.put_worlds``)
stepped ``BlockPlan.chunk`` steps at a time (``kernels.Stepper``: captured where warp can; its
set-up and capture kept for the next block of its shape, ``rigs``)
and read back after each chunk (``samples.hand_over``), a generator the base drives, times
and records (``batch_recording.record_block``; a run alone: ``wholerun.one_of_block``). Each block's trajectories are handed
on as soon as it is done, so a caller that keeps only a summary of each (``bench``, a sweep)
holds one block at a time: host memory within ``HOST_BYTES`` at any number of worlds.

``settings["batch_size"]`` says how many worlds shared the block, ``wall_time`` is the run's
share of the block's stepping and reading back as the base timed it (by its steps), ``settings["warmup_s"]`` the kernels' loading
(``kernels.load_kernels``: compiling, the first time on a machine) and ``settings["kernels"]``
whether they were ``compiled`` or ``cached``; a world whose acceleration passed MAXVAL is
``diverged`` with MuJoCo's warning, as in MuJoCo C.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Generator, Iterator, Sequence

import mujoco
import numpy as np

from chatterbench.reference.scene import Scene

from ..api import Diverged, EngineAdapter, Recording, SettingsError
from ..base import n_steps, settings_fields
from ..batch_recording import record_block
from ..mujoco_common import Prepared, prepare, warning_note
from ..trajectory import Trajectory
from ..wholerun import BlockSamples
from ..window import CHUNK
from .kernels import STEPS_PER_GRAPH, KernelLoad
from .rigs import give_back, take
from .samples import controls_of, hand_over
from .worlds import Incompatible, Worlds, put_worlds, warp_model, warp_modules

HOST_BYTES = 2e9  # [B] what one block may hold on the host: its worlds' recorded samples and a chunk read back
WORLD_BYTES = 8_000  # [B] a world's fixed cost on the host: its Recording, Prepared, trajectory objects
STEP_BYTES = 160  # [B] host work arrays per world and step of a chunk read back (``samples.hand_over``), and 4 a float
FEW_STEPS = 1024  # [steps] a chunk at least this long where the run is (a world's per-chunk cost is ~10 us)


@dataclass(frozen=True)
class BlockPlan:
    """How a group of worlds is stepped: ``worlds`` per block, ``chunk`` steps between two readbacks."""

    worlds: int
    chunk: int  # a multiple of kernels.STEPS_PER_GRAPH


def block_plan(nworld: int, samples: int, walls: int, row_floats: int, host_bytes: float = HOST_BYTES) -> BlockPlan:
    """Worlds per block and steps per chunk for ``nworld`` runs of ``samples`` samples each on ``walls`` walls, a
    step reading back ``row_floats`` floats per world (qpos, qvel, sensors), within ``host_bytes`` (module
    docstring): a recorded sample costs 40 B of state and 9 B per wall (``window.Recorder``), a step of a chunk
    ``STEP_BYTES`` and 4 B a float read back. The chunk is ``FEW_STEPS`` (the whole run when shorter) while blocks
    must be cut, and as long as the memory left allows once they fit (``window.CHUNK`` at most)."""
    G = STEPS_PER_GRAPH
    whole = math.ceil(samples / G) * G
    step = STEP_BYTES + 4 * row_floats
    kept = samples * (40 + 9 * walls) + WORLD_BYTES
    chunk = min(FEW_STEPS, whole)
    worlds = max(1, min(nworld, int(host_bytes // (kept + chunk * step))))
    worlds = math.ceil(nworld / math.ceil(nworld / worlds))  # equal blocks
    room = int((host_bytes / worlds - kept) // step) // G * G
    return BlockPlan(worlds, max(chunk, min(CHUNK, whole, room)))


def roll_worlds(worlds: Worlds, ps: Sequence[Prepared], runs: Sequence[Recording],
                chunk: int) -> Generator[BlockSamples | None, None, dict[str, Any]]:
    """Step every world its ``nstep`` times from its initial state with its controls (all of them the longest run's
    steps: a world past its end steps on unread), ``chunk`` steps of all of them at a time, yielding each chunk's
    samples for the runs (``samples.hand_over``), None once set up (the kernels loaded, the data put, the steps
    captured). Returns ``warned`` (per world: MuJoCo's mjWARN_BADQACC), ``load`` (``kernels.KernelLoad``) and
    ``capture_s``."""
    wp, _ = warp_modules()
    mjm = warp_model(ps[0].structure.model)
    nw, nstep = len(ps), max(p.nstep for p in ps)
    warned = [False] * nw
    with wp.ScopedDevice(worlds.device):
        rig, key = take(worlds, mjm, nw, chunk, nstep)  # kept from a block of its shape, or made (kernels, capture)
        fresh = not rig.used
        before = rig.start(worlds, ps, nstep)
        d, out = rig.data, rig.out
        yield None
        for k0 in range(0, nstep, chunk):
            k1 = min(nstep, k0 + chunk)
            if all(r.stopped or r.recorder.count == r.n + 1 for r in runs):  # every run cut, or at its end
                break
            ctrl, mocap = rig.controls(*controls_of(ps, k0, k1, rig.steps))
            rig.ctrl_in.assign(ctrl)
            rig.mocap_in.assign(mocap)
            if mjm.nu:
                d.ctrl.assign(ctrl[0])
            if mjm.nmocap:
                d.mocap_pos.assign(mocap[0])
            rig.stepper.start(k0)
            rig.stepper.run(k1 - k0)
            qpos, qvel, sens = (a.numpy()[:nw, : k1 - k0] for a in out)
            samples, chunk_warned = hand_over(runs, ps, k0, before, qpos, qvel, sens, rig.bad_acc.numpy()[:nw])
            yield samples
            warned = [a or b for a, b in zip(warned, chunk_warned)]
            if all(r.stopped for r in runs):
                break
    give_back(rig, key)
    load = rig.load if fresh else KernelLoad(worlds.device, 0.0, False, rig.load.cache)
    return {"warned": warned, "load": load, "capture_s": rig.capture_s if fresh else 0.0}


def run_block(runs: Sequence[Recording], ps: Sequence[Prepared], device: str, chunk: int) -> list[Exception | None]:
    """Step the runs as the worlds of one MuJoCo Warp model (when they cannot share one: the runs of each compiled
    structure as one, e.g. one integrator's), driven, timed and recorded by the base (``batch_recording.record_block``);
    each run's failure (None: none) for ``Recording.trajectory``."""
    try:
        worlds = put_worlds(ps, device)
    except Incompatible:  # models that differ in a shared field: a block per compiled structure (else per run)
        keys = [id(p.structure) for p in ps] if len({id(p.structure) for p in ps}) > 1 else list(range(len(ps)))
        failures: dict[int, Exception | None] = {}
        for k in dict.fromkeys(keys):
            mine = [i for i, key in enumerate(keys) if key == k]
            failures.update(zip(mine, run_block([runs[i] for i in mine], [ps[i] for i in mine], device, chunk)))
        return [failures[i] for i in range(len(ps))]
    try:
        done = record_block(runs, roll_worlds(worlds, ps, runs, chunk), [p.nstep for p in ps])  # by its steps
    except Exception as exc:  # noqa: BLE001  an engine failure is a result, not a crash
        return [exc] * len(runs)
    return finished(runs, done)


def finished(runs: Sequence[Recording], done: dict[str, Any]) -> list[Exception | None]:
    """What a block's ``roll_worlds`` returned (``done``) into its runs' records; each run's failure (None: none)."""
    load = done["load"]
    for r in runs:
        r.record.update(batch_size=len(runs), warmup_s=load.seconds, kernels="compiled" if load.compiled else "cached",
                        capture_s=done["capture_s"])
    return [Diverged(warning_note({"mjWARN_BADQACC"}, r.settings)) if w else None for r, w in zip(runs, done["warned"])]


def _signature(p: Prepared) -> tuple:
    """What must agree for runs to share one model: sizes and controls (MuJoCo's ``run._signature`` without the step
    count: a batch steps its longest run's steps, each world read to its own end)."""
    m = p.structure.model
    return (m.signature, m.nu, m.nmocap)


def iter_blocks(engine: EngineAdapter, jobs: Sequence[tuple[Scene, Any]],
                host_bytes: float = HOST_BYTES) -> Iterator[list[tuple[int, Trajectory]]]:
    """The jobs' trajectories, block by block (module docstring): each block's as (index in ``jobs``, trajectory).
    Raises SettingsError, like ``run``, before anything runs: ``prepare`` refuses what ``validate`` refuses (an
    unstable w0 dt, a scene MuJoCo cannot compile), ``device_of`` a device that is not there."""
    groups: dict[tuple, list[tuple[int, Prepared]]] = {}
    failed = []
    for i, (scene, given) in enumerate(jobs):
        s = engine.settings(given)
        device = engine.device_of(s)
        try:  # the compiled structure, contact law and initial state: what ``validate`` checks, found once
            p = prepare(scene, s, n_steps(scene.duration, s.dt))
        except SettingsError:
            raise
        except Exception:  # noqa: BLE001  run alone once every job is checked: its failure is its own result
            failed.append(i)
            continue
        groups.setdefault((device, _signature(p)), []).append((i, p))
    if failed:
        yield [(i, engine.run(*jobs[i])) for i in failed]
    for (device, _), members in groups.items():
        members.sort(key=lambda m: m[1].nstep)  # blocks of like lengths: a block steps its longest run's steps
        first = members[-1][1]
        plan = block_plan(len(members), first.nstep, max(len(p.scene.gap.walls) for _, p in members),
                          first.structure.model.nq + first.structure.model.nv + first.structure.model.nsensordata,
                          host_bytes)
        for b0 in range(0, len(members), plan.worlds):
            block, alone = [], []
            for i, p in members[b0:b0 + plan.worlds]:
                try:
                    block.append((i, p, _opened(engine, p)))
                except MemoryError:  # its samples cannot fit: the run's own result says so
                    alone.append((i, engine.run(p.scene, p.settings)))
            failures = run_block([r for _, _, r in block], [p for _, p, _ in block], device, plan.chunk) if block else []
            yield alone + [(i, r.trajectory(f)) for (i, _, r), f in zip(block, failures)]


def _opened(engine: EngineAdapter, p: Prepared) -> Recording:
    """``engine.open`` for a prepared run, whose settings ``prepare`` and ``device_of`` have checked already."""
    s = p.settings
    record = {**settings_fields(s), **engine.record(p.scene, s)}
    return Recording(engine.name, p.scene, s, record, None, engine.contact_scales(p.scene, s))
