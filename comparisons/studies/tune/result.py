"""What a tune answers: every candidate tried, the recommendation, the fragile pass, the best reachable and the frontier.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...               ladder=None, check_robust=False)     # one candidate, no neighbourhood: every pass counts
    >>> result.chosen["settings"], result.chosen_tolerance.stick, result.margin < 1
    ('dt=0.001, pybullet.restitution_velocity_threshold=0.1', 0.05, True)

``chosen`` is what is written (``recommended.json``, the guide): the recommendation at the asked
tolerances (``tune.choice``); where there is none, the tightest robust frontier point's answer,
robust at its own tolerances (``written``); where nothing is robust anywhere, the best reachable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from chatterbench.reference.scene import Scene

from ...pipeline.tolerances import Tolerances
from .checks import judged_margin
from .choice import TIE_BAND, cost_key, passing
from .ladder import margin_at


@dataclass(frozen=True)
class TuneResult:
    """Every candidate tried (``table``, cheapest first), the recommendation, the fragile pass and the best reachable."""

    scene: Scene
    engine: str
    tolerance: Tolerances
    table: pd.DataFrame  # tune.rows.TUNE_COLUMNS plus one column per searched setting
    best: dict[str, Any] | None  # the cheapest robust pass (tune.choice.choose), None if none
    best_reachable: dict[str, Any] | None  # when nothing robust passes: the closest (tune.choice.reachable)
    extra: dict[str, Any] = field(default_factory=dict)  # space, grid, searched, defaults, tie band, repeats, wall time
    fragile: dict[str, Any] | None = None  # the cheapest pass whose neighbourhood fails, if cheaper than ``best``
    frontier: list[dict[str, Any]] = field(default_factory=list)  # tune.frontier.frontier_entries, cheapest first
    written: int | None = None  # nothing robust at the asked tolerances: the ladder point whose answer is written

    @property
    def written_row(self) -> dict[str, Any] | None:
        """The answer of the ladder point ``written`` (None: none)."""
        return None if self.written is None else self.extra["answers"][self.written]

    @property
    def chosen(self) -> dict[str, Any] | None:
        """What is written: the recommendation; when nothing robust passes the asked tolerances, the tightest robust
        frontier point's answer (``written``: robust at its own tolerances); when nothing is robust anywhere, the
        best reachable candidate."""
        if self.best is not None:
            return self.best
        return self.written_row if self.written is not None else self.best_reachable

    @property
    def chosen_tolerance(self) -> Tolerances:
        """The tolerances the chosen candidate is judged at: the asked ones, or the written frontier point's."""
        return self.tolerance if self.written is None else self.extra["points"][self.written]

    @property
    def margin(self) -> float:
        """The chosen candidate's worst measured error over its tolerance among the judge's checks [-] (<= 1: passes,
        the smaller the more room; inf: an episode with no error to measure; NaN: none ran), at its tolerances
        (``chosen_tolerance``). Restitution under the scene's forces is ``scene_restitution_ratio`` beside it."""
        c = self.chosen
        if c is None:
            return math.nan
        return margin_at(c, self.written) if self.written is not None else judged_margin(c)

    def cheaper(self, fragile: bool = False) -> pd.DataFrame:
        """The failing candidates no more expensive than the chosen one (steps within the tie band), cheapest first;
        ``fragile``: the passes among them whose neighbourhood fails instead."""
        c = self.chosen
        if c is None:
            return self.table.iloc[0:0]
        t = self.table
        key = cost_key(t[t["verdict"] != "refused"])
        limit = c[key] * (1.0 + self.extra.get("tie_band", TIE_BAND))
        which = (passing(t["verdict"]) & (t["robust"] == False)) if fragile else ~passing(t["verdict"])  # noqa: E712
        searched = t["phase"].isna() if "phase" in t else True  # a band's run checks a candidate: it is none itself
        return t[(t[key] <= limit) & which & searched & (t["settings"] != c["settings"])].sort_values(key, kind="stable")
