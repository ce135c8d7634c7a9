"""The choice among a tune's candidates: the recommendation, the fragile pass beside it and the best reachable one.

    >>> import pandas as pd
    >>> from chatterbench.comparisons.studies.tune.choice import choose
    >>> table = pd.DataFrame({"verdict": ["match", "match", "late"], "robust": [True, True, None],
    ...                       "steps_per_sim_s": [1000.0, 1050.0, 500.0], "cost_per_sim_s": [0.2, 0.1, 0.05],
    ...                       "n_non_default": [1, 0, 0], "dt": [1e-3, 9.5e-4, 2e-3], "settings": ["a", "b", "c"]})
    >>> choose(table)["settings"]     # 1,050 steps are within 10% of 1,000: a tie, which goes to the simpler setting
    'b'

Cost and choice. The cost of a candidate is its steps per simulated second (1 / dt: every
searched setting makes one force evaluation per step, so this is the work, and it is free
of timing noise), with the wall-clock stepping time per simulated second beside it
(``cost_per_sim_s``: the minimum over ``repeats`` runs for the candidates the choice is
between, interleaved, one run for the others; ``cost_repeats`` says which): reported, never
deciding, since on a shared machine it follows the load (``TIE_BAND``'s comment). The
recommendation (``best``) is the *robust* passing candidate (verdicts ``match`` or ``none`` in
every episode, and in every episode of each neighbour) of fewest steps; those within
``tie_band`` (10%) of it in steps are tied, and the tie goes to the simplest: fewest settings
away from the engine's defaults, then the larger dt, then the smaller wall time. Beside it,
``fragile``: the cheapest pass whose neighbourhood fails, when it is cheaper than the answer
(an isolated point: a small change of the model can land on a failure); a tie in steps goes as
the frontier's answers do (``TIE_KEYS``), never to the faster-timed run. The margin is the
answer's worst error over its tolerance among the judge's checks (restitution under the
scene's forces beside it). When nothing robust passes, ``best_reachable`` is the
pass whose neighbourhood fails least (fewest failing neighbours, then the smallest worst ratio
over the neighbourhood, then the fewest steps), else the candidate with the most matching
episodes, then the smallest ``worst_ratio``, then the fewest steps.
"""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from .passes import agrees

TIE_BAND = 0.1  # [-] steps per simulated second within 10% of each other are a tie
# Wall time decides nothing: on this shared 2-core machine the least of 3 interleaved timings of PyBullet at
# dt = 4.05e-4 with 10 and 50 solver iterations (identical trajectories) came out 1.10x apart in one measurement
# and 2.2x in another (tune feigin-pair --engine pybullet --tolerance 0.01): a choice by it follows the load.


def passing(verdicts: pd.Series) -> pd.Series:
    """Whether each candidate's verdict agrees with the reference (``match``, or ``none`` when nothing sticks)."""
    return verdicts.map(agrees).astype(bool)


def cost_key(frame: pd.DataFrame) -> str:
    """The column that ranks cost in ``frame``: steps when every candidate has them, else wall time."""
    return "steps_per_sim_s" if frame["steps_per_sim_s"].notna().all() else "cost_per_sim_s"


def tied(frame: pd.DataFrame, column: str, band: float) -> pd.DataFrame:
    """The rows of ``frame`` within ``band`` [-] of its least ``column`` (all of them when none has a value)."""
    low = frame[column].min()
    return frame[frame[column] <= low * (1.0 + band)] if pd.notna(low) else frame


def choose(table: pd.DataFrame, band: float = TIE_BAND, max_cost: float = math.inf,
           checked: bool = True) -> dict[str, Any] | None:
    """The recommendation among ``table``'s robust passing candidates of at most ``max_cost`` steps per simulated
    second (module docstring); None if none.

    ``checked`` False (no neighbourhood was run), or a table without ``robust``: every pass counts. Otherwise a pass
    whose neighbourhood the budget left unrun is no answer.
    """
    ok = table[passing(table["verdict"]) & ~(table["steps_per_sim_s"] > max_cost)]
    if "robust" in ok and checked:
        ok = ok[ok["robust"] == True]  # noqa: E712 (an object column: True, False or None)
    if ok.empty:
        return None
    meets_r = ok[~(ok["scene_restitution_ratio"] > 1.0)] if "scene_restitution_ratio" in ok else ok
    ok = meets_r if len(meets_r) else ok  # R missed under the scene's forces counts against a candidate
    return (tied(ok, cost_key(ok), band).sort_values(["n_non_default", "dt", "cost_per_sim_s"], ascending=[True, False, True])
            .iloc[0].to_dict())


def fragile(table: pd.DataFrame, best: dict[str, Any] | None) -> dict[str, Any] | None:
    """The cheapest pass whose neighbourhood fails, when it is cheaper than ``best`` (or there is no ``best``)."""
    if "robust" not in table:
        return None
    weak = table[passing(table["verdict"]) & (table["robust"] == False)]  # noqa: E712
    if best is not None:
        weak = weak[weak["steps_per_sim_s"] < best["steps_per_sim_s"]]
    return None if weak.empty else first_of(weak, ["steps_per_sim_s"], [True])


def reachable(table: pd.DataFrame, max_cost: float = math.inf) -> dict[str, Any] | None:
    """The best reachable candidate (module docstring): a fragile pass failing least, else most matching episodes,
    then the smallest worst ratio, then the fewest steps.

    Among the searched candidates of at most ``max_cost`` steps per simulated second: a run made only as another's
    neighbour (dt x 0.8 or x 1.25, off the searched lattice; stage ``neighbourhood``) checks that one and is no
    answer, unless nothing else ran.
    """
    ran = table[table["verdict"] != "refused"]
    if "stage" in ran:
        searched = ran[(ran["stage"] != "neighbourhood") & ~(ran["steps_per_sim_s"] > max_cost)]
        ran = searched if len(searched) else ran
    if ran.empty:
        return None
    if "robust" in ran:
        weak = ran[passing(ran["verdict"]) & (ran["robust"] == False)]  # noqa: E712
        if len(weak):
            n_fail = weak["neighbourhood"].str.count(";") + 1
            best = first_of(weak.assign(_n=n_fail), ["_n", "neighbourhood_worst_ratio", "steps_per_sim_s"],
                            [True, True, True])
            return {k: v for k, v in best.items() if k != "_n"}
    return first_of(ran, ["n_match", "worst_ratio", "steps_per_sim_s"], [False, True, True])


# a tie in the keys, in the frontier's answers (``frontier.answers``) as in the fragile pass and the best reachable:
# fewest settings changed from the defaults, the larger dt, the settings' text; never the table's order, which follows
# measured wall times (``rows.table_of``)
TIE_KEYS = (("n_non_default", True), ("dt", False), ("settings", True))


def first_of(frame: pd.DataFrame, keys: list[str], ascending: list[bool]) -> dict[str, Any]:
    """The first row of ``frame`` by ``keys``, ties broken by ``TIE_KEYS`` (those ``frame`` has), as a dict."""
    tail = [(k, a) for k, a in TIE_KEYS if k in frame and k not in keys]
    order = frame.sort_values([*keys, *(k for k, _ in tail)], ascending=[*ascending, *(a for _, a in tail)],
                              kind="stable")
    return order.iloc[0].to_dict()
