"""Running a gate: each check's comparison (shared between checks that ask for the same run), each limit's outcome.

    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"defaults": {"dt": 1e-3}, "check": [
    ...     {"scene": "bouncing-ball", "engine": "pybullet", "limits": ["verdict == match", "stick_error_rel_max <= 0.05"]}]})
    >>> result = run_gate(gate)
    >>> result.passed, result.table()["result"].tolist()        # one row per (check, limit)
    (True, ['pass', 'pass'])

A failure never passes by omission (``CheckResult.outcomes_for``): a run whose verdict is a
failure class fails its check unless a limit names that class.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import pandas as pd

from chatterbench.comparisons.pipeline.budget import Budget, check_comparison
from chatterbench.comparisons.pipeline.compare import compare
from chatterbench.comparisons.pipeline.summary import summarize
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

    def failure_message(self) -> str:
        """Readable account: measured against the limit, per limit, with the run's context."""
        c = self.check
        head = (f"chatter gate {c.name!r} {'passed' if self.passed else 'failed'}: {c.scene.name} on {c.engine}, "
                f"dt = {fmt_value(self.row.get('dt'))} s"
                + (f", settings {dict(c.settings)}" if c.settings else "")
                + (f", scene {dict(c.scene_overrides)}" if c.scene_overrides else ""))
        width = max(len(str(o.limit)) for o in self.outcomes)
        lines = [head]
        for o in self.outcomes:
            lines.append(f"  {str(o.limit):<{width}}  measured {fmt_value(o.measured):>12}  {'ok' if o.passed else 'FAIL'}")
        lines.append(f"  episodes {self.row.get('n_episodes')}, matched {self.row.get('n_match')}, "
                     f"engine run {self.row.get('status')}"
                     + (f": {str(self.row.get('message')).splitlines()[0]}" if self.row.get("message") else ""))
        return "\n".join(lines)


@dataclass(frozen=True)
class GateResult:
    """Every check's result, in the file's order."""

    gate: Gate
    results: tuple[CheckResult, ...]
    wall_s: float  # [s]
    versions: Mapping[str, str] = field(default_factory=dict)  # engine -> version

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.results)

    def table(self) -> pd.DataFrame:
        """One row per (check, limit): check, limit, measured, result (``pass`` / ``FAIL``)."""
        rows = [{"check": r.check.name, "limit": str(o.limit), "measured": fmt_value(o.measured),
                 "result": "pass" if o.passed else "FAIL"} for r in self.results for o in r.outcomes]
        return pd.DataFrame(rows, columns=["check", "limit", "measured", "result"])


def fmt_value(v: Any) -> str:
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "NaN (not measured)" if math.isnan(v) else f"{v:.4g}"
    return str(v)



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
        c = compare(check.scene, engines=(check.engine,), dt=check.dt,
                    overrides={f"{check.engine}.{k}": v for k, v in check.settings.items()}, tol=check.tolerances,
                    timeout=timeout)
        row = summarize(c, check.engine, {})
        if cache is not None:
            cache[key] = (row, row["engine_version"])
    return CheckResult(check=check, row=row, outcomes=CheckResult.outcomes_for(check, row), wall_s=time.perf_counter() - start)


def run_gate(gate: Gate, progress: Callable[[str], None] | None = None, timeout: float | None = None,
             budget: Budget | None = None) -> GateResult:
    """Run every check of a validated gate, in order; checks needing the same run share it.

    ``timeout`` [s]: each engine run is isolated in a child with this limit (``run_check``).
    ``budget``: every check's runs are estimated against it before the first one starts.
    """
    if budget is not None:
        for check in gate.checks:
            settings = make_settings(check.engine, check.dt, {f"{check.engine}.{k}": v for k, v in check.settings.items()})
            check_comparison(check.scene, {check.engine: settings}, budget)
    cache: dict[str, tuple[dict, str]] = {}
    results = []
    start = time.perf_counter()
    for i, check in enumerate(gate.checks, 1):
        result = run_check(check, cache, timeout)
        results.append(result)
        if progress:
            progress(f"[{i}/{len(gate.checks)}] {check.name}: {'pass' if result.passed else 'FAIL'} ({result.wall_s:.1f} s)")
    versions = {r.check.engine: str(r.row.get("engine_version", "")) for r in results}
    return GateResult(gate=gate, results=tuple(results), wall_s=time.perf_counter() - start, versions=versions)
