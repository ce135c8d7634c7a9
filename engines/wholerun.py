"""The run every whole-run engine shares: its generator of sample chunks, stepped, timed and recorded by the base.

    >>> import numpy as np
    >>> from chatterbench.engines.api import EngineAdapter, Samples
    >>> from chatterbench.engines.base import Recording
    >>> from chatterbench.engines.pybullet_engine import PybulletSettings
    >>> from chatterbench.engines.wholerun import record
    >>> from chatterbench.reference.scene import load_scene
    >>> class Resting(EngineAdapter):          # a toy whole-run engine: the ball stays where it starts
    ...     def samples(self, run):
    ...         yield None                      # set up: what came before is not stepping time
    ...         t = run.scene.initial.t + run.settings.dt * np.arange(run.n + 1)
    ...         yield Samples(t, {"lower": np.zeros(len(t))}, y=np.full(len(t), run.scene.initial.y), vy=0 * t)
    >>> run = Recording("resting", load_scene("bouncing-ball"), PybulletSettings(dt=0.5), {}, None, (0.0, np.inf))
    >>> record(run, Resting().samples(run)); run.trajectory().status, len(run.trajectory().t)
    ('ok', 5)

An engine that runs a whole run at once (MuJoCo's rollout, Drake's integrator, a child process)
writes ``samples(run)``, a generator: it sets its engine up (builds the model, compiles, starts
a process), yields ``None`` once set up, then steps and yields the run's samples chunk by chunk
as ``Samples``, in order, the initial state first. The base (``record``)

1. drives it: each ``send`` steps it to its next chunk, and the time spent inside it after its
   set-up is the run's stepping time (``Recording.wall_time``): no adapter reads a clock;
2. hands each chunk to ``Recording.add`` (checked against the run's time grid, cut at the
   first bad sample, body 1 filled) and sends back ``add``'s answer: ``False`` when the run
   was cut, then the generator stops (it may still raise, to say why its engine stopped);
3. closes it when the run ends (its ``finally`` and ``with`` blocks run: a child killed, a
   model released), and lets what it raised be the run's failure (``base.EngineAdapter.finish``
   classifies it).

``record_many`` drives the generators of a batch's runs in turn, a chunk of each (MuJoCo's
runs sharing one ``MjData``), each run's time its own; ``batch_recording.record_block`` drives
one generator that steps many runs as one (MuJoCo Warp's worlds) and yields ``BlockSamples``
(``one_of_block``: such a generator of one run as that run's own).

Promises: the samples are exactly what the generator yields, in its order (the base adds
nothing but body 1 of an infinite mass and the cut); the set-up before a ``None`` is never
counted as stepping; a generator is always closed.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, Generator, Mapping, Sequence

import numpy as np

Recording = Any  # a ``base.Recording`` (not imported: the base imports this module)
# a whole-run adapter's generator: yields None (set up) or Samples, is sent whether to go on, returns anything
Chunks = Generator["Samples | None", "bool | None", Any]


@dataclasses.dataclass(frozen=True, slots=True)
class Samples:
    """The next samples of one run, as a whole-run engine yields them (``Recording.add``'s arguments).

    ``t`` [s]: the samples' times, the next ones of the run's grid t0 + k dt (k = 0 .. n, the
    initial state first); ``force``: per wall of ``scene.gap.walls`` the force [N] the wall pushed
    body 2 with (> 0: contact), one per sample; body 2 as ``x2, v2`` [m, m/s] or relative to body 1
    as ``y, vy`` (x2 = x1 + y); body 1 as ``x1, v1`` (None for an infinite body 1: the base fills
    in its rest or prescribed motion); ``bad``: samples the engine knows to be broken (the run is
    cut there, ``diverged``). Arrays of one length, shape (c,).
    """

    t: np.ndarray
    force: Mapping[str, np.ndarray]
    y: np.ndarray | None = None
    vy: np.ndarray | None = None
    x2: np.ndarray | None = None
    v2: np.ndarray | None = None
    x1: np.ndarray | None = None
    v1: np.ndarray | None = None
    bad: np.ndarray | None = None


@dataclasses.dataclass(frozen=True, slots=True)
class BlockSamples:
    """The next samples of many runs stepped as one (a block of worlds), ``batch_recording.add_many``'s arguments:
    arrays of shape (runs, c), ``lengths`` (runs,) the samples each run takes (its own end), None: all."""

    t: np.ndarray
    force: Mapping[str, np.ndarray]
    y: np.ndarray
    vy: np.ndarray
    x1: np.ndarray
    v1: np.ndarray
    bad: np.ndarray | None = None
    lengths: np.ndarray | None = None

    def of(self, w: int, finite1: bool, walls: Sequence[str]) -> Samples:
        """Run ``w``'s samples alone (its own walls, body 1 when finite), as ``add_many`` hands them to its ``add``."""
        n = self.t.shape[1] if self.lengths is None else min(int(self.lengths[w]), self.t.shape[1])
        body1 = {"x1": self.x1[w, :n], "v1": self.v1[w, :n]} if finite1 else {}
        return Samples(self.t[w, :n], {wall: self.force[wall][w, :n] for wall in walls}, y=self.y[w, :n],
                       vy=self.vy[w, :n], bad=None if self.bad is None else self.bad[w, :n], **body1)


def _add(run: Recording, s: Samples) -> bool:
    return run.add(s.t, s.force, y=s.y, vy=s.vy, x2=s.x2, v2=s.v2, x1=s.x1, v1=s.v1, bad=s.bad)


class _Feed:
    """One run's generator as the base drives it: a chunk per ``step``, timed into the run, handed to its ``add``."""

    def __init__(self, run: Recording, chunks: Chunks) -> None:
        self.run, self.chunks = run, chunks
        self.go_on: bool | None = None  # what the next send says (None: the first, or after the set-up)
        self.done = False
        self.failure: BaseException | None = None

    def step(self) -> None:
        clock = time.perf_counter
        start = clock()
        try:
            got = self.chunks.send(self.go_on)
        except StopIteration:
            self.run.wall_time += clock() - start
            self.finish()
            return
        except Exception as exc:  # noqa: BLE001  the engine's failure: the run's result says it
            self.run.wall_time += clock() - start
            self.finish(exc)
            return
        if got is None:  # set up: what it took is not stepping
            return
        self.run.wall_time += clock() - start
        if self.go_on is False:  # stepped on after the run was cut: nothing more is recorded
            self.finish()
            return
        try:
            self.go_on = _add(self.run, got)
        except Exception as exc:  # noqa: BLE001  samples off the run's grid: the adapter's failure
            self.finish(exc)

    def finish(self, failure: BaseException | None = None) -> None:
        self.done, self.failure = True, failure
        self.chunks.close()


def record(run: Recording, chunks: Chunks) -> None:
    """Drive a whole-run adapter's generator ``chunks`` over ``run`` (module docstring); raises what it raised (or
    what ``run.add`` raised for its samples) once the samples before are recorded."""
    feed = _Feed(run, chunks)
    try:
        while not feed.done:
            feed.step()
    finally:
        chunks.close()
    if feed.failure is not None:
        raise feed.failure


def record_many(runs: Sequence[Recording], chunks: Sequence[Chunks]) -> list[BaseException | None]:
    """Drive the generators ``chunks`` of ``runs`` in turn, a chunk of each, each timed into its own run (MuJoCo's
    runs sharing one ``MjData``: a run's state is its generator's own); each run's failure (None: none)."""
    feeds = [_Feed(r, c) for r, c in zip(runs, chunks)]
    try:
        while not all(f.done for f in feeds):
            for f in feeds:
                if not f.done:
                    f.step()
    finally:
        for c in chunks:
            c.close()
    return [f.failure for f in feeds]


def one_of_block(chunks: Generator[BlockSamples | None, None, Any], run: Recording) -> Chunks:
    """A block generator of the one run ``run`` (which stops by itself once the run is cut or done) as that run's
    own generator of ``Samples``; returns what the block generator returned."""
    finite1, walls = not run.scene.body1_infinite, run.scene.gap.walls
    try:
        while True:
            try:
                got = next(chunks)
            except StopIteration as stop:
                return stop.value
            yield None if got is None else got.of(0, finite1, walls)
    finally:
        chunks.close()
