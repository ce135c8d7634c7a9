"""Where tune's coarse grid stalls: the walk over its dt rows that stops the finer ones (``tune.search``).

    >>> from chatterbench.comparisons.studies.tune.stall import StallWalk
    >>> walk = StallWalk()
    >>> for dt in (1e-2, 4.1e-3, 1.68e-3, 6.87e-4):     # rows 2.44x apart, the same error on each
    ...     step = walk.add_row(dt, [{"worst_ratio": 3.0, "n_match": 0}])
    ...     walk.judge(dt, step, answering=False)
    >>> walk.stalled_dt, walk.past(6.87e-4), walk.past(1.68e-3)
    (0.00168, True, False)

The coarse rows are taken in *steps*: the first row alone, then each run of rows that ends
``STALL_STEP`` (2.44x) or more finer than the step before (one row of ``tune.space``'s spaces
at the default depth; four at depth 0; as many as it takes in a space of closer dts), so that
the gain asked of a step is that of a first-order error over the same span whatever the rows'
spacing. A step is judged once, as its last row is run with its neighbourhoods. It gets
closer when one of its runs is now a ladder point's answer or could still be one at a point it
passes (``answering``: the search's ``answerable``; a pass, fragile or unchecked, may turn
robust finer), or it matches more episodes than any step before, or its least worst error
over its tolerance is below the best so far / ``STALL_GAIN``. Steps count only from the first
that measured something (a match or a finite worst error: a refused, unresolved or unstable
coarse row says nothing of the step's error); the ``STALL_ROWS``-th step in a row that does
not get closer is the stall, latched at its last row's dt: no finer lattice dt runs after it.
What is left is the contact model's error, not the step's (a first-order step's error falls
2.44x a step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from .grid import DT_RATIO

STALL_ROWS = 2  # steps of coarse rows in a row that bring the grid no closer before the finer ones are left
STALL_GAIN = 1.5  # [-] a step gets closer when its least worst error (over its tolerance) is this much below the best
STALL_STEP = DT_RATIO ** 4  # [-] a step of the walk spans at least this dt ratio (2.44x: a coarse row of tune's spaces)
STEP_SLACK = 1.01  # [-] the coarse dts are rounded to 3 significant digits: a row 2.43x finer still ends a step


def finite(x: Any, missing: float = math.inf) -> float:
    """A row's measure as a number, ``missing`` where it has none (None, NaN): a worst error ratio infinitely far."""
    return missing if x is None or isinstance(x, float) and math.isnan(x) else float(x)


@dataclass
class StallWalk:
    """The walk's place (module docstring): the step's runs so far, the dt [s] that ended the last step, the best
    match and worst error of the steps walked, the steps in a row that got no closer, and the stall once latched."""

    rows_walked: int = 0  # coarse rows walked so far (the search's next row to walk is this one)
    step: list[dict] = field(default_factory=list)
    last_dt: float | None = None
    match: float = 0.0
    worst: float = math.inf
    still: int = 0
    stalled_dt: float | None = None  # [s] the coarse dt where the grid stalled, None: not (yet)

    def add_row(self, dt: float, row: list[dict]) -> list[dict] | None:
        """Add a wholly run coarse row at ``dt`` [s]; the step's runs when this row ends a step, else None."""
        self.rows_walked += 1
        self.step += row
        if self.last_dt is not None and self.last_dt / dt < STALL_STEP / STEP_SLACK:
            return None
        step, self.step, self.last_dt = self.step, [], dt
        return step

    def judge(self, dt: float, step: list[dict] | None, answering: bool) -> None:
        """Judge a step ended at ``dt`` [s] (None: no step ended there); ``answering``: one of its runs is now an
        answer or could still be one. Latches ``stalled_dt`` at the ``STALL_ROWS``-th step in a row no closer."""
        if step is None or self.stalled_dt is not None:
            return
        match = max(finite(r.get("n_match"), 0.0) for r in step)
        worst = min(finite(r.get("worst_ratio")) for r in step)
        started = self.match > 0 or math.isfinite(self.worst)
        closer = answering or match > self.match or worst < self.worst / STALL_GAIN
        self.match, self.worst = max(self.match, match), min(self.worst, worst)
        self.still = 0 if closer or not started else self.still + 1
        if self.still >= STALL_ROWS:
            self.stalled_dt = dt

    def past(self, dt: float) -> bool:
        """Whether a lattice ``dt`` [s] is finer than the row where the grid stalled: it is not run."""
        return self.stalled_dt is not None and dt < self.stalled_dt
