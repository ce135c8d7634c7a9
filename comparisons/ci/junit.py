"""A gate's result as JUnit XML, the report every CI system reads: one testcase per check.

    >>> from chatterbench.comparisons.ci.checks import run_gate
    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"check": [{"scene": "bouncing-ball", "engine": "pybullet", "dt": 1e-3,
    ...                               "limits": ["verdict == none"]}]})
    >>> xml = junit_xml(run_gate(gate))                # the ball slides: "none" fails, with the numbers
    >>> 'tests="1" failures="1"' in xml, "verdict = match, limit verdict == none" in xml
    (True, True)

A failing check carries a ``<failure>`` with the measured values against their limits; every
testcase carries the check's summary row (JSON) in ``<system-out>``.
"""

from __future__ import annotations

import json
import math
import socket
from datetime import datetime, timezone
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

from chatterbench.comparisons.outputs.atomic import write_text
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS

from .checks import GateResult, fmt_value


def junit_xml(result: GateResult) -> str:
    """The result as JUnit XML: one testcase per check; a failing one carries a <failure> with the numbers."""
    failures = sum(not r.passed for r in result.results)
    stem = Path(result.gate.path).stem
    suites = ET.Element("testsuites", name="chatterbench gate", tests=str(len(result.results)),
                        failures=str(failures), errors="0", time=f"{result.wall_s:.3f}")
    suite = ET.SubElement(suites, "testsuite", name=result.gate.path, tests=str(len(result.results)),
                          failures=str(failures), errors="0", skipped="0", time=f"{result.wall_s:.3f}",
                          timestamp=datetime.now(timezone.utc).isoformat(timespec="seconds"), hostname=socket.gethostname())
    props = ET.SubElement(suite, "properties")
    for engine, version in sorted(result.versions.items()):
        ET.SubElement(props, "property", name=f"{engine}.version", value=version)
    for r in result.results:
        case = ET.SubElement(suite, "testcase", classname=f"chatterbench.gate.{stem}", name=r.check.name, time=f"{r.wall_s:.3f}")
        if not r.passed:
            bad = [o for o in r.outcomes if not o.passed]
            message = "; ".join(f"{o.limit.metric} = {fmt_value(o.measured)}, limit {o.limit}" for o in bad)
            failure = ET.SubElement(case, "failure", message=message, type="GateFailure")
            failure.text = r.failure_message()
        out = ET.SubElement(case, "system-out")
        out.text = json.dumps({k: _json_value(r.row[k]) for k in ("scene", "engine", "dt", "status", "verdict", "n_episodes",
                                                                 "n_match", *METRIC_COLUMNS, "cost_per_sim_s", "engine_version")},
                              default=str)
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def _json_value(v: Any) -> Any:
    return None if isinstance(v, float) and math.isnan(v) else v


def write_junit(result: GateResult, path: str | Path) -> Path:
    """Write ``junit_xml(result)`` to ``path`` atomically."""
    return write_text(Path(path), junit_xml(result))
