"""Gate against a saved run: fail when an error metric grew beyond a band since the baseline.

    $ chatterbench gate gates/default.toml --save-baseline baseline.json     # on main
    $ chatterbench gate gates/default.toml --baseline baseline.json          # on a pull request

A baseline file is JSON: the gate's path, when it ran, the engine versions, and each check's
number metrics (``METRIC_COLUMNS``: the errors, all smaller-is-better). A metric regresses when
``now > base * (1 + band) + floor`` with ``floor`` = 1e-12 of the metric's own unit (so an
exact 0 may become rounding noise without failing). Wall-clock cost is recorded but not
compared: it follows the machine, not the code. A check missing from the baseline, or a
metric measured now but not then, is reported, never silently passed; the engine versions of
both runs are in every message.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from chatterbench.comparisons.outputs.atomic import write_text
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS
from chatterbench.reference.errors import InputError, check_number

from .checks import GateResult, fmt_value

BAND = 0.1  # relative growth allowed before a metric counts as a regression
FLOOR = 1e-12
FORMAT = "chatterbench-gate-baseline/1"


class BaselineError(InputError):
    """A baseline file that cannot be read or does not fit the gate (the message says which and why)."""


@dataclass(frozen=True)
class Regression:
    """One metric of one check that grew beyond the band (or cannot be compared)."""

    check: str
    metric: str
    base: float
    now: float
    message: str


def _number(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


def baseline_data(result: GateResult) -> dict[str, Any]:
    """What ``--save-baseline`` writes: versions and each check's metrics (NaN as null)."""
    checks = {}
    for r in result.results:
        values = {m: _number(r.row.get(m)) for m in (*METRIC_COLUMNS, "cost_per_sim_s")}
        checks[r.check.name] = {m: (None if math.isnan(v) else v) for m, v in values.items()}
        checks[r.check.name]["verdict"] = str(r.row.get("verdict"))
    return {"format": FORMAT, "gate": result.gate.path, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "versions": dict(result.versions), "checks": checks}


def save_baseline(result: GateResult, path: str | Path) -> Path:
    """Write the baseline of ``result`` to ``path`` (atomically)."""
    return write_text(Path(path), json.dumps(baseline_data(result), indent=1) + "\n")


def load_baseline(path: str | Path) -> dict[str, Any]:
    """Read a baseline file; ``BaselineError`` naming the file when it is not one."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise BaselineError(f"--baseline {path}: cannot be read ({exc.strerror or exc})") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise BaselineError(f"--baseline {path}: not JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or not isinstance(data.get("checks"), dict):
        raise BaselineError(f"--baseline {path}: not a chatterbench gate baseline (write one with --save-baseline)")
    return data


def regressions(result: GateResult, base: dict[str, Any], band: float = BAND) -> list[Regression]:
    """Every error metric of ``result`` beyond ``base`` by more than ``band`` (module docstring)."""
    band = check_number("--band", band, lo=0.0, error=BaselineError)
    versions = (f"engines now {', '.join(f'{e} {v}' for e, v in sorted(result.versions.items()))}; baseline "
                f"{', '.join(f'{e} {v}' for e, v in sorted(base.get('versions', {}).items()))}")
    out = []
    for r in result.results:
        then = base["checks"].get(r.check.name)
        if then is None:
            out.append(Regression(r.check.name, "", math.nan, math.nan,
                                  f"{r.check.name}: not in the baseline ({versions})"))
            continue
        for metric in METRIC_COLUMNS:
            now, was = _number(r.row.get(metric)), _number(then.get(metric))
            if math.isnan(now) and math.isnan(was):
                continue
            if math.isnan(was) != math.isnan(now):
                out.append(Regression(r.check.name, metric, was, now, f"{r.check.name}: {metric} = {fmt_value(now)}, "
                                      f"baseline {fmt_value(was)}: measured in one run only ({versions})"))
            elif now > was * (1.0 + band) + FLOOR:
                out.append(Regression(r.check.name, metric, was, now, f"{r.check.name}: {metric} = {fmt_value(now)}, "
                                      f"baseline {fmt_value(was)}: grew {now / was - 1 if was else math.inf:.0%} "
                                      f"(band {band:.0%}) ({versions})"))
    return out
