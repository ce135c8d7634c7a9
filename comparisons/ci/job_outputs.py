"""A gate's result for a CI job: a Markdown job summary, GitHub annotations, a benchmark JSON.

    >>> from chatterbench.comparisons.ci.checks import run_gate
    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"check": [{"scene": "bouncing-ball", "engine": "pybullet", "dt": 1e-3,
    ...                               "limits": ["verdict == none"]}]})
    >>> result = run_gate(gate)
    >>> print(annotations(result)[0][:60])
    ::error title=chatter gate bouncing-ball/pybullet::verdict =
    >>> entries = benchmark_entries(result)
    >>> entries[0]["name"], entries[0]["unit"]
    ('bouncing-ball/pybullet: stick_error_max', 's')

- ``job_summary``: Markdown for ``$GITHUB_STEP_SUMMARY`` (GitHub shows it on the run's page):
  pass/fail, each check's limits with the measured values, the engine versions.
- ``annotations``: one ``::error title=...::message`` workflow command per failed check, which
  GitHub Actions turns into an annotation on the run (printed when ``GITHUB_ACTIONS=true``).
- ``benchmark_entries``: every measured number metric of every check in the
  ``customSmallerIsBetter`` format of github-action-benchmark (a JSON list of ``{"name",
  "unit", "value", "extra"}``): errors and cost, all smaller-is-better; NaN (not measured)
  left out.
"""

from __future__ import annotations

import json
import math
from typing import Any

from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS

from .checks import GateResult, fmt_value

# the unit of each number metric written to the benchmark JSON
UNITS = {m: ("1" if m.endswith("_rel_max") or m == "restitution_error_max" else "m" if m == "penetration_max" else "s")
         for m in METRIC_COLUMNS}
UNITS["cost_per_sim_s"] = "s/s"


def _escape(text: str, property_: bool = False) -> str:
    """GitHub workflow-command escaping (``%``, line breaks; ``:`` and ``,`` in properties)."""
    text = text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
    return text.replace(":", "%3A").replace(",", "%2C") if property_ else text


def annotations(result: GateResult) -> list[str]:
    """One ``::error`` workflow command per failed check: the failing limits with their measured values."""
    out = []
    for r in result.results:
        if r.passed:
            continue
        bad = "; ".join(f"{o.limit.metric} = {fmt_value(o.measured)}, limit {o.limit}" for o in r.outcomes if not o.passed)
        title = _escape(f"chatter gate {r.check.name}", property_=True)
        out.append(f"::error title={title}::{_escape(bad)}")
    return out


def job_summary(result: GateResult, extra: str = "") -> str:
    """The gate as Markdown: verdict line, one table row per limit, engine versions; ``extra`` appended."""
    n_ok = sum(r.passed for r in result.results)
    lines = [f"## chatterbench gate `{result.gate.path}`: {'PASS' if result.passed else 'FAIL'}", "",
             f"{n_ok} of {len(result.results)} checks passed in {result.wall_s:.1f} s.", "",
             "| check | limit | measured | result |", "|---|---|---:|---|"]
    for r in result.results:
        for o in r.outcomes:
            lines.append(f"| {r.check.name} | `{o.limit}` | {fmt_value(o.measured)} | "
                         f"{'pass' if o.passed else '**FAIL**'} |")
    lines += ["", "Engines: " + ", ".join(f"{e} {v}" for e, v in sorted(result.versions.items()))]
    if extra:
        lines += ["", extra]
    return "\n".join(lines) + "\n"


def benchmark_entries(result: GateResult) -> list[dict[str, Any]]:
    """Every measured number metric as a ``customSmallerIsBetter`` entry (module docstring)."""
    entries = []
    for r in result.results:
        for metric, unit in UNITS.items():
            value = r.row.get(metric)
            if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
                entries.append({"name": f"{r.check.name}: {metric}", "unit": unit, "value": float(value),
                                "extra": f"verdict {r.row.get('verdict')}; {r.check.engine} "
                                         f"{r.row.get('engine_version', '')}; dt {fmt_value(r.row.get('dt'))} s"})
    return entries


def benchmark_json(result: GateResult) -> str:
    """``benchmark_entries`` as the JSON text the benchmark action reads."""
    return json.dumps(benchmark_entries(result), indent=1) + "\n"
