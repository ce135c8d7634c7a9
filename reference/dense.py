"""A dense trajectory sampled at any times from a scene and its event log.

    >>> result = simulate(scene)
    >>> traj = sample(scene, result.log, np.linspace(0.0, scene.t_end, 2001))
    >>> traj[["t", "y", "vy"]].head()

The event log holds the state just after every event (x1, v1 in its columns, y on the
named wall, vy = v_plus), and whether the masses move freely or in kinematic constraint
follows from the event kinds (constrained from a ``stick`` until its ``exit``). Each sample
is the closed-form flow of ``linear.py`` from the last event at or before its time, so
the samples are as exact as the log itself. Columns: t [s], x1, x2, y [m], v1, v2, vy [m/s].
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .flow import Flow
from .linear import V1, VY, X1, Y, LinearSystem
from .scene import Scene

DENSE_COLUMNS = ["t", "x1", "x2", "v1", "v2", "y", "vy"]


def _segments(scene: Scene, log: pd.DataFrame):
    """(start time, x1, v1, y, vy, constrained) for the initial state and after every event."""
    init = scene.initial
    stuck_now = False
    starts = [(init.t, init.x1, init.v1, init.y, init.vy, False)]
    for t, kind, wall, v_plus, x1, v1 in zip(
        log["t"].to_numpy(), log["kind"].to_numpy(), log["wall"].to_numpy(),
        log["v_plus"].to_numpy(), log["x1"].to_numpy(), log["v1"].to_numpy(),
    ):
        if kind == "stick":
            stuck_now = True
        elif kind == "exit":
            stuck_now = False
        elif kind == "plate_entry":
            continue  # informational: the impact row beside it carries the state
        y = scene.gap.position(wall)
        starts.append((float(t), float(x1), float(v1), y, 0.0 if stuck_now else float(v_plus), stuck_now))
    return starts


def sample(scene: Scene, log: pd.DataFrame, times) -> pd.DataFrame:
    """Sample the reference motion at ``times`` [s] (any order, inside the run).

    Returns
    -------
    DataFrame
        One row per time, columns ``DENSE_COLUMNS``.
    """
    times = np.asarray(times, dtype=float)
    system = LinearSystem.from_scene(scene)
    flows = {
        False: Flow(system.free, horizon=scene.time_scale / 4.0),
        True: Flow(system.stuck, horizon=scene.time_scale / 4.0),
    }
    starts = _segments(scene, log)
    t_starts = np.array([s[0] for s in starts])
    # an event shares its time with the ones logged right after it: take the last of them
    idx = np.searchsorted(t_starts, times, side="right") - 1
    idx = np.clip(idx, 0, len(starts) - 1)
    out = np.empty((len(times), 7))
    for j in np.unique(idx):
        t0, x1, v1, y, vy, stuck = starts[j]
        flow = flows[stuck]
        s0 = system.state(t0, x1, v1, y, vy)
        for i in np.nonzero(idx == j)[0]:
            h = times[i] - t0
            s = flow.advance(s0, max(h, 0.0))
            out[i] = (times[i], s[X1], s[X1] + s[Y], s[V1], s[V1] + s[VY], s[Y], s[VY])
    return pd.DataFrame(out, columns=DENSE_COLUMNS)
