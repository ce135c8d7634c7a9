"""A block's device set-up (model rows, worlds' data, recording arrays, captured steps), kept for the next like block.

    >>> from chatterbench.engines.mujoco_warp_engine.rigs import capacity, world_slots
    >>> capacity(2_001), capacity(16_384)      # [steps] a chunk's arrays: the next power of two, at least one graph
    (2048, 16384)
    >>> capacity(2_001, slots=1, row_bytes=40), capacity(2_001, slots=128, row_bytes=40)  # what 4 MB holds
    (16384, 2048)
    >>> world_slots(1), world_slots(3), world_slots(37)    # a block of 37 worlds steps 48: a rig for 33 to 48
    (1, 4, 48)
    >>> world_slots(2, nstep=288), world_slots(2, nstep=20_000), world_slots(1, nstep=288)  # a short block steps 16
    (16, 2, 1)

A block of worlds (``batch.roll_worlds``) needs a MuJoCo Warp model with its per-world rows (timestep
and contact solref, ``worlds.put_worlds``), a ``Data`` of its worlds, the recording's arrays and the
steps captured as a graph (``kernels.Stepper``). On the CPU device the capture costs more than a
short run's steps: 0.33 s of APIC capture per run of bouncing-ball at the default settings against
0.14 s for everything else of the run (a tune of bouncing-ball, 40 runs, profiled on this code). So a
``Rig`` is kept per process and reused by the next block of the same shape: the same kept device
model (``worlds.device_model``: one compiled structure), worlds (``world_slots``), chunk capacity
(``capacity``: a world alone holds ``window.CHUNK`` steps, whatever its dt), rows shared or per
world, and capture. The graph points at the rig's arrays, so a new block writes into them, never
replaces them: its rows (``Rig.load_rows``), its data reset to a fresh
``put_data``'s (the template's arrays copied: the solver's warm start and every counter as a new
run has them) and its initial states. Worlds beyond the block's (``world_slots`` rounds up) step
copies of its last world, unread; chunk arrays beyond the chunk are never stepped into (a chunk's
launches are its own steps).

Promises: a run in a kept rig is the run in a fresh one bit for bit, and a world's run does not
depend on the other worlds stepped beside it (``tests/engines/test_mujoco_warp.py``); a rig is used
by one block at a time (taken from the table while in use); rigs are this process's own (a forked
child makes its own); blocks of several structures or of more than ``MOST_RIG_BYTES`` of arrays get
a rig of their own, not kept.
"""

from __future__ import annotations

import dataclasses
import os
import threading
from collections import OrderedDict
from typing import Any, Sequence

import mujoco
import numpy as np

import chatterbench.engines.mujoco_warp_engine.kernels as kernels  # graphs() read at each call (a test sets it)

from ..mujoco_common import Prepared
from ..window import CHUNK
from .kernels import STEPS_PER_GRAPH, Stepper, load_kernels
from .samples import Before
from .worlds import Worlds, copied, field, set_field, warp_modules

MOST_RIGS = 32  # rigs kept per process (a tune's slices, each with its runs' rig and its strike batches')
WORLD_ROUND = 16  # [worlds] a block takes a rig of the next power of two up to this, then of the next multiple of it
SHORT_STEPS = 1024  # [steps] a block of 2 to WORLD_ROUND worlds of at most this many steps (nstep: samples) takes a rig
# of WORLD_ROUND worlds
LEAST_RIG_BYTES = 4e6  # [B] a rig's chunk arrays hold at least the steps that fit in this (up to ``window.CHUNK``)
MOST_RIG_BYTES = 64e6  # [B] a block whose chunk arrays pass this gets a rig of its own (a GPU's thousands of worlds)

_IDLE: OrderedDict[tuple, "Rig"] = OrderedDict()
_LOCK = threading.Lock()


def capacity(chunk: int, slots: int = 0, row_bytes: int = 0) -> int:
    """Steps a rig's chunk arrays hold for a chunk of ``chunk`` steps: the next power of two, at least one graph, and
    at least the power of two of steps of ``slots`` worlds of ``row_bytes`` [B] a step that fit in ``LEAST_RIG_BYTES``
    (up to ``window.CHUNK``: a run's length, and so its dt, then picks no rig of its own)."""
    fit = int(LEAST_RIG_BYTES // (slots * row_bytes)) if slots and row_bytes else 0
    least = min(CHUNK, 1 << (fit.bit_length() - 1)) if fit else 0
    return max(STEPS_PER_GRAPH, least, 1 << (max(1, chunk) - 1).bit_length())


def world_slots(nworld: int, nstep: int | None = None) -> int:
    """Worlds a rig steps for a block of ``nworld`` worlds of up to ``nstep`` steps: the next power of two up to
    ``WORLD_ROUND``, then the next multiple of it (few shapes of rig, and a small block steps few worlds: on the CPU
    device a step of 16 worlds costs 3.7 times one world's, of 8 worlds 2.2 times, ``bench sweep --only warp``).

    A short block of 2 to ``WORLD_ROUND`` worlds (at most ``SHORT_STEPS``: a tune's strikes, 288 steps in batches of
    2 to 12 worlds) takes ``WORLD_ROUND`` worlds whatever its size, so that one rig serves every such block of a
    structure: a rig's first capture costs ~0.05 s on the CPU device (~11 ms a step of ``kernels.STEPS_PER_GRAPH``),
    its set-up as much again, 1,024 steps of 14 extra worlds ~0.05 s (3.6 us a world-step). A run alone keeps a rig of
    one world: once its rig is kept, 15 extra worlds would cost it three times its steps for nothing."""
    if nstep is not None and nstep <= SHORT_STEPS and 1 < nworld <= WORLD_ROUND:
        return WORLD_ROUND
    return 1 << (nworld - 1).bit_length() if nworld <= WORLD_ROUND else -(-nworld // WORLD_ROUND) * WORLD_ROUND


class Rig:
    """One block's device set-up (module docstring): ``model`` (rows of ``slots`` worlds or one shared row), ``data``
    of ``slots`` worlds, ``out`` (qpos, qvel, sensors: (slots, steps, size) float32), ``ctrl_in`` (steps, slots, nu),
    ``mocap_in``, ``bad_acc`` (slots,), the ``stepper``; ``load`` and ``capture_s``: what making it cost."""

    def __init__(self, worlds: Worlds, mjm: mujoco.MjModel, slots: int, steps: int) -> None:
        wp, mjw = warp_modules()
        self.slots, self.steps, self.base, self.used = slots, steps, worlds.base, False
        self.model = copied(worlds.model)  # its own rows (below), the kept model's other arrays
        for path in worlds.rows:
            old = field(worlds.model, path)
            new = wp.zeros((old.shape[0] if old.shape[0] == 1 else slots, *old.shape[1:]), dtype=old.dtype)
            new._is_batched = True  # as mujoco_warp marks its per-world arrays
            set_field(self.model, path, new)
        self.load = load_kernels(worlds.model, mjw.put_data(mjm, mujoco.MjData(mjm)), worlds.device)
        self.mjm, self.template = mjm, None  # a fresh data to reset to, made when the rig is first reused
        self.data = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=slots)
        d = self.data
        self.out = [wp.zeros((slots, steps, size), dtype=wp.float32) for size in (mjm.nq, mjm.nv, mjm.nsensordata)]
        self.ctrl_in = wp.zeros((steps, slots, mjm.nu), dtype=wp.float32)
        self.mocap_in = wp.zeros((steps, slots, mjm.nmocap), dtype=wp.vec3)
        self.bad_acc = wp.zeros(slots, dtype=wp.int32)
        self.rows = worlds.rows
        self.load_rows(worlds)
        self.stepper = Stepper(self.model, d, slots, [d.qpos, d.qvel, d.qacc, d.sensordata, d.ctrl, d.mocap_pos,
                                                      self.ctrl_in, self.mocap_in, *self.out, self.bad_acc],
                               worlds.device)
        self.capture_s = self.stepper.capture_s

    def load_rows(self, worlds: Worlds) -> None:
        """The block's per-world rows (``worlds.rows``) into the rig's, the last world's repeated to ``slots``."""
        for path in self.rows:
            mine = field(self.model, path)
            mine.assign(_padded(field(worlds.model, path).numpy(), mine.shape[0]))

    def start(self, worlds: Worlds, ps: Sequence[Prepared], nstep: int) -> Before:
        """Ready for the block ``ps`` of ``worlds``: its rows, a fresh data (a used rig's reset to the template's), its
        initial states and times, ``bad_acc`` at ``nstep`` (no bad step); returns the states before the first chunk."""
        if self.used:
            if self.template is None:
                _, mjw = warp_modules()
                self.template = mjw.put_data(self.mjm, mujoco.MjData(self.mjm), nworld=self.slots)
            self.load_rows(worlds)
            _restore(self.data, self.template)
        self.used = True
        before, d = Before(ps), self.data
        d.qpos.assign(_padded(before.qpos.astype(np.float32), self.slots))
        d.qvel.assign(_padded(before.qvel.astype(np.float32), self.slots))
        d.time.assign(_padded(np.array([p.scene.initial.t for p in ps], np.float32), self.slots))
        self.bad_acc.assign(np.full(self.slots, nstep, np.int32))
        return before

    def controls(self, ctrl: np.ndarray, mocap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A chunk's controls (chunk, nworld, nu) and mocap positions as the rig's arrays take them."""
        return (_padded(ctrl.swapaxes(0, 1), self.slots).swapaxes(0, 1),
                _padded(mocap.swapaxes(0, 1), self.slots).swapaxes(0, 1))


def key_of(worlds: Worlds, slots: int, steps: int) -> tuple | None:
    """What a rig for ``worlds`` must share with it: process, kept device model, worlds, steps, which rows are shared,
    capture; None for a block that gets a rig of its own (several structures, or arrays past ``MOST_RIG_BYTES``)."""
    if worlds.base is None:
        return None
    if slots * steps * 4 * _row_floats(worlds.base) > MOST_RIG_BYTES:
        return None
    shared = tuple(field(worlds.model, path).shape[0] == 1 for path in worlds.rows)
    return os.getpid(), id(worlds.base), worlds.device, slots, steps, worlds.rows, shared, kernels.graphs(worlds.device)


def take(worlds: Worlds, mjm: mujoco.MjModel, nworld: int, chunk: int,
         nstep: int | None = None) -> tuple[Rig, tuple | None]:
    """A rig for a block of ``nworld`` worlds of up to ``nstep`` steps, stepped ``chunk`` steps at a time: an idle kept
    one of its shape (``world_slots``, ``capacity``), else a new one; with its key, to give it back (``give_back``)
    when the block is done (None: not kept)."""
    slots, steps, key = nworld, chunk, None
    if worlds.base is not None:
        kept_slots = world_slots(nworld, nstep)
        kept_steps = capacity(chunk, kept_slots, 4 * _row_floats(worlds.base))
        key = key_of(worlds, kept_slots, kept_steps)
        if key is not None:
            slots, steps = kept_slots, kept_steps
    with _LOCK:
        rig = _IDLE.pop(key, None) if key is not None else None
    return rig or Rig(worlds, mjm, slots, steps), key  # the key holds id(base), the rig holds base: no other model


def give_back(rig: Rig, key: tuple | None) -> None:
    """Keep a rig whose block is done for the next block of its shape (the oldest dropped past ``MOST_RIGS``)."""
    if key is None:
        return
    with _LOCK:
        _IDLE[key] = rig
        _IDLE.move_to_end(key)
        while len(_IDLE) > MOST_RIGS:
            _IDLE.popitem(last=False)


def idle() -> list[Rig]:
    """The rigs this process keeps, idle, oldest first."""
    with _LOCK:
        return list(_IDLE.values())


def drop_all() -> None:
    """Forget every kept rig of this process (a test's fresh start)."""
    with _LOCK:
        _IDLE.clear()


def _row_floats(m: Any) -> int:
    """Floats a world's step takes in a rig's chunk arrays: qpos, qvel, sensors read back, controls and mocap in."""
    return m.nq + m.nv + m.nsensordata + m.nu + 3 * m.nmocap


def _padded(rows: np.ndarray, slots: int) -> np.ndarray:
    """``rows`` (n, ...) with its last row repeated to ``slots`` rows (as it is when n is already that: a shared row
    of a rig's model is one row of one). One row is padded too: one world's states assigned to 16 worlds' arrays left
    them wrong from step 513 when a block of one world stepped in a rig of 16 (``test_mujoco_warp.py``).

        >>> import numpy as np
        >>> from chatterbench.engines.mujoco_warp_engine.rigs import _padded
        >>> _padded(np.zeros((1, 3)), 4).shape, _padded(np.zeros((1, 3)), 1).shape
        ((4, 3), (1, 3))
    """
    n = rows.shape[0]
    if n == slots:
        return np.ascontiguousarray(rows)
    return np.ascontiguousarray(np.concatenate([rows, np.repeat(rows[-1:], slots - n, axis=0)]))


def _restore(dst: Any, src: Any) -> None:
    """Every array of a ``mujoco_warp.Data`` (and of the dataclasses in it) copied from ``src``'s, in place."""
    wp, _ = warp_modules()
    for f in dataclasses.fields(dst):
        mine = getattr(dst, f.name)
        if isinstance(mine, wp.array):
            wp.copy(mine, getattr(src, f.name))
        elif dataclasses.is_dataclass(mine) and not isinstance(mine, type):
            _restore(mine, getattr(src, f.name))
