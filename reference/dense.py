"""A dense trajectory sampled at any times from a scene and its event log.

    >>> import numpy as np
    >>> from chatterbench.reference.dense import sample
    >>> from chatterbench.reference import load_scene, simulate
    >>> scene = load_scene("feigin-pair")
    >>> traj = sample(scene, simulate(scene).log, np.linspace(0.0, scene.t_end, 2001))
    >>> traj.shape, list(traj.columns)
    ((2001, 7), ['t', 'x1', 'x2', 'v1', 'v2', 'y', 'vy'])

The event log holds the state just after every event (x1, v1 in its columns, y on the
named wall, vy = v_plus), and whether the masses move freely or in kinematic constraint
follows from the event kinds (constrained from a ``stick`` until its ``exit``). Each sample
is the closed-form flow of ``linear.py`` from the last event at or before its time, so
the samples are as exact as the log itself. Columns: t [s], x1, x2, y [m], v1, v2, vy [m/s].
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .flow import shared_flow
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


class Motion:
    """The exact motion of ``scene`` from its event log, ready to be sampled many times: its segments (the state after
    every event), system and flows made once (``sample_states`` makes them at each call; a caller sampling a few
    times at a time, as strikes do before each impact, keeps one: ``ReferenceSolution.motion``)."""

    def __init__(self, scene: Scene, log: pd.DataFrame) -> None:
        self.system = LinearSystem.from_scene(scene)
        horizon = scene.time_scale / 4.0
        self.flows = {False: shared_flow(self.system.free, horizon), True: shared_flow(self.system.stuck, horizon)}
        self.starts = _segments(scene, log)
        self.t_starts = np.array([s[0] for s in self.starts])

    def states(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact (x1, v1, y, vy) at non-decreasing ``times`` [s], shape (n, 4), and the wall y of the kinematic
        constraint at each time (NaN while the masses move freely), shape (n,) (``sample_states``)."""
        times = np.asarray(times, dtype=float)
        system, starts = self.system, self.starts
        # an event shares its time with the ones logged right after it: take the last of them
        idx = np.clip(np.searchsorted(self.t_starts, times, side="right") - 1, 0, len(starts) - 1)
        out = np.empty((len(times), 4))
        stuck_y = np.full(len(times), np.nan)
        cuts = np.searchsorted(idx, np.arange(len(starts) + 1))  # idx is sorted: segment j is cuts[j]:cuts[j+1]
        for j in np.flatnonzero(np.diff(cuts)):
            lo, hi = cuts[j], cuts[j + 1]
            t0, x1, v1, y, vy, stuck = starts[j]
            flow = self.flows[stuck]
            s = system.state(t0, x1, v1, y, vy)
            h = np.maximum(times[lo:hi] - t0, 0.0)
            # as Flow.advance: whole steps while h > step, then the remainder in (0, step]
            whole = np.maximum(np.ceil(h / flow.step) - 1.0, 0.0).astype(np.int64)
            done = 0
            for m in np.unique(whole):
                while done < m:
                    s = flow.step_matrix @ s
                    done += 1
                sel = np.flatnonzero(whole == m)
                r = h[sel] - m * flow.step
                coeffs = flow.taylor(s)  # (order + 1, n_state)
                vals = np.broadcast_to(coeffs[-1], (len(sel), coeffs.shape[1])).copy()
                for c in coeffs[-2::-1]:
                    vals = vals * r[:, None] + c
                out[lo + sel] = vals[:, [X1, V1, Y, VY]]
            if stuck:
                stuck_y[lo:hi] = y
        return out, stuck_y

    def at(self, times) -> np.ndarray:
        """Exact (x1, v1, y, vy) at ``times`` [s] in any order (inside the run), shape (n, 4)."""
        times = np.asarray(times, dtype=float)
        order = np.argsort(times, kind="stable")
        out = np.empty((len(times), 4))
        out[order] = self.states(times[order])[0]
        return out


def sample_states(scene: Scene, log: pd.DataFrame, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact (x1, v1, y, vy) at non-decreasing ``times`` [s], shape (n, 4), and the wall y of
    the kinematic constraint at each time (NaN while the masses move freely), shape (n,).

    Each segment's Taylor polynomial is evaluated by Horner's rule over all of its samples
    at once (whole flow steps first), so 1e6 samples take about a second.
    """
    return Motion(scene, log).states(times)


def sample(scene: Scene, log: pd.DataFrame, times) -> pd.DataFrame:
    """Sample the reference motion at ``times`` [s] (any order, inside the run).

    Returns
    -------
    DataFrame
        One row per time, columns ``DENSE_COLUMNS``.
    """
    times = np.asarray(times, dtype=float)
    x1, v1, y, vy = Motion(scene, log).at(times).T
    return pd.DataFrame({"t": times, "x1": x1, "x2": x1 + y, "v1": v1, "v2": v1 + vy, "y": y, "vy": vy},
                        columns=DENSE_COLUMNS)
