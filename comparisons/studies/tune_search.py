"""The order in which ``tune`` tries candidates: one setting at a time, each combination down a dt ladder, then a bisection of dt.

    >>> calls = []
    >>> def run_batch(batch, stage):      # a stand-in judge: passes at dt <= 2e-4 whatever w
    ...     calls.extend(batch)
    ...     return [{**p, "verdict": "match" if p["dt"] <= 2e-4 else "late", "stage": stage} for p in batch]
    >>> rows = search(run_batch, {"dt": (1e-3, 3e-4, 1e-4), "e.w": (1, 2)}, refine_steps=2, band=0.1,
    ...               current=lambda rows: {"e.w": 1})
    >>> sorted({r["dt"] for r in rows if r["verdict"] == "match"}), len(calls)
    ([0.0001, 0.000173], 10)

Promises:

- stage by stage (the settings in the order the space lists them), a stage tries every value
  of its setting with the others fixed at the current choice (``current``: the recommendation
  so far, else the best reachable candidate; the defaults before anything ran);
- each stage walks the dt ladder from coarse to fine, all of its combinations at a level in
  one batch (they run in parallel), and stops at the first level where one passes, or at the
  level past the cheapest pass so far (a finer dt costs more steps, so it cannot be cheaper);
- then, ``refine_steps`` times, every combination whose cheapest pass is tied (within ``band``)
  with the cheapest one bisects dt geometrically towards its nearest failure above, while the
  two are more than ``MIN_RATIO`` apart: the front is found to within a factor of
  (ladder step)^(1 / 2^refine_steps);
- no candidate runs twice, and every candidate run is returned (refused ones included).
"""

from __future__ import annotations

import math
from typing import Any, Callable

from ..pipeline.vocabulary import VERDICTS

MIN_RATIO = 1.3  # [-] stop bisecting dt when the pass and the failure above it are this close
SIG_DIGITS = 3  # a bisected dt is rounded to this many significant digits (it is printed and pasted)


def agrees(verdict: str) -> bool:
    """Whether a verdict passes: the engine does what the reference does (``match``, or ``none`` for both)."""
    return verdict in VERDICTS and VERDICTS[verdict].group == "agree"


def _key(params: dict[str, Any]) -> tuple:
    return tuple(sorted(params.items()))


def search(run_batch: Callable[[list[dict], str], list[dict]], space: dict[str, tuple], refine_steps: int, band: float,
           current: Callable[[list[dict]], dict[str, Any] | None]) -> list[dict]:
    """Every candidate row the search ran (module docstring); ``run_batch(params, stage)`` judges a batch.

    ``params`` holds ``dt`` and every setting of ``space``; a row is its params plus at least ``verdict``.
    """
    ladder = sorted(space["dt"], reverse=True)
    options = {k: tuple(v) for k, v in space.items() if k != "dt"}
    rows: list[dict] = []
    seen: dict[tuple, dict] = {}

    def evaluate(batch: list[dict], stage: str) -> None:
        new = list({_key(p): p for p in batch if _key(p) not in seen}.values())
        for params, row in zip(new, run_batch(new, stage) if new else []):
            seen[_key(params)] = row
            rows.append(row)

    def cheapest_pass() -> float | None:
        dts = [r["dt"] for r in rows if agrees(r["verdict"])]
        return max(dts) if dts else None

    fixed = {k: v[0] for k, v in options.items()}
    for name, values in (options.items() if options else [("dt", (None,))]):
        combos = [{**fixed, name: v} for v in values] if options else [{}]
        for dt in ladder:
            best = cheapest_pass()
            if best is not None and dt < best / (1.0 + band):
                break
            batch = [{"dt": dt, **c} for c in combos]
            evaluate(batch, name.split(".")[-1] if options else "ladder")
            if any(agrees(seen[_key(p)]["verdict"]) for p in batch):
                break
        choice = current(rows)
        if choice is not None:
            fixed = {k: choice[k] for k in options}
    for _ in range(refine_steps):
        best = cheapest_pass()
        if best is None:
            break
        batch = []
        for combo in {_key({k: r[k] for k in options}): {k: r[k] for k in options} for r in rows}.values():
            mine = [r for r in rows if all(r[k] == v for k, v in combo.items()) and r["verdict"] != "refused"]
            ok = [r["dt"] for r in mine if agrees(r["verdict"])]
            if not ok or max(ok) < best / (1.0 + band):
                continue
            lo = max(ok)
            above = [r["dt"] for r in mine if r["dt"] > lo]
            if not above or min(above) / lo < MIN_RATIO:
                continue
            mid = float(f"{math.sqrt(lo * min(above)):.{SIG_DIGITS}g}")
            batch.append({"dt": mid, **combo})
        if not batch:
            break
        evaluate(batch, "refine")
    return rows
