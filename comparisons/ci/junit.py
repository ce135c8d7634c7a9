"""A gate's decision as JUnit XML, the report every CI system reads: a testcase per check and per regressed metric.

    >>> from chatterbench.comparisons.ci.junit import junit_xml
    >>> from chatterbench.comparisons.ci.checks import run_gate
    >>> from chatterbench.comparisons.ci.decision import decide
    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"check": [{"scene": "bouncing-ball", "engine": "pybullet", "dt": 1e-3,
    ...                               "settings": {"restitution_velocity_threshold": 0.02},
    ...                               "limits": ["verdict == none"]}]})
    >>> xml = junit_xml(decide(run_gate(gate)))       # the ball slides: "none" fails, with the numbers
    >>> 'tests="1" failures="1"' in xml, "verdict = match, limit verdict == none" in xml
    (True, True)

Renders ``decision.Decision`` and decides nothing: a check's testcase fails when the decision
fails the check (its limits, a failed run, its regressions, a missing baseline entry), with a
``<failure>`` whose message lists each failure's measured value against its limit and whose
text is the check's account and the commands to run next; each regressed metric has its own
testcase (``CHECK: METRIC against the baseline``) whose ``<failure>`` carries the measured
value, the limit and the baseline's value. Every check's testcase carries its summary row
(JSON) in ``<system-out>``; ``failures`` counts the failing testcases.
"""

from __future__ import annotations

import json
import math
import socket
from datetime import datetime, timezone
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

from chatterbench.comparisons.pipeline.atomic import write_text
from chatterbench.comparisons.pipeline.inert_text import log_text
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS

from .decision import Decision


def _cases(decision: Decision) -> list[tuple[str, float, tuple[str, str, str] | None, str | None]]:
    """(name, time [s], failure (message, type, text) or None, system-out or None) per testcase."""
    out = []
    for c in decision.checks:
        failure = None
        if not c.passed:
            text = c.account() + (f"\n{decision.baseline_line()}" if decision.baseline else "")
            failure = (c.failure_line(), "GateFailure", text)
        row = c.result.row
        system_out = json.dumps({k: _json_value(row.get(k)) for k in ("scene", "engine", "dt", "status", "verdict",
                                 "n_episodes", "n_match", *METRIC_COLUMNS, "cost_per_sim_s", "engine_version")}, default=str)
        name = log_text(c.name)  # a JUnit reader prints it to its log: one line, inert
        out.append((name, c.result.wall_s, failure, system_out))
        for i in c.failures:
            if i.kind == "regressed":
                text = f"{name}: {log_text(i.message())}\n{decision.baseline_line()}"
                out.append((f"{name}: {i.metric} against the baseline", 0.0, (log_text(i.message()), "GateRegression",
                                                                              text), None))
    return out


def junit_xml(decision: Decision) -> str:
    """The decision as JUnit XML (module docstring)."""
    result, cases = decision.result, _cases(decision)
    failures = str(sum(f is not None for _, _, f, _ in cases))
    stem = log_text(Path(result.gate.path).stem)
    suites = ET.Element("testsuites", name="chatterbench gate", tests=str(len(cases)),
                        failures=failures, errors="0", time=f"{result.wall_s:.3f}")
    suite = ET.SubElement(suites, "testsuite", name=log_text(result.gate.path), tests=str(len(cases)),
                          failures=failures, errors="0", skipped="0", time=f"{result.wall_s:.3f}",
                          timestamp=datetime.now(timezone.utc).isoformat(timespec="seconds"), hostname=socket.gethostname())
    props = ET.SubElement(suite, "properties")
    for engine, version in sorted(result.versions.items()):
        ET.SubElement(props, "property", name=log_text(f"{engine}.version"), value=log_text(version))
    if decision.baseline:
        ET.SubElement(props, "property", name="baseline", value=log_text(decision.baseline))
        ET.SubElement(props, "property", name="band", value=f"{decision.band:g}")
    for name, wall, failure, system_out in cases:
        case = ET.SubElement(suite, "testcase", classname=f"chatterbench.gate.{stem}", name=name, time=f"{wall:.3f}")
        if failure is not None:
            message, kind, text = failure
            ET.SubElement(case, "failure", message=message, type=kind).text = text
        if system_out is not None:
            ET.SubElement(case, "system-out").text = system_out
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def _json_value(v: Any) -> Any:
    return None if isinstance(v, float) and math.isnan(v) else v


def write_junit(decision: Decision, path: str | Path) -> Path:
    """Write ``junit_xml(decision)`` to ``path`` atomically."""
    return write_text(Path(path), junit_xml(decision))
