"""An adaptive sweep's levels: the runs each level adds from the rows before it, and the fine map they stand for.

    >>> from chatterbench.comparisons.studies.sweep.adaptive import Sweep, Levels, fine_sweep
    >>> sweep = Sweep(scene="bouncing-ball", engines=("pybullet",), fixed={"duration": 0.6},
    ...               grid={"dt": (1e-3, 1e-2), "restitution": (0.3, 0.7)}, refine={"axes": ["dt", "restitution"], "depth": 1})
    >>> levels = Levels(sweep)
    >>> len(levels.runs(0, rows=None)), levels.fine_shape                      # level 0: the coarse grid
    (4, (3, 3))
    >>> len(fine_sweep(sweep).grid["dt"]), fine_sweep(sweep).refine is None  # the full fine grid, for comparison
    (3, True)

``Levels`` keeps, for each engine and each combination of the other grid keys (a slice),
the fine indices ``(i, j)`` of the points run so far and the level each was added at, and
the edge midpoints inferred (``refine.split_points``);
level ``k`` asks ``refine.split_points`` which cells of level ``k - 1`` to split, from the
rows of the levels before. The same rows give the same levels, so a resumed sweep plans
exactly what an uninterrupted one ran. An engine for which an axis is another engine's
setting is not refined (it runs the coarse grid only).

``agreement`` measures an adaptive map against the full fine grid (``fine_sweep``, run as
an ordinary sweep): each fine point of each engine and slice is filled from the adaptive
rows (``refine.fill``) and compared with the fine grid's row there, on the spec's
boundary label (``refine.boundary_label``; the verdict by default).
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

import numpy as np
import pandas as pd

from chatterbench.comparisons.pipeline.summary import REFINE_LEVEL, point_id

from .refine import boundary_label, fill, lattice, refine_axis_values, split_points
from .dataset import same_value
from .spec import RunTask, Sweep, run_params, seen_by, sweep_runs

Cell = tuple[int, int]  # fine indices (i along axes[0], j along axes[1])
SliceKey = tuple[str, tuple]  # (engine, the slice's (key, value) pairs)


@dataclass(frozen=True)
class LatticeRun:
    """A run a refined sweep may hold at some level: its parameters (what ``dataset.part_problem`` checks)."""

    params: tuple[tuple[str, Any], ...]


def fine_sweep(sweep: Sweep) -> Sweep:
    """The full fine grid an adaptive sweep stands for: each refined axis at every value of its depth, no [refine]."""
    r = sweep.refine
    grid = {k: (lattice(refine_axis_values(v), r.depth) if k in r.axes else v) for k, v in sweep.grid.items()}
    return dataclasses.replace(sweep, grid=grid, refine=None)


class Levels:
    """The points of a refined sweep, level by level (see the module docstring)."""

    def __init__(self, sweep: Sweep) -> None:
        if sweep.refine is None:
            raise ValueError("Levels needs a sweep with [refine]")
        self.sweep, self.refine = sweep, sweep.refine
        self.name = sweep.scene_name
        self.axes = self.refine.axes
        self.values = {a: lattice(refine_axis_values(sweep.grid[a]), self.refine.depth) for a in self.axes}
        self.index = {a: {v: i for i, v in enumerate(vals)} for a, vals in self.values.items()}
        self.fine_shape = (len(self.values[self.axes[0]]), len(self.values[self.axes[1]]))
        self.engines = [e for e in sweep.engines if all(seen_by(a, e) for a in self.axes)]
        # (engine, slice) -> fine indices -> (level added, point id)
        self.added: dict[SliceKey, dict[Cell, tuple[int, str]]] = {}
        self.inferred: dict[SliceKey, dict[Cell, Any]] = {}  # (engine, slice) -> midpoints inferred, not run -> label

    def slices(self, engine: str) -> Iterator[tuple[tuple, dict[str, Any]]]:
        """Each combination of the grid keys other than the axes that ``engine``'s runs see."""
        keys = [k for k in self.sweep.grid if k not in self.axes and seen_by(k, engine)]
        for combo in itertools.product(*(self.sweep.grid[k] for k in keys)):
            yield tuple(zip(keys, combo)), dict(zip(keys, combo))

    def point(self, where: Mapping[str, Any], cell: Cell) -> dict[str, Any]:
        """The point at fine indices ``cell`` of a slice, keys in spec order ([set], then [grid])."""
        at = {self.axes[0]: self.values[self.axes[0]][cell[0]], self.axes[1]: self.values[self.axes[1]][cell[1]]}
        grid = {k: at[k] if k in at else where[k] for k in self.sweep.grid if k in at or k in where}
        return {**self.sweep.fixed, **grid}

    def _record(self, engine: str, key: tuple, where: dict, cells: list[Cell], level: int) -> list[dict[str, Any]]:
        added = self.added.setdefault((engine, key), {})
        points = []
        for cell in sorted(cells):
            p = self.point(where, cell)
            added[cell] = (level, point_id(self.name, engine, run_params(p, engine)))
            points.append(p)
        return points

    def runs(self, level: int, rows: pd.DataFrame | None, start: int = 0, seen: set[str] | None = None) -> list[RunTask]:
        """The runs level ``level`` adds (level 0: the whole grid and [[points]]); ``rows``: those of the levels before.

        Call levels in order, 0 first: each records its points for the next.
        """
        seen = set() if seen is None else seen
        step = 2 ** self.refine.depth
        if level == 0:
            nx, ny = (len(refine_axis_values(self.sweep.grid[a])) for a in self.axes)
            coarse = [(i * step, j * step) for i in range(nx) for j in range(ny)]
            for e in self.engines:
                for key, where in self.slices(e):
                    self._record(e, key, where, coarse, 0)
            return sweep_runs(self.sweep, start=start, seen=seen)
        labels = {k: boundary_label(r, self.refine) for k, r in _records(rows)}
        runs: list[RunTask] = []
        for e in self.engines:
            for key, where in self.slices(e):
                added = self.added.get((e, key), {})
                known = {c: labels[(pid, e)] for c, (_, pid) in added.items() if (pid, e) in labels}
                inferred = self.inferred.setdefault((e, key), {})
                todo, guessed = split_points({**inferred, **known}, level, self.refine.depth)
                inferred.update(guessed)
                points = self._record(e, key, where, list(todo), level)
                runs += sweep_runs(self.sweep, points, engines=(e,), start=start + len(runs), seen=seen)
        return runs

    def lattice_runs(self, frame: pd.DataFrame) -> dict[tuple[str, str], LatticeRun]:
        """The rows of ``frame`` whose points lie on this sweep's fine lattice, as runs (for ``dataset.check_parts``).

        A row belongs when each of its run's parameters is one the spec allows there (the
        fixed value, a grid value, or a fine value of an axis) and its point id is theirs.
        """
        grid, out = self.sweep.grid, {}
        for rec in frame.to_dict("records"):
            e = rec.get("engine")
            if e not in self.engines:
                continue
            point: dict[str, Any] = {}
            for k in list(self.sweep.fixed) + [k for k in grid if k not in self.sweep.fixed]:
                if not seen_by(k, e):
                    continue
                allowed = [self.sweep.fixed[k]] if k in self.sweep.fixed else self.values.get(k, grid[k])
                match = [a for a in allowed if same_value(rec.get(k), a)]
                if not match:
                    break
                point[k] = match[0]
            else:
                params = run_params(point, e)
                if point_id(self.name, e, params) == rec.get("point_id"):
                    out[(rec["point_id"], e)] = LatticeRun(tuple(params.items()))
        return out


def _records(rows: pd.DataFrame | None) -> Iterator[tuple[tuple[str, str], dict[str, Any]]]:
    if rows is None or rows.empty:
        return
    for rec in rows.to_dict("records"):
        yield (rec["point_id"], rec["engine"]), rec


def _cells(levels: Levels, rows: pd.DataFrame, engine: str, where: Mapping[str, Any]) -> pd.DataFrame:
    """``engine``'s rows of one slice that sit on the fine lattice, with their fine indices ``i``, ``j``."""
    sub = rows[rows["engine"] == engine]
    for k, v in where.items():
        sub = sub[[same_value(x, v) for x in sub[k]]] if k in sub else sub.iloc[0:0]
    x, y = levels.axes
    i = [levels.index[x].get(float(v)) for v in sub[x]]
    j = [levels.index[y].get(float(v)) for v in sub[y]]
    sub = sub.assign(_i=i, _j=j)
    return sub[sub["_i"].notna() & sub["_j"].notna()]


def agreement(sweep: Sweep, adaptive: pd.DataFrame, fine: pd.DataFrame) -> pd.DataFrame:
    """How well an adaptive map stands for the full fine grid, per engine.

    Parameters
    ----------
    adaptive : the refined sweep's rows (with ``refine_level``).
    fine : the rows of ``fine_sweep(sweep)``.

    Returns
    -------
    DataFrame
        engine, cells (fine points over every slice), agree (those whose filled label
        equals the fine grid's), agreement = agree / cells, adaptive_runs, fine_runs.
    """
    levels = Levels(sweep)
    out = []
    for e in levels.engines:
        cells = agree = 0
        for _, where in levels.slices(e):
            got = _cells(levels, adaptive, e, where)
            want = _cells(levels, fine, e, where)
            points = {(int(a), int(b)): (int(lv), boundary_label(r, sweep.refine))
                      for a, b, lv, r in zip(got["_i"], got["_j"], got[REFINE_LEVEL], got.to_dict("records"))}
            filled = fill(points, levels.fine_shape, sweep.refine.depth)
            truth = np.full(levels.fine_shape, None, dtype=object)
            for a, b, r in zip(want["_i"], want["_j"], want.to_dict("records")):
                truth[int(a), int(b)] = boundary_label(r, sweep.refine)
            have = np.array([t is not None for t in truth.ravel()])
            cells += int(have.sum())
            agree += int(sum(f == t for f, t, h in zip(filled.ravel(), truth.ravel(), have) if h))
        out.append({"engine": e, "cells": cells, "agree": agree, "agreement": agree / cells if cells else float("nan"),
                    "adaptive_runs": int((adaptive["engine"] == e).sum()), "fine_runs": int((fine["engine"] == e).sum())})
    return pd.DataFrame(out)
