"""Gate against a saved run: fail when an error metric grew beyond a band since the baseline.

    $ chatterbench gate gates/default.toml --save-baseline baseline.json     # on main
    $ chatterbench gate gates/default.toml --baseline baseline.json          # on a pull request

A baseline file is JSON: the gate's path, when it ran, the engine versions, and each check's
number metrics (``METRIC_COLUMNS``: the errors, all smaller-is-better) with the fingerprint of
the run it measured (``run_fingerprint``: scene, engine, settings, tolerances). A check whose
run differs from its baseline entry's (a baseline saved from another gate file, or before its
settings changed) is not compared: it is reported as missing from the baseline, with the
command that saves a new one. A metric regresses when
``now > base * (1 + band) + floor`` with ``floor`` = 1e-12 of the metric's own unit (so an
exact 0 may become rounding noise without failing). Wall-clock cost is recorded but not
compared: it follows the machine, not the code. A check missing from the baseline, or a
metric measured now but not then, is reported, never silently passed; the engine versions of
both runs are in every message.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from chatterbench.comparisons.pipeline.atomic import write_text
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS
from chatterbench.reference.errors import InputError, check_number, shown
from chatterbench.reference.tables import TooDeep, check_depth, printable, read_text

if TYPE_CHECKING:  # `gate --help` reads BAND without loading the runs
    from .checks import GateResult

BAND = 0.1  # relative growth allowed before a metric counts as a regression
FLOOR = 1e-12
FORMAT = "chatterbench-gate-baseline/1"


class BaselineError(InputError):
    """A baseline file that cannot be read or does not fit the gate (the message says which and why)."""


@dataclass(frozen=True)
class Regression:
    """One metric of one check that fails against the baseline: it grew beyond the band, or it was
    measured in one run only; ``metric`` is "" when the check is not in the baseline at all."""

    check: str
    metric: str  # one of METRIC_COLUMNS, or "" (the check is not in the baseline)
    base: float  # the baseline's value [the metric's unit]; NaN: not measured then
    now: float  # this run's value; NaN: not measured now
    allowed: float  # the ceiling base * (1 + band) + FLOOR; NaN when there is nothing to compare
    band: float
    other_run: bool = False  # the baseline's entry of this name measured another run (``run_fingerprint``)

    @property
    def why(self) -> str:
        """``missing`` (check not in the baseline), ``other run`` (its entry measured another run), ``one run``
        (measured in one run only) or ``grew``."""
        if self.other_run:
            return "other run"
        if not self.metric:
            return "missing"
        return "one run" if math.isnan(self.base) or math.isnan(self.now) else "grew"


def _number(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


def run_fingerprint(check) -> str:
    """16 hex digits naming the run a check measures (scene, engine, dt, settings, tolerances: ``Check.run_key``)."""
    return hashlib.sha256(check.run_key().encode("utf-8")).hexdigest()[:16]


def baseline_data(result: GateResult) -> dict[str, Any]:
    """What ``--save-baseline`` writes: versions and each check's metrics (NaN as null) and run fingerprint."""
    checks = {}
    for r in result.results:
        values = {m: _number(r.row.get(m)) for m in (*METRIC_COLUMNS, "cost_per_sim_s")}
        checks[r.check.name] = {m: (None if math.isnan(v) else v) for m, v in values.items()}
        checks[r.check.name]["verdict"] = str(r.row.get("verdict"))
        checks[r.check.name]["run"] = run_fingerprint(r.check)
    return {"format": FORMAT, "gate": result.gate.path, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "versions": dict(result.versions), "checks": checks}


def save_baseline(result: GateResult, path: str | Path) -> Path:
    """Write the baseline of ``result`` to ``path`` (atomically)."""
    return write_text(Path(path), json.dumps(baseline_data(result), indent=1) + "\n")


def load_baseline(path: str | Path) -> dict[str, Any]:
    """Read a baseline file, validated whole (before any run); ``BaselineError`` naming the file and the field.

    A regular file of at most ``tables.MAX_FILE_BYTES``, nested at most ``tables.MAX_DEPTH``
    deep; ``versions`` a table of strings, ``checks`` a table of tables whose metrics are
    numbers or null and whose ``verdict`` is a string.
    """
    where = f"--baseline {path}"
    text = read_text(path, where, BaselineError, kind="JSON")
    try:
        data = check_depth(json.loads(text))
    except (RecursionError, TooDeep):
        raise BaselineError(f"{where}: {TooDeep()}") from None
    except ValueError as exc:
        raise BaselineError(f"{where}: not JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or not isinstance(data.get("checks"), dict):
        raise BaselineError(f"{where}: not a chatterbench gate baseline (write one with --save-baseline)")
    _check_fields(where, data)
    return data


def _check_fields(where: str, data: Mapping[str, Any]) -> None:
    """The fields the comparison and its messages read, each of its type."""
    versions = data.get("versions", {})
    if not isinstance(versions, dict) or not all(isinstance(v, str) for v in versions.values()):
        raise BaselineError(f"{where}: versions = {shown(versions)}: must be a table of engine = \"version\"")
    if not isinstance(data.get("gate", ""), str):
        raise BaselineError(f"{where}: gate = {shown(data['gate'])}: must be the gate file's path, a string")
    for name, check in data["checks"].items():
        if not isinstance(check, dict):
            raise BaselineError(f"{where}: checks.{printable(name)} = {shown(check)}: must be a table of metric = value")
        for key, value in check.items():
            text = key in ("verdict", "run")
            ok = isinstance(value, str) if text else (value is None or (isinstance(value, (int, float))
                                                                        and not isinstance(value, bool)))
            if not ok:
                want = "a string" if text else "a number or null"
                raise BaselineError(f"{where}: checks.{printable(name)}.{printable(key)} = {shown(value)}: must be {want}")
            if isinstance(value, int) and not isinstance(value, bool) and not _fits_a_float(value):
                raise BaselineError(f"{where}: checks.{printable(name)}.{printable(key)} = {shown(value)}: too large "
                                    f"for a metric, which is at most {sys.float_info.max:.3g}")


def _fits_a_float(value: int) -> bool:
    try:
        float(value)
    except OverflowError:  # a 401-digit integer: JSON reads it, no float holds it
        return False
    return True


def check_regressions(name: str, row: Mapping[str, Any], base: Mapping[str, Any], band: float = BAND,
                      run: str | None = None) -> list[Regression]:
    """Every error metric of one check's summary ``row`` beyond ``base`` by more than ``band``
    (module docstring); one ``missing`` Regression when the check is not in the baseline, one ``other run``
    when its entry's fingerprint is not ``run`` (``run_fingerprint`` of the check now)."""
    band = check_number("--band", band, lo=0.0, error=BaselineError)
    then = base["checks"].get(name)
    if then is None:
        return [Regression(name, "", math.nan, math.nan, math.nan, band)]
    if run is not None and then.get("run") is not None and then["run"] != run:
        return [Regression(name, "", math.nan, math.nan, math.nan, band, other_run=True)]
    out = []
    for metric in METRIC_COLUMNS:
        now, was = _number(row.get(metric)), _number(then.get(metric))
        if math.isnan(now) and math.isnan(was):
            continue
        allowed = was * (1.0 + band) + FLOOR
        if math.isnan(was) or math.isnan(now) or now > allowed:
            out.append(Regression(name, metric, was, now, allowed, band))
    return out


def versions_note(now: Mapping[str, str], base: Mapping[str, Any]) -> str:
    """Both runs' engine versions, for every message about the baseline."""
    def listed(versions: Mapping[str, Any]) -> str:
        return ", ".join(f"{e} {v}" for e, v in sorted(versions.items())) or "none recorded"
    return f"engines now {listed(now)}; baseline {listed(base.get('versions') or {})}"
