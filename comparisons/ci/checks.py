"""Running a gate: each check's comparison (shared between checks that ask for the same run), each limit's outcome.

    >>> from chatterbench.comparisons.ci.checks import run_gate
    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"defaults": {"dt": 1e-3}, "check": [
    ...     {"scene": "bouncing-ball", "engine": "pybullet", "settings": {"restitution_velocity_threshold": 0.02},
    ...      "limits": ["verdict == match", "stick_error_rel_max <= 0.05"]}]})     # 0.02 m/s: the ball rests
    >>> result = run_gate(gate)
    >>> [(str(o.limit), o.passed) for o in result.results[0].outcomes]      # each limit's outcome
    [('verdict == match', True), ('stick_error_rel_max <= 0.05', True)]

A failure never passes by omission (``CheckResult.outcomes_for``): a run whose verdict is a
failure class fails its check unless a limit names that class. Whether the gate passes is
decided once, in ``decision.py`` (limits, the baseline, failed runs), for every writer.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from chatterbench.comparisons.pipeline.budget import Budget, check_comparison
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.summary import signed_worst, summarize
from chatterbench.comparisons.pipeline.vocabulary import FAILURES
from chatterbench.engines.registry import make_settings

from .gate import TEXT_METRICS, Check, Gate, Limit


@dataclass(frozen=True)
class LimitOutcome:
    limit: Limit
    measured: Any  # the metric's value in the run's summary row
    passed: bool


@dataclass(frozen=True)
class CheckResult:
    """A check's run: its summary row (``rows.summarize``), each limit's outcome, and the run's cost."""

    check: Check
    row: Mapping[str, Any]
    outcomes: tuple[LimitOutcome, ...]
    wall_s: float  # [s] of the comparison (0 when the run was shared with an earlier check)

    @property
    def passed(self) -> bool:
        """Every limit holds (the gate's decision adds the baseline: ``decision.decide_check``)."""
        return all(o.passed for o in self.outcomes)

    @staticmethod
    def outcomes_for(check: "Check", row: Mapping[str, Any]) -> tuple["LimitOutcome", ...]:
        """Each limit's outcome on ``row``; a failed run whose class no text limit names adds a failing
        ``verdict`` outcome (a failure never passes by omission)."""
        outcomes = [LimitOutcome(lim, row.get(lim.metric), lim.holds(row.get(lim.metric))) for lim in check.limits]
        verdict = str(row.get("verdict"))
        if verdict in FAILURES and not any(lim.metric in TEXT_METRICS and lim.names(verdict) for lim in check.limits):
            implicit = Limit("verdict", "!=", verdict)
            outcomes.append(LimitOutcome(implicit, verdict, False))
        return tuple(outcomes)


@dataclass(frozen=True)
class GateResult:
    """Every check's result, in the file's order."""

    gate: Gate
    results: tuple[CheckResult, ...]
    wall_s: float  # [s]
    versions: Mapping[str, str] = field(default_factory=dict)  # engine -> version


def fmt_value(v: Any) -> str:
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "NaN (not measured)" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def check_settings(check: Check) -> Any:
    """The check's engine settings object: the one ``make_check`` made (a Check built by hand: made here)."""
    if check.engine_settings is not None:
        return check.engine_settings
    return make_settings(check.engine, check.dt, {f"{check.engine}.{k}": v for k, v in check.settings.items()})


def run_check(check: Check, cache: dict[str, tuple[dict, str]] | None = None,
              timeout: float | None = None) -> CheckResult:
    """Run the check's comparison (or reuse an equal one from ``cache``) and test every limit.

    ``timeout`` [s]: the engine runs isolated in a child with this limit (``compare``).
    """
    key = check.run_key()
    start = time.perf_counter()
    if cache is not None and key in cache:
        row, _ = cache[key]
    else:
        c = compare(check.scene, engines=(check.engine,), settings={check.engine: check_settings(check)},
                    tol=check.tolerances, timeout=timeout)
        # the summary row, with the report's signed worst errors (``summary.SIGNED_COLUMNS``) a limit may name too
        row = {**summarize(c, check.engine, {}), **signed_worst(c.table[c.table["engine"] == check.engine])}
        if cache is not None:
            cache[key] = (row, row["engine_version"])
    return CheckResult(check=check, row=row, outcomes=CheckResult.outcomes_for(check, row), wall_s=time.perf_counter() - start)


def run_gate(gate: Gate, on_check: Callable[[int, CheckResult], None] | None = None, timeout: float | None = None,
             budget: Budget | None = None, starting: Callable[[int, Check], None] | None = None) -> GateResult:
    """Run every check of a validated gate, in order; checks needing the same run share it.

    ``on_check(i, result)`` is called as each check's run ends (``i`` from 1): the CLI decides
    the check there (``decision.decide_check``) and prints its progress line; ``starting(i, check)`` as
    each check's run starts (the CLI's progress says which check runs).
    ``timeout`` [s]: each engine run is isolated in a child with this limit (``run_check``).
    ``budget``: every check's runs are estimated against it before the first one starts.
    """
    if budget is not None:
        for check in gate.checks:
            check_comparison(check.scene, {check.engine: check_settings(check)}, budget)
    cache: dict[str, tuple[dict, str]] = {}
    results = []
    start = time.perf_counter()
    for i, check in enumerate(gate.checks, 1):
        if starting:
            starting(i, check)
        result = run_check(check, cache, timeout)
        results.append(result)
        if on_check:
            on_check(i, result)
    versions = {r.check.engine: str(r.row.get("engine_version", "")) for r in results}
    return GateResult(gate=gate, results=tuple(results), wall_s=time.perf_counter() - start, versions=versions)
