"""What goes to the device and comes back per chunk of steps: every world's controls, every world's samples to its run.

    >>> import numpy as np
    >>> from chatterbench.engines.mujoco_common import prepare
    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> from chatterbench.engines.mujoco_warp_engine.samples import controls_of
    >>> from chatterbench.reference.scene import load_scene
    >>> ps = [prepare(load_scene("feigin-pair", [f"initial.t={t}"]), MujocoSettings(dt=1e-3), 10) for t in (0.0, 1.0)]
    >>> ctrl, mocap = controls_of(ps, 0, 4, rows=8)
    >>> ctrl.shape, mocap.shape, bool(np.all(ctrl[4:] == ctrl[3]))    # (rows, worlds, nu); padded with the last
    ((8, 2, 1), (8, 2, 0, 3), True)

``controls_of`` makes the controls of many worlds at once: the worlds that share a compiled
structure and a timestep share the scene's forcing too (``compiled.structure_key``), so their
times t0 + k dt go through ``model.controls`` as one array, element by element the numbers
``mujoco_common.rollout_controls`` makes for each run alone (then rounded to float32, as
MuJoCo Warp holds them). ``hand_over`` makes each world's samples for its run as
``mujoco_common.take`` makes MuJoCo's: the state at each sample (the chunk's first sample is
where the last chunk ended), the contact flags and forces from the same sensors, a world whose
acceleration went past MAXVAL (MuJoCo C's mjWARN_BADQACC, found on the device) cut there; the
per-world arithmetic is done for all worlds at once, each run then gets its columns from the
base (``wholerun.record_block``, ``batch_recording.add_many``: its own checks, its body 1, its
recording).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..recording import Recording
from ..mujoco_common import Prepared
from ..wholerun import BlockSamples


def controls_of(ps: Sequence[Prepared], k0: int, k1: int, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Controls (rows, nworld, nu) [N] and mocap positions (rows, nworld, nmocap, 3) [m] of steps k0 .. k1 - 1 of
    every run of ``ps``, float32; rows past k1 - k0 repeat the last step's (a chunk's arrays have a fixed length)."""
    from ..mujoco_engine.model import controls

    model = ps[0].structure.model
    nu, nmocap, c = model.nu, model.nmocap, k1 - k0
    ctrl = np.zeros((rows, len(ps), nu), np.float32)
    mocap = np.zeros((rows, len(ps), nmocap, 3), np.float32)
    if not (nu or nmocap):
        return ctrl, mocap
    shared: dict[tuple, list[int]] = {}
    for w, p in enumerate(ps):
        shared.setdefault((id(p.structure), p.settings.dt), []).append(w)
    steps = np.arange(k0, k1)
    for members in shared.values():
        p = ps[members[0]]
        t0 = np.array([ps[w].scene.initial.t for w in members])
        t = (t0[:, None] + p.settings.dt * steps[None, :]).ravel()  # = each run's sample_times[k0:k1], bit for bit
        if nu:
            ctrl[:c, members] = controls(p.scene, p.settings, t).reshape(len(members), c, nu).transpose(1, 0, 2)
        if nmocap:  # held over step k at x1(t_k), as rollout's mjSTATE_MOCAP_POS controls
            x1 = p.scene.prescribed.position(t).reshape(len(members), c).T  # (c, members)
            mocap[:c, members] = np.stack([x1, np.zeros_like(x1), np.zeros_like(x1)], axis=-1)[:, :, None, :]
    ctrl[c:], mocap[c:] = ctrl[c - 1], mocap[c - 1]
    return ctrl, mocap


class Before:
    """Every world's state at the next chunk's first sample [m, m/s]: ``qpos`` (nworld, nq), ``qvel`` (nworld, nv)."""

    def __init__(self, ps: Sequence[Prepared]) -> None:
        nq, nv = ps[0].structure.model.nq, ps[0].structure.model.nv
        states = np.concatenate([p.initial_state for p in ps])  # rollout's layout: time, qpos, qvel, ...
        self.qpos, self.qvel = states[:, 1:1 + nq], states[:, 1 + nq:1 + nq + nv]


def hand_over(runs: Sequence[Recording], ps: Sequence[Prepared], k0: int, before: Before, qpos: np.ndarray,
              qvel: np.ndarray, sens: np.ndarray, bad_acc: np.ndarray) -> tuple[BlockSamples, list[bool]]:
    """Samples k0 .. k0 + c - 1 for each run not yet stopped, from ``before`` (the states at sample k0, then moved on
    to k0 + c) and the chunk's ``qpos`` (nworld, c, nq), ``qvel`` (nworld, c, nv) after each step and ``sens``
    (nworld, c, nsensordata) at its start (float32 from the device); ``bad_acc`` (nworld,): the first step whose
    acceleration was past MAXVAL (the states after it are dropped). A run takes the samples up to its own end
    (``Prepared.nstep``). Returns the samples (for ``batch_recording.add_many``) and each world's MuJoCo warning
    (True: mjWARN_BADQACC in this chunk)."""
    nw, c = qpos.shape[:2]
    lengths = np.array([p.nstep - k0 for p in ps])  # a run's samples in this chunk: to its own end
    warned = [bool(b < k0 + min(c, n)) and not r.stopped for b, r, n in zip(bad_acc, runs, lengths)]

    def at_samples(chunk: np.ndarray, first: np.ndarray) -> np.ndarray:
        """(nworld, c) float64: the state at samples k0 .. k0 + c - 1, ``first`` at k0, then after each step."""
        out = np.empty((nw, c))
        out[:, 0] = first
        out[:, 1:] = chunk[:, :c - 1]
        return out

    y, vy = at_samples(qpos[:, :, -1], before.qpos[:, -1]), at_samples(qvel[:, :, -1], before.qvel[:, -1])
    x1, v1 = at_samples(qpos[:, :, 0], before.qpos[:, 0]), at_samples(qvel[:, :, 0], before.qvel[:, 0])
    before.qpos, before.qvel = qpos[:, c - 1].astype(np.float64), qvel[:, c - 1].astype(np.float64)
    for w in np.flatnonzero(warned):  # the sample after a bad step is its state: dropped (MuJoCo C's states go bad)
        y[w, max(0, int(bad_acc[w]) - k0 + 1):] = np.nan
    bad = ~np.isfinite(sens).all(axis=2)  # (nworld, c): a sensor that is not finite
    t0 = np.array([p.scene.initial.t for p in ps])[:, None]
    dt = np.array([p.settings.dt for p in ps])[:, None]
    t = t0 + dt * np.arange(k0, k0 + c)[None, :]  # = each run's sample_times(scene, dt)[k0:k0 + c]
    return BlockSamples(t, _forces(ps, y, sens), y=y, vy=vy, x1=x1, v1=v1, bad=bad, lengths=lengths), warned


def _forces(ps: Sequence[Prepared], y: np.ndarray, sens: np.ndarray) -> dict[str, np.ndarray]:
    """Per wall the contact force on body 2 [N] of every world (nworld, c; 0 for a world without that wall) as
    ``mujoco_common.take`` reads the sensors: the joint limit's force on the wall y is beyond, or each wall's contact
    sensor."""
    nw, c = y.shape
    lower, upper = np.zeros((nw, c)), np.zeros((nw, c))
    if ps[0].settings.gap_model == "limit":  # a group shares its gap model (its sensors' sizes)
        f = np.maximum(sens[:, :, 0], 0.0, dtype=np.float64)
        mid = np.array([0.5 * (p.scene.gap.lower + p.scene.gap.upper) if p.scene.gap.upper is not None else np.inf
                        for p in ps])[:, None]
        upper_side = y > mid  # only the wall y is beyond can push
        upper = np.where(upper_side, f, 0.0)
        f[upper_side] = 0.0
        lower = f
    else:
        lower = np.maximum(sens[:, :, 0], 0.0, dtype=np.float64)
        if sens.shape[2] > 3:
            upper = np.maximum(sens[:, :, 3], 0.0, dtype=np.float64)
    return {"lower": lower, "upper": upper}
