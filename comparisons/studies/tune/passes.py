"""Where a tune candidate's row stands: whether it passes and at which ladder points, its cost, how close it comes, and
the ladder points where a run can still matter.

    >>> from chatterbench.comparisons.studies.tune.passes import agrees, cost, passes
    >>> row = {"dt": 1e-3, "verdict": "match", "steps_per_sim_s": None}
    >>> agrees("late"), passes(row, asked=2), cost(row)    # no ``passes`` of its own: the asked point, where it agrees
    (False, (2,), 1000.0)
"""

from __future__ import annotations

import math
from typing import Any

from ...pipeline.vocabulary import VERDICTS
from .grid import DT_RATIO

NEED_SLACK = 1.01  # [-] a run's cost may differ from 1 / dt by its step count's rounding; this covers it


def agrees(verdict: str) -> bool:
    """Whether a verdict passes: the engine does what the reference does (``match``, or ``none`` for both)."""
    return verdict in VERDICTS and VERDICTS[verdict].group == "agree"


def params_key(params: dict[str, Any]) -> tuple:
    """A candidate's identity: its settings (and phase), sorted."""
    return tuple(sorted(params.items()))


def cost(row: dict[str, Any]) -> float:
    """A row's steps per simulated second (1 / dt where the engine reported none)."""
    c = row.get("steps_per_sim_s", math.nan)
    return 1.0 / row["dt"] if c is None or (isinstance(c, float) and math.isnan(c)) else float(c)


def reach_key(row: dict[str, Any]) -> tuple:
    """How close a row comes to passing, the closest first: most matching episodes, the smallest worst error over its
    tolerance, the fewest steps."""
    worst = row.get("worst_ratio", math.inf)
    return (-row.get("n_match", 0), math.inf if worst is None or math.isnan(worst) else worst, cost(row))


def need(c: float, bounds: list[float], asked: int) -> list[int]:
    """The ladder points where a run of cost ``c`` (steps per simulated second) can still matter, given the search's
    ``bounds`` when it was asked for: the asked point, and every point whose bound reaches ``c`` / ``DT_RATIO`` (the
    cheapest candidate it can be the dt x 0.8 neighbour of; ``NEED_SLACK`` over it for rounding). Bounds only fall,
    so a point left out never matters to it later: neither as a candidate (dearer than the point's answer, or than
    that of a tighter point) nor as a neighbour (its candidates are dearer still)."""
    return [p for p, b in enumerate(bounds) if p == asked or c <= b * DT_RATIO * NEED_SLACK]


def passes(row: dict[str, Any], asked: int = 0) -> tuple[int, ...]:
    """The ladder points a row passes at (its ``passes``; without one, the asked point when its verdict agrees)."""
    p = row.get("passes")
    if p is not None and not (isinstance(p, float) and math.isnan(p)):
        return tuple(p)
    return (asked,) if agrees(row["verdict"]) else ()
