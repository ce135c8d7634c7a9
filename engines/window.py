"""Compact trajectories: an engine run's samples near the walls and the few others the judge reads, taken chunk by chunk.

    >>> import numpy as np
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.window import compact
    >>> from chatterbench.engines.registry import make_settings, run_engine
    >>> scene = load_scene("bouncing-ball")
    >>> full = run_engine("pybullet", scene, make_settings("pybullet", dt=1e-4))
    >>> small = compact(full, scene, above=0)               # what a run of more than COMPACT_ABOVE samples hands on
    >>> full.compact, small.compact, len(full.t), len(small.t), small.dt == full.dt   # the ball: 0.65 s resting kept
    (False, True, 20001, 14063, True)
    >>> bool(np.array_equal(small.t, full.t[small.index]))  # the samples kept are the run's own, unchanged
    True

An adapter hands its samples to a ``Recorder`` in chunks (``add``, consecutive samples, in
order) and asks it for the ``Trajectory`` at the end. A run of at most ``COMPACT_ABOVE``
samples comes back full, bit for bit the samples added; a longer one comes back compact
(``Trajectory.index``, ``Trajectory.step``), and the recorder never holds more than
``CHUNK``-sized blocks besides what it keeps, so the run's memory follows the time spent
near the walls, not its length. ``compact`` does the same to a full trajectory after the fact.

What a compact trajectory keeps, with y = x2 - x1 and, per wall, d = n (y - y_wall) (n = +1
lower, -1 upper: the distance from the wall, < 0 past it) and u = n y':

1. every sample in contact with a wall or on or past it (d <= 0), and both samples of every
   step (k, k + 1) on which the extraction could see an impact between samples:
   min(d_k, d_k+1) <= ``REACH_FACTOR`` (max(|u_k|, |u_k+1|) + |u_k+1 - u_k|) dt (its test,
   ``comparisons/pipeline/extract.py``, needs min d <= max |u| dt + |y''| dt^2 and a jump of
   u over 2 |y''| dt, so |y''| dt < |u_k+1 - u_k|: wherever that test can fire, this one does),
   each with ``MARGIN`` samples on either side (contact onsets and releases read the samples
   next to them);
2. the first two samples and the last, and each sample where |y'| exceeds every earlier one (the
   judge's energy bound, m |y'|^2 / 2 over a limit, is first passed at one of them);
3. in every stretch left out, its samples of largest and of smallest y: the highest point of a
   flight (the extraction's ``apex``, a maximum of d between impacts) is then the full run's;
4. every ``stride``-th sample, ``PLOT_SAMPLES`` in all at most, for plots.

What is left out is free flight clear of the walls, where every penetration is 0 (a contact
is kept whole: the judge's penetration windows may end anywhere inside one). The extraction
skips the steps between kept samples that are not neighbours (``index``), the judge counts
a window holding only left-out samples as 0 penetration, and both give the same impacts,
episodes, verdicts and metrics as on the full run, to the last bit
(``tests/engines/test_window.py``: every built-in scene, MuJoCo, PyBullet and Drake, a wrong R too). Rule 1
holds for the extraction's default ``jump_factor`` 2 (``REACH_FACTOR`` 2 covers >= 1.5).

An engine opts in by creating ``Recorder(scene, n_samples)`` before stepping, calling
``add`` with each chunk of samples (``CHUNK`` at a time is a good size), and returning
``recorder.trajectory(engine, wall_time, ...)``; an adapter that builds a full trajectory
anyway can return ``compact(traj, scene)`` (the judge's memory is then bounded, the run's not).
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Mapping

import numpy as np

from chatterbench.reference.scene import Scene

from .trajectory import Trajectory

COMPACT_ABOVE = 500_000  # [samples] runs longer than this are handed on compact (feigin-pair at dt 1e-4 is 402,124)
CHUNK = 1 << 14  # [samples] a good chunk for ``Recorder.add``: small against the run, large against numpy's overhead
MARGIN = 2  # [samples] kept on either side of a sample near a wall (the extraction reads one neighbour)
REACH_FACTOR = 2.0  # [-] safety factor on the impact-between-samples test (rule 1; 1 is exact arithmetic)
PLOT_SAMPLES = 10_000  # thinned samples kept for plots (a chart is a few thousand pixels wide)

_STATE = ("t", "x1", "v1", "x2", "v2")
Block = dict  # column name -> array, all of one length; "index": int step numbers


def _take(block: Block, sel) -> Block:
    return {k: v[sel] for k, v in block.items()}


def _join(blocks: list[Block]) -> Block:
    return {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Runs of True in ``mask``: run i is starts[i] .. stops[i] - 1."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _median(counts: dict[float, int]) -> float:
    """``np.median`` of values given as value -> how many times (the run's sample spacings)."""
    total = sum(counts.values())
    if not total:
        return math.nan
    values = sorted(counts)
    cum = np.cumsum([counts[v] for v in values])
    lo, hi = (values[int(np.searchsorted(cum, pos, side="right"))] for pos in ((total - 1) // 2, total // 2))
    return float(lo) if total % 2 else float((lo + hi) / 2.0)


class _Stretches:
    """Rule 3: the kept samples in order, with each left-out stretch's samples of largest and smallest y.

    A stretch still open at the end of a block is carried: the samples rules 2 and 4 keep in
    it and its rows of largest and smallest y so far; they are written when it ends, so the
    samples stay in order.
    """

    def __init__(self) -> None:
        self.pieces: list[Block] = []
        self.open: dict | None = None  # {"rows": [Block], "hi": Block, "lo": Block} of the open stretch

    def _flush(self, rows: list[Block]) -> None:
        rows = [r for r in rows if len(r["t"])]
        if rows:
            joined = _join(rows)
            _, first = np.unique(joined["index"], return_index=True)  # sorted, each sample once
            self.pieces.append(_take(joined, first))

    def take(self, block: Block, keep: np.ndarray, extra: np.ndarray) -> None:
        """Samples in order; ``keep``: the ones rule 1 keeps (the stretches are the rest), ``extra``: rules 2 and 4."""
        n = len(keep)
        if not n:
            return
        y = block["x2"] - block["x1"]
        emit = keep | extra
        starts, stops = _runs(~keep)
        if self.open is not None and not (len(starts) and starts[0] == 0):
            self._flush([*self.open["rows"], self.open["hi"], self.open["lo"]])  # it ended where this block starts
            self.open = None
        for s, e in zip(starts.tolist(), stops.tolist()):
            carried, best = (self.open, {}) if s == 0 else (None, {})
            if s == 0:
                self.open = None
            for key, pos, sign in (("hi", s + int(np.argmax(y[s:e])), 1.0), ("lo", s + int(np.argmin(y[s:e])), -1.0)):
                old = carried[key] if carried else None
                best[key] = old if old is not None and sign * _y(old) >= sign * y[pos] else pos  # the earlier wins a tie
            rows = carried["rows"] if carried else []
            if e < n:  # the stretch ends in this block: what it carried goes before this block's samples
                self._flush([*rows, *(v for v in best.values() if not isinstance(v, int))])
                for v in best.values():
                    if isinstance(v, int):
                        emit[v] = True
                continue
            rows = [*rows, _take(block, s + np.flatnonzero(extra[s:]))]
            emit[s:] = False
            self.open = {"rows": rows, **{k: v if not isinstance(v, int) else _take(block, slice(v, v + 1))
                                          for k, v in best.items()}}
        self.pieces.append(_take(block, emit))

    def result(self) -> Block | None:
        """Every sample kept, in order (None when none was taken)."""
        if self.open is not None:
            self._flush([*self.open["rows"], self.open["hi"], self.open["lo"]])
            self.open = None
        pieces = [p for p in self.pieces if len(p["t"])]
        return _join(pieces) if pieces else None


def _y(row: Block) -> float:
    return float(row["x2"][0] - row["x1"][0])


class _Window:
    """Rules 1, 2 and 4 on samples coming in chunks; rule 3 in ``_Stretches``."""

    def __init__(self, scene: Scene, n_samples: int) -> None:
        self.walls = tuple((w, 1.0 if w == "lower" else -1.0, scene.gap.position(w)) for w in scene.gap.walls)
        self.stride = max(1, math.ceil(n_samples / PLOT_SAMPLES))
        self.pending: Block | None = None  # the last MARGIN + 1 samples, waiting for the samples after them
        self.reach = -1  # samples up to this step number are kept (MARGIN after the last sample near a wall)
        self.vmax = -math.inf  # the largest |y'| so far [m/s]
        self.spacings: dict[float, int] = {}
        self.last_t: float | None = None
        self.stretches = _Stretches()

    def add(self, block: Block, k0: int) -> None:
        t = block["t"]
        index = np.arange(k0, k0 + len(t))
        before = () if self.last_t is None else (self.last_t,)
        values, counts = np.unique(np.diff(np.concatenate((before, t))), return_counts=True)
        for v, c in zip(values.tolist(), counts.tolist()):
            self.spacings[v] = self.spacings.get(v, 0) + c
        self.last_t = float(t[-1])
        speed = np.abs(block["v2"] - block["v1"])
        highest = np.fmax.accumulate(np.concatenate(([self.vmax], speed)))
        self.vmax = float(highest[-1])
        extra = (speed > highest[:-1]) | (index % self.stride == 0) | (index <= 1)  # samples 0, 1: Trajectory.dt
        block = {**block, "index": index, "extra": extra, "active": np.zeros(len(t), bool)}
        if self.pending is not None:
            block = _join([self.pending, block])
        block["active"] |= self._near(block)
        self._decide(block, final=False)

    def _near(self, block: Block) -> np.ndarray:
        """Rule 1 before the margin: samples in contact, on or past a wall, or on a step that may hide an impact."""
        y, vy = block["x2"] - block["x1"], block["v2"] - block["v1"]
        near = ~(np.isfinite(y) & np.isfinite(vy))
        speed = np.abs(vy)
        with np.errstate(invalid="ignore"):
            reach = REACH_FACTOR * (np.maximum(speed[:-1], speed[1:]) + np.abs(np.diff(vy))) * np.diff(block["t"])
            for wall, nrm, position in self.walls:
                d = nrm * (y - position)
                near |= block[f"contact:{wall}"] | (d <= 0.0)
                step = np.minimum(d[:-1], d[1:]) <= reach
                near[:-1] |= step
                near[1:] |= step
        return near

    def _decide(self, block: Block, final: bool) -> None:
        n = len(block["t"])
        index, active = block["index"], block["active"]
        keep = active.copy()
        for shift in range(1, MARGIN + 1):  # MARGIN samples either side of an active one
            keep[shift:] |= active[:-shift]
            keep[:-shift] |= active[shift:]
        keep |= index <= self.reach
        hits = np.flatnonzero(active)
        if len(hits):
            self.reach = max(self.reach, int(index[hits[-1]]) + MARGIN)
        if final:
            keep[-1] = True
        done = n if final else max(0, n - MARGIN - 1)  # a sample is near by its step to the next one too
        columns = [k for k in block if k not in ("extra", "active")]
        self.stretches.take({k: block[k][:done] for k in columns}, keep[:done], block["extra"][:done])
        self.pending = _take(block, slice(done, n))

    def finish(self) -> tuple[Block | None, float]:
        if self.pending is not None and len(self.pending["t"]):
            self._decide(self.pending, final=True)
        return self.stretches.result(), _median(self.spacings)


def _physical_memory() -> float:
    """This machine's memory [B] (inf where the system does not say)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


class Recorder:
    """An engine run's samples, taken chunk by chunk; a full or a compact ``Trajectory`` at the end (module docstring).

    Parameters
    ----------
    scene : Scene
        The scene run (its walls).
    n_samples : int
        Samples the run will have if it finishes (``base.n_steps`` + 1); a failed run adds fewer.
    above : float, optional
        Compact when ``n_samples`` exceeds this (default ``COMPACT_ABOVE``; 0: always, inf: never).
    """

    def __init__(self, scene: Scene, n_samples: int, above: float | None = None) -> None:
        self.walls = tuple(scene.gap.walls)
        self.n_samples = int(n_samples)
        self.compact = self.n_samples > (COMPACT_ABOVE if above is None else above)
        self.count = 0  # samples added so far
        self.names = [*_STATE, *(f"contact:{w}" for w in self.walls), *(f"force:{w}" for w in self.walls)]
        if self.compact:
            # a run that stays on a wall keeps every sample: refuse what could not fit, as a full run's arrays would
            worst = self.n_samples * (8.0 * (len(_STATE) + 1) + 9.0 * len(self.walls))  # [B]
            if worst > _physical_memory():
                raise MemoryError(f"{self.n_samples} samples may need {worst:.3g} B, more than this machine's "
                                  f"{_physical_memory():.3g} B")
            self._window = _Window(scene, self.n_samples)
        else:
            self._full = {k: np.empty(self.n_samples, bool if k.startswith("contact") else float) for k in self.names}

    def add(self, t, x1, v1, x2, v2, contact: Mapping[str, np.ndarray], force: Mapping[str, np.ndarray]) -> None:
        """The next samples, in order: arrays of one length [s, m, m/s, m, m/s], per wall the contact flag and force [N]."""
        block = {"t": t, "x1": x1, "v1": v1, "x2": x2, "v2": v2,
                 **{f"contact:{w}": np.asarray(contact[w], bool) for w in self.walls},
                 **{f"force:{w}": np.asarray(force[w], float) for w in self.walls}}
        m = len(t)
        if not m:
            return
        if self.count + m > self.n_samples:
            raise ValueError(f"{self.count + m} samples added to a recorder of {self.n_samples}")
        if self.compact:
            self._window.add({k: np.array(v, dtype=bool if k.startswith("contact") else float) for k, v in block.items()},
                             self.count)
        else:
            for k, v in block.items():
                self._full[k][self.count:self.count + m] = v
        self.count += m

    def trajectory(self, engine: str, wall_time: float, **fields) -> Trajectory:
        """The samples added as a ``Trajectory`` (compact when the run is long); ``fields``: its other fields."""
        if self.compact:
            cols, step = self._window.finish()
            if cols is None:  # nothing was added
                cols = {**{k: np.empty(0, bool if k.startswith("contact") else float) for k in self.names},
                        "index": np.empty(0, np.int64)}
            fields["index"] = cols["index"]
            fields.setdefault("step", step)  # the run's dt when the caller records it (``recording.Recording``)
        else:
            cols = {k: v[:self.count] for k, v in self._full.items()}
        return Trajectory(engine=engine, t=cols["t"], x1=cols["x1"], x2=cols["x2"], v1=cols["v1"], v2=cols["v2"],
                          contact={w: cols[f"contact:{w}"] for w in self.walls},
                          normal_force={w: cols[f"force:{w}"] for w in self.walls}, wall_time=wall_time, **fields)


def compact(traj: Trajectory, scene: Scene, above: float | None = None, chunk: int = CHUNK) -> Trajectory:
    """``traj`` compact when it has more than ``above`` samples (default ``COMPACT_ABOVE``), else itself unchanged."""
    n = len(traj.t)
    recorder = Recorder(scene, n, above)
    if traj.compact or not recorder.compact:
        return traj
    for k0 in range(0, n, chunk):
        part = slice(k0, k0 + chunk)
        recorder.add(*(getattr(traj, k)[part] for k in _STATE), {w: traj.contact[w][part] for w in recorder.walls},
                     {w: traj.normal_force[w][part] for w in recorder.walls})
    skip = {"engine", "wall_time", "t", "x1", "x2", "v1", "v2", "contact", "normal_force", "index"}  # step: kept
    return recorder.trajectory(traj.engine, traj.wall_time,
                               **{f.name: getattr(traj, f.name) for f in dataclasses.fields(traj) if f.name not in skip})
