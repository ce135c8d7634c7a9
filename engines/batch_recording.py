"""One chunk of samples recorded for many runs at once: ``Recording.add`` for the worlds of a batch, checked together.

    >>> import numpy as np
    >>> from chatterbench.engines.base import Recording
    >>> from chatterbench.engines.batch_recording import add_many
    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> scene = load_scene("bouncing-ball", ["duration=0.002"])           # 2 steps of 1 ms: 3 samples
    >>> runs = [Recording("x", scene, MujocoSettings(dt=1e-3), {}, None, (0.0, 1.0)) for _ in range(2)]
    >>> y = np.array([[1.0, 0.9, 0.8], [1.0, np.nan, 0.8]])              # the second run goes bad at sample 1
    >>> zeros = np.zeros((2, 3))
    >>> add_many(runs, np.tile([0.0, 1e-3, 2e-3], (2, 1)), {"lower": zeros}, y=y, vy=zeros, x1=zeros, v1=zeros)
    >>> [r.recorder.count for r in runs], runs[1].cut
    ([3, 1], 'non-finite or huge state at t = 0.001 s (sample 1)')

An engine that steps many runs together (MuJoCo Warp's worlds) hands each chunk of all of
them over in one call; each run gets exactly what its own ``Recording.add`` would give it (the
same samples, cut and message: ``tests/engines/test_mujoco_warp.py`` runs a batch both ways),
and the per-sample checks (non-finite or huge state, non-finite force, what the engine marks
bad) are made on the whole chunk at once, so that a batch of thousands of worlds costs a few
microseconds per world and chunk beyond its samples. ``record_block`` is the base's driver of
such an engine's block: its generator of ``wholerun.BlockSamples`` stepped, timed and recorded
(a single run's is ``wholerun.record``).
"""

from __future__ import annotations

import time
from typing import Any, Generator, Mapping, Sequence

import numpy as np

from .recording import MAXVAL, Recording
from .wholerun import BlockSamples


def add_many(runs: Sequence[Recording], t: np.ndarray, force: Mapping[str, np.ndarray], *, y: np.ndarray,
             vy: np.ndarray, x1: np.ndarray, v1: np.ndarray, bad: np.ndarray | None = None,
             lengths: np.ndarray | None = None) -> None:
    """``Recording.add`` of one chunk for many runs at once (a batch's worlds): arrays of shape (len(runs), c), per
    run its times [s], ``force`` per wall of any run (a run takes its own walls; give zeros where it has none),
    ``y, vy`` [m, m/s], ``x1, v1`` body 1 [m, m/s] (read for a finite body 1 only: an infinite one's is the base's,
    as ``add`` fills it), ``bad`` samples the engine knows to be broken; ``lengths`` (len(runs),): how many of the
    chunk's samples each run takes (a run that ends inside the chunk; 0: none; default all). Each run not stopped
    gets what ``add`` would give it for its samples, the same samples, cut and message
    (``tests/engines/test_batch_recording.py``), the checks made for all runs together; a run recorded compact
    (``window.Recorder``), or whose ``add`` is wrapped, takes its ``add``."""
    finite1 = np.array([not r.scene.body1_infinite for r in runs])[:, None]
    state = (y, vy)
    held = (np.abs(y) <= MAXVAL) & (np.abs(vy) <= MAXVAL)  # False for NaN and inf too: ``add``'s two checks in one
    held &= ~finite1 | ((np.abs(x1) <= MAXVAL) & (np.abs(v1) <= MAXVAL))
    for f in force.values():
        held &= np.isfinite(f)
    broken = ~held
    if bad is not None:
        broken |= bad
    c = t.shape[1]
    lengths = np.full(len(runs), c) if lengths is None else np.minimum(lengths, c)
    first = np.where(broken.any(axis=1), np.argmax(broken, axis=1), c)
    for w, r in enumerate(runs):
        n = int(lengths[w])
        if r.cut or n <= 0:
            continue
        walls = r.scene.gap.walls
        if r.recorder.compact or "add" in vars(r):  # compact; or its ``add`` wrapped (the contract test's faults)
            r.add(t[w, :n], {wall: force[wall][w, :n] for wall in walls}, y=y[w, :n], vy=vy[w, :n],
                  bad=None if bad is None else bad[w, :n], **({"x1": x1[w, :n], "v1": v1[w, :n]} if finite1[w, 0] else {}))
            continue
        r._check_times(t[w, :n])
        m = min(int(first[w]), n)
        if m < n:
            r.cut = f"non-finite or huge state at t = {t[w, m]:.6g} s (sample {r.recorder.count + m})"
        tw = t[w, :m]
        b1 = (x1[w, :m], v1[w, :m]) if finite1[w, 0] else r.body1(tw)
        fw = {wall: force[wall][w, :m] for wall in walls}
        r.recorder.add(tw, b1[0], b1[1], b1[0] + state[0][w, :m], b1[1] + state[1][w, :m],
                       {wall: f > 0.0 for wall, f in fw.items()}, fw)


def record_block(runs: Sequence[Recording], chunks: Generator[BlockSamples | None, None, Any],
                 weights: Sequence[float]) -> Any:
    """Drive one generator that steps ``runs`` as one block (``BlockSamples``, None once set up; each handed over
    with ``add_many``); the block's stepping time goes to the runs in proportion to ``weights``
    (their steps). Returns what the generator returned; raises what it raised."""
    clock = time.perf_counter
    wall = 0.0
    try:
        while True:
            start = clock()
            try:
                got = next(chunks)
            except StopIteration as stop:
                wall += clock() - start
                return stop.value
            except BaseException:
                wall += clock() - start
                raise
            if got is None:  # set up
                continue
            add_many(runs, got.t, got.force, y=got.y, vy=got.vy, x1=got.x1, v1=got.v1, bad=got.bad,
                     lengths=got.lengths)
            wall += clock() - start  # a block's hand-over is timed with its steps (the runs' checks made together)
    finally:
        chunks.close()
        total = float(sum(weights))
        for r, w in zip(runs, weights):
            r.wall_time += wall * w / total if total > 0 else 0.0
