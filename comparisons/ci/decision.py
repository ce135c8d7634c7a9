"""The gate's one decision: which checks failed and why (limits, the baseline, failed runs), rendered by every writer.

    >>> from chatterbench.comparisons.ci.decision import decide
    >>> from chatterbench.comparisons.ci.checks import run_gate
    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"check": [{"scene": "bouncing-ball", "engine": "pybullet", "dt": 1e-3,
    ...                               "limits": ["cost_per_sim_s <= 1e-9"]}]})
    >>> decision = decide(run_gate(gate))           # no engine runs a simulated second in a nanosecond
    >>> decision.exit_code, decision.failures[0].message().split(" = ")[0], decision.failures[0].limit
    (1, 'cost_per_sim_s', 'cost_per_sim_s <= 1e-09')
    >>> decision.next_steps()[1]
    'chatterbench compare bouncing-ball --engines pybullet --dt 0.001 --out gate-failure/bouncing-ball-pybullet'

A check is judged by its items, each one line a user can check by hand:

- ``limit``: a limit of the gate file, measured on the run (``checks.LimitOutcome``);
- ``failed run``: the run's verdict is a failure class (crashed, timeout, error, diverged)
  that no limit names (a failure never passes by omission);
- ``regressed``: an error metric grew beyond the baseline's band, or was measured in one run
  only (``baseline.check_regressions``);
- ``missing``: the check is not in the baseline.

Promises: a check passes when every item passes and the gate when every check does; the exit
code, the progress lines, the terminal table, JUnit (``junit.py``), the job summary, the
``::error`` annotations and the benchmark JSON (``job_outputs.py``) all read this object and
decide nothing themselves. A failing decision names the worst check (a failed run before a
failed limit before a regression before a missing baseline entry; then how far past its
limit) and the commands to run next for it.
"""

from __future__ import annotations

import dataclasses
import math
import re
import shlex
from dataclasses import dataclass
from typing import Any, Mapping

import pandas as pd

from chatterbench.comparisons.pipeline.inert_text import log_text
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.reference.tables import toml_literal

from .baseline import BAND, Regression, check_regressions, run_fingerprint, versions_note
from .checks import CheckResult, GateResult, LimitOutcome, fmt_value
from .gate import Check

KINDS = ("failed run", "limit", "regressed", "missing")  # worst first
OUT_ROOT = "gate-failure"  # where the suggested commands write


@dataclass(frozen=True)
class Item:
    """One judged line of a check: a limit, a failed run, or a metric against the baseline."""

    kind: str  # one of KINDS
    metric: str  # the metric judged; "" for a check missing from the baseline
    limit: str  # what had to hold, as the user reads it: "stick_error_max <= 0.01"
    measured: Any  # the run's value
    passed: bool
    baseline: float | None = None  # the baseline's value (kind "regressed")
    note: str = ""  # "grew 900%", "measured in one run only"
    excess: float = 0.0  # how far past its limit (measured / allowed; inf: not a number): ranks failures
    line: int = 0  # where the gate file says it: the limit's line, else its check's [[check]] line (0: no file)

    def message(self) -> str:
        """One line: ``METRIC = MEASURED, limit LIMIT[; NOTE]``."""
        if self.kind == "missing":
            return f"not in the baseline{'' if self.measured == 'absent' else ' as this run'}; {self.note}"
        return f"{self.metric} = {fmt_value(self.measured)}, limit {self.limit}" + (f"; {self.note}" if self.note else "")


def _rank(i: Item) -> tuple[int, float]:
    return len(KINDS) - KINDS.index(i.kind), i.excess


def _limit_item(check: Check, o: LimitOutcome, k: int) -> Item:
    """Item of the ``k``-th outcome (of ``check.limits`` in order, then the implicit one)."""
    failed_run = o.limit not in check.limits  # the implicit limit of a failure class (CheckResult.outcomes_for)
    line = check.limit_lines[k] if k < len(check.limit_lines) and check.limit_lines[k] else check.line
    return Item("failed run" if failed_run else "limit", o.limit.metric, str(o.limit), o.measured, o.passed,
                note="the run failed and no limit names its verdict" if failed_run else "",
                excess=0.0 if o.passed else _excess(o.limit.op, o.measured, o.limit.value), line=line)


def _excess(op: str, measured: Any, value: Any) -> float:
    if not isinstance(measured, (int, float)) or isinstance(measured, bool) or not isinstance(value, float):
        return math.inf
    if math.isnan(measured):
        return math.inf
    measured, value = abs(measured), abs(value)  # a signed error's limit (>= -0.01) ranks by its size too
    num, den = (measured, value) if op in ("<=", "<") else (value, measured) if op in (">=", ">") else (1.0, 0.0)
    return num / den if den > 0 else math.inf


def _regression_item(g: Regression, versions: str) -> Item:
    if g.why == "missing":
        return Item("missing", "", "in the baseline", "absent", False, note=versions)
    if g.why == "other run":  # a baseline from another gate file, or from before the check changed: not comparable
        return Item("missing", "", "the same run in the baseline", "another run", False,
                    note=f"the baseline's {g.check!r} measured another scene, engine, dt, settings or tolerances; "
                         f"{versions}")
    if g.why == "one run":
        return Item("regressed", g.metric, f"{g.metric} measured in both runs", g.now, False,
                    baseline=None if math.isnan(g.base) else g.base, note="measured in one run only", excess=math.inf)
    grew = f"grew {g.now / g.base - 1:.0%}" if g.base > 0 else "grew from 0"
    return Item("regressed", g.metric, f"{g.metric} <= {g.allowed:.4g} (baseline {g.base:.4g} + {g.band:.0%})",
                g.now, False, baseline=g.base, note=grew, excess=g.now / g.allowed if g.allowed > 0 else math.inf)


@dataclass(frozen=True)
class CheckDecision:
    """One check's run and every item it was judged by."""

    result: CheckResult
    items: tuple[Item, ...]

    @property
    def name(self) -> str:
        return self.result.check.name

    @property
    def passed(self) -> bool:
        return all(i.passed for i in self.items)

    @property
    def failures(self) -> tuple[Item, ...]:
        return tuple(i for i in self.items if not i.passed)

    def line(self) -> int:
        """The gate file's line to point at: its worst failure's (its limit's, else the check's), else the check's."""
        worst = max(self.failures, key=_rank, default=None)
        return (worst.line if worst is not None and worst.line else 0) or self.result.check.line

    def failure_line(self) -> str:
        """Every failure's ``message`` on one line (JUnit's failure message, the ``::error`` annotation)."""
        return log_text("; ".join(i.message() for i in self.failures))

    def severity(self) -> tuple[int, float]:
        """(rank of the worst failure's kind, its excess); larger is worse, (-1, 0) for a pass."""
        return max(map(_rank, self.failures), default=(-1, 0.0))

    def reasons(self) -> str:
        """``2 limits failed, 5 metrics regressed``: the failures counted by kind."""
        n = {k: sum(i.kind == k for i in self.failures) for k in KINDS}
        parts = ["the run failed"] if n["failed run"] else []
        if n["limit"]:
            parts.append(f"{n['limit']} limit{'s' * (n['limit'] > 1)} failed")
        if n["regressed"]:
            parts.append(f"{n['regressed']} metric{'s' * (n['regressed'] > 1)} regressed")
        if n["missing"]:
            parts.append("not in the baseline")
        return ", ".join(parts)

    def progress_line(self, i: int, n: int) -> str:
        """``[i/n] NAME: pass (0.4 s)`` or ``[i/n] NAME: FAIL (reasons) (0.4 s)``."""
        verdict = "pass" if self.passed else f"FAIL ({self.reasons()})"
        return log_text(f"[{i}/{n}] {self.name}: {verdict} ({self.result.wall_s:.1f} s)")

    def account(self) -> str:
        """Readable account: every item, measured against its limit, the run's context, and (failing) what to run next."""
        c, row = self.result.check, self.result.row
        head = (f"chatter gate {c.name!r} {'passed' if self.passed else 'failed'}: {c.scene.name} on {c.engine}, "
                f"dt = {fmt_value(row.get('dt'))} s"
                + (f", settings {dict(c.settings)}" if c.settings else "")
                + (f", scene {dict(c.scene_overrides)}" if c.scene_overrides else ""))
        width = max(len(i.limit) for i in self.items)
        lines = [head]
        for i in self.items:
            lines.append(f"  {i.limit:<{width}}  measured {fmt_value(i.measured):>12}  {'ok' if i.passed else 'FAIL'}"
                         + (f" ({i.note})" if i.note and not i.passed else ""))
        lines.append(f"  episodes {row.get('n_episodes')}, matched {row.get('n_match')}, engine run {row.get('status')}"
                     + (f": {str(row.get('message')).splitlines()[0]}" if row.get("message") else ""))
        if not self.passed and any(i.kind != "missing" for i in self.failures):
            lines += ["  to see it: " + compare_command(c), "  to search for settings that pass: " + tune_command(c)]
        return "\n".join(map(log_text, lines))  # each line its own: no name, key or message starts another


def decide_check(result: CheckResult, base: Mapping[str, Any] | None = None, band: float = BAND) -> CheckDecision:
    """Judge one check's run: its limits, a failed run, and (with ``base``, a loaded baseline) its regressions."""
    items = [_limit_item(result.check, o, k) for k, o in enumerate(result.outcomes)]
    if base is not None:
        engine = result.check.engine
        note = versions_note({engine: str(result.row.get("engine_version", ""))},
                             {"versions": {k: v for k, v in (base.get("versions") or {}).items() if k == engine}})
        items += [dataclasses.replace(_regression_item(g, note), line=result.check.line)
                  for g in check_regressions(result.check.name, result.row, base, band, run_fingerprint(result.check))]
    return CheckDecision(result, tuple(items))


@dataclass(frozen=True)
class Decision:
    """The gate's decision: every check's, in the file's order, and the baseline they were judged against."""

    result: GateResult
    checks: tuple[CheckDecision, ...]
    baseline: str | None = None  # the baseline file's path; None: no baseline
    band: float = BAND
    versions: str = ""  # both runs' engine versions (with a baseline)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def exit_code(self) -> int:
        """0 every check passed, 1 one failed (the CLI's 2, bad input, comes before any decision)."""
        return 0 if self.passed else 1

    @property
    def failures(self) -> tuple[Item, ...]:
        return tuple(i for c in self.checks for i in c.failures)

    @property
    def n_passed(self) -> int:
        return sum(c.passed for c in self.checks)

    @property
    def n_regressed(self) -> int:
        return sum(i.kind == "regressed" for i in self.failures)

    def baseline_line(self) -> str:
        """``baseline PATH: engines now ...; baseline ...`` ("" without a baseline)."""
        return log_text(f"baseline {self.baseline}: {self.versions}") if self.baseline else ""

    def worst(self) -> CheckDecision | None:
        """The failing check to look at first (module docstring), None when the gate passes."""
        failing = [c for c in self.checks if not c.passed]
        return max(failing, key=CheckDecision.severity) if failing else None

    def headline(self) -> str:
        """``PASS: 2 of 2 checks passed[; 0 metric(s) regressed against B]``."""
        return log_text(f"{'PASS' if self.passed else 'FAIL'}: {self.n_passed} of {len(self.checks)} checks passed"
                        + (f"; {self.n_regressed} metric(s) regressed against {self.baseline}" if self.baseline else ""))

    def table(self) -> pd.DataFrame:
        """One row per item: check, limit, measured, result (``pass`` / ``FAIL``)."""
        rows = [{"check": c.name, "limit": i.limit, "measured": fmt_value(i.measured), "result": "pass" if i.passed else "FAIL"}
                for c in self.checks for i in c.items]
        return pd.DataFrame(rows, columns=["check", "limit", "measured", "result"])

    def next_steps(self) -> list[str]:
        """What to run next for the worst check: a sentence, then one command per line ([] when the gate passes)."""
        worst = self.worst()
        if worst is None:
            return []
        first = max(worst.failures, key=_rank)
        c = worst.result.check
        if first.kind == "missing":
            steps = [f"Next: {c.name!r} is not in the baseline {self.baseline}; on the main branch, record it:",
                     f"chatterbench gate {shlex.quote(self.result.gate.path)} --save-baseline {shlex.quote(self.baseline or 'baseline.json')}"]
        else:
            steps = [f"Next, the worst check {c.name!r} ({first.message()}): "
                     "see its episodes and figures, then search for settings that pass:",
                     compare_command(c), tune_command(c)]
        return [log_text(step) for step in steps]  # a file's name with a line break stays on its line


def decide(result: GateResult, base: Mapping[str, Any] | None = None, band: float = BAND,
           baseline_path: str | None = None, checks: tuple[CheckDecision, ...] | None = None) -> Decision:
    """The gate's decision; ``checks``: the checks already decided as they ran (``decide_check`` with the same
    ``base`` and ``band``), so the progress lines and the writers read the same objects."""
    if checks is None:
        checks = tuple(decide_check(r, base, band) for r in result.results)
    return Decision(result, tuple(checks), baseline_path if base is not None else None, band,
                    versions_note(result.versions, base) if base is not None else "")


def _scene_args(c: Check) -> list[str]:
    args = [c.scene_source or c.scene.name]
    for key, value in c.scene_overrides.items():
        args += ["--set", f"{key}={toml_literal(value)}"]
    default = Tolerances().as_dict()
    for key, value in c.tolerances.as_dict().items():
        if value != default.get(key):
            args += ["--tolerance", f"{key}={toml_literal(value)}"]
    return args


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-.") or "check"


def compare_command(c: Check) -> str:
    """The ``chatterbench compare`` that reruns check ``c`` with its figures under ``gate-failure/NAME``."""
    args = ["chatterbench", "compare", *_scene_args(c), "--engines", c.engine]
    if c.dt is not None:
        args += ["--dt", repr(c.dt)]
    for key, value in c.settings.items():
        args += ["--set", f"{c.engine}.{key}={toml_literal(value)}"]
    return shlex.join(args + ["--out", f"{OUT_ROOT}/{_slug(c.name)}"])


def tune_command(c: Check) -> str:
    """The ``chatterbench tune`` that searches settings of ``c``'s engine that pass on its scene."""
    return shlex.join(["chatterbench", "tune", *_scene_args(c), "--engines", c.engine,
                       "--out", f"{OUT_ROOT}/{_slug(c.name)}-tune"])

