"""The event log and the episode table: the vocabulary every simulator in the suite speaks.

    >>> from chatterbench.reference.log import EventLog, episodes
    >>> log = EventLog()
    >>> log.add(0.45, "impact", "lower", v_minus=-4.43, v_plus=2.21, x1=0.0, v1=0.0)
    >>> log.add(0.9, "stick", "lower", v_minus=0.0, v_plus=0.0, x1=0.0, v1=0.0, rule="zeno")
    >>> episodes(log.frame())[["wall", "t_first_impact", "t_stick", "n_impacts"]].values.tolist()
    [['lower', 0.45, 0.9, 1]]

Event log columns (one row per event, in time order):

=========  =================================================================================
t          event time [s]
kind       ``impact``, ``plate_entry``, ``stick`` or ``exit``
wall       ``lower`` or ``upper``
v_minus    relative velocity y' just before the event [m/s] (y = x2 - x1)
v_plus     relative velocity y' just after the event [m/s] (0 for plate_entry/stick/exit
           in Feigin's model)
x1, v1     body 1 position [m] and velocity [m/s] just after the event
rule       what started a ``stick``: ``plate`` (strike inside Feigin's Pi_2, (2.1)-(2.2)),
           ``accumulation`` (impacts accumulating outside the plate), ``zeno`` (the
           accumulation point of the full impact sequence, exhaustive mode), ``inelastic``
           (R = 0 and y'' into the wall), ``contact`` (a state resting on a wall, e.g. the
           initial one); for an ``impact`` that Feigin's model makes perfectly inelastic,
           ``plate``; empty otherwise
=========  =================================================================================

Episodes (one per visit to a wall that ends in sticking; a visit starts at the first
impact after an exit, after an impact on the other wall, or at the start of the run; an
exit closes only a stick on its own wall, so an episode never takes another wall's exit):

=================  =========================================================================
wall               ``lower`` or ``upper``
t_first_impact     first impact of the visit [s]
t_plate_entry      first strike of the visit inside Pi_2 [s] (NaN if none)
t_stick            start of the motion in kinematic constraint [s]
t_exit             separation, when y'' of the free motion turns away from the wall [s]
                   (NaN if the run ends stuck)
n_impacts          impacts of the visit up to the sticking (a Feigin plate strike counts)
stick_rule         the ``rule`` of the stick event
=================  =========================================================================
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

KINDS = ("impact", "plate_entry", "stick", "exit")
WALLS = ("lower", "upper")
LOG_COLUMNS = ["t", "kind", "wall", "v_minus", "v_plus", "x1", "v1", "rule"]
EPISODE_COLUMNS = ["wall", "t_first_impact", "t_plate_entry", "t_stick", "t_exit", "n_impacts", "stick_rule"]


class EventLog:
    """An append-only list of events, turned into a DataFrame with ``frame()``."""

    def __init__(self) -> None:
        self.rows: list[tuple] = []

    def add(self, t: float, kind: str, wall: str, v_minus: float, v_plus: float, x1: float, v1: float, rule: str = "") -> None:
        """Append one event (units and meaning in the module docstring)."""
        self.rows.append((t, kind, wall, v_minus, v_plus, x1, v1, rule))

    def __len__(self) -> int:
        return len(self.rows)

    def frame(self) -> pd.DataFrame:
        """The log as a DataFrame with ``LOG_COLUMNS``."""
        return log_frame(self.rows)


def log_frame(rows) -> pd.DataFrame:
    """DataFrame with ``LOG_COLUMNS`` and fixed dtypes from an iterable of row tuples."""
    rows = list(rows)
    cols = list(zip(*rows)) if rows else [()] * len(LOG_COLUMNS)
    data = {}
    for name, values in zip(LOG_COLUMNS, cols):
        if name in ("kind", "wall", "rule"):
            arr = np.empty(len(values), dtype=object)
            arr[:] = values
        else:
            arr = np.asarray(values, dtype=float)
        data[name] = arr
    return pd.DataFrame(data, columns=LOG_COLUMNS)


def episodes(log: pd.DataFrame) -> pd.DataFrame:
    """Derive the episode table (``EPISODE_COLUMNS``) from an event log."""
    out = []
    visit = None  # the open visit: dict of episode fields
    stuck = ""  # the wall the masses are stuck on ("" while free)
    kinds, rules = log["kind"].tolist(), log["rule"].tolist()
    for t, kind, wall in zip(log["t"].tolist(), kinds, log["wall"].tolist()):
        if kind == "impact":
            if stuck:
                continue
            if visit is None or visit["wall"] != wall:
                visit = {"wall": wall, "t_first_impact": t, "t_plate_entry": math.nan, "n_impacts": 0}
            visit["n_impacts"] += 1
        elif kind == "plate_entry":
            if visit is None or visit["wall"] != wall:
                visit = {"wall": wall, "t_first_impact": math.nan, "t_plate_entry": math.nan, "n_impacts": 0}
            if math.isnan(visit["t_plate_entry"]):
                visit["t_plate_entry"] = t
        elif kind == "stick":
            if visit is None or visit["wall"] != wall:
                visit = {"wall": wall, "t_first_impact": math.nan, "t_plate_entry": math.nan, "n_impacts": 0}
            visit["t_stick"] = t
            visit["t_exit"] = math.nan
            visit["stick_rule"] = ""
            out.append(visit)
            stuck = wall
        elif kind == "exit":
            if stuck != wall:
                continue  # an exit closes only a stick on its own wall
            out[-1]["t_exit"] = t
            stuck = ""
            visit = None
    for ep, rule in zip(out, (rule for kind, rule in zip(kinds, rules) if kind == "stick")):
        ep["stick_rule"] = rule
    df = pd.DataFrame(out, columns=EPISODE_COLUMNS)
    df["n_impacts"] = df["n_impacts"].astype(int)
    return df
