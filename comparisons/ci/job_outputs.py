"""A gate's decision for a CI job: a Markdown job summary, GitHub annotations, a benchmark JSON.

    >>> from chatterbench.comparisons.ci.job_outputs import annotations, benchmark_entries
    >>> from chatterbench.comparisons.ci.checks import run_gate
    >>> from chatterbench.comparisons.ci.decision import decide
    >>> from chatterbench.comparisons.ci.gate import parse_gate
    >>> gate = parse_gate({"check": [{"scene": "bouncing-ball", "engine": "pybullet", "dt": 1e-3,
    ...                               "limits": ["verdict == none"]}]})
    >>> decision = decide(run_gate(gate))
    >>> print(annotations(decision)[0][:60])        # a gate read from a file says where: file=GATE,line=N,
    ::error title=chatter gate bouncing-ball/pybullet::verdict =
    >>> entries = benchmark_entries(decision)
    >>> entries[0]["name"], entries[0]["unit"], entries[0]["extra"][:9]
    ('bouncing-ball/pybullet: stick_error_max', 's', 'gate FAIL')

Each renders ``decision.Decision`` and decides nothing:

- ``job_summary``: Markdown for ``$GITHUB_STEP_SUMMARY`` (GitHub shows it on the run's page):
  PASS or FAIL, a row per failure (measured, limit, baseline), the commands to run next,
  every item of every check, the engine versions. Every name and string from an input (the
  gate file's, a baseline's) passes ``pipeline.inert_text`` (``md_escape``, ``md_code``): none
  starts a line, a heading or a table row of its own, none is a tag.
- ``annotations``: one ``::error file=GATE,line=N,title=...::message`` workflow command per
  failed check (its failures; ``N``: the line of its worst failing limit in the gate file, or
  of its ``[[check]]`` header), and a ``::notice`` with the commands to run next, which GitHub
  Actions turns into annotations on the run and on the gate file's line (printed when
  ``GITHUB_ACTIONS=true``).
- ``benchmark_entries``: every measured number metric of every check in the
  ``customSmallerIsBetter`` format of github-action-benchmark (a JSON list of ``{"name",
  "unit", "value", "extra"}``): errors and cost, all smaller-is-better; NaN (not measured)
  left out; ``extra`` says whether the check passed, and for a regressed metric its baseline.
"""

from __future__ import annotations

import json
import math
import os
import stat
from typing import Any

from chatterbench.comparisons.pipeline.inert_text import md_code, md_escape
from chatterbench.comparisons.pipeline.summary import METRIC_COLUMNS

from .checks import fmt_value
from .decision import Decision

# the unit of each number metric written to the benchmark JSON
UNITS = {m: ("1" if m.endswith("_rel_max") or m == "restitution_error_max" else "m" if m == "penetration_max" else "s")
         for m in METRIC_COLUMNS}
UNITS["cost_per_sim_s"] = "s/s"


def _escape(text: str, property_: bool = False) -> str:
    """GitHub workflow-command escaping (``%``, line breaks; ``:`` and ``,`` in properties); and the runner's legacy
    ``##[`` (read anywhere in a line) broken as ``log_text`` breaks it."""
    text = text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
    text = text.replace(":", "%3A").replace(",", "%2C") if property_ else text
    while "##[" in text:
        text = text.replace("##[", "## [")
    return text


def annotations(decision: Decision) -> list[str]:
    """One ``::error`` workflow command per failed check (its failures), then one ``::notice`` with what to run next."""
    out, path = [], decision.result.gate.path
    for c in decision.checks:
        if not c.passed:
            where = f"file={_escape(path, property_=True)}," if c.result.check.line else ""
            where += f"line={c.line()}," if c.line() else ""
            title = _escape(f"chatter gate {c.name}", property_=True)
            out.append(f"::error {where}title={title}::{_escape(c.failure_line())}")
    steps = decision.next_steps()
    if steps:
        out.append(f"::notice title={_escape('chatter gate: what to run next', property_=True)}::{_escape(chr(10).join(steps))}")
    return out


def job_summary(decision: Decision) -> str:
    """The decision as Markdown: PASS/FAIL heading, a row per failure, what to run next, every item, the versions."""
    result = decision.result
    lines = [f"## chatterbench gate {md_code(result.gate.path)}: {'PASS' if decision.passed else 'FAIL'}", "",
             f"{decision.n_passed} of {len(decision.checks)} checks passed (their runs took {result.wall_s:.1f} s)"
             + (f"; {decision.n_regressed} metric(s) regressed against {md_code(decision.baseline)} (band "
                f"{decision.band:.0%})" if decision.baseline else "") + ".", ""]
    if not decision.passed:
        lines += ["### Failures", "", "| check | failure | measured | limit | baseline | note |", "|---|---|---:|---|---:|---|"]
        for c in decision.checks:
            for i in c.failures:
                base = "" if i.baseline is None else fmt_value(i.baseline)
                lines.append(f"| {md_escape(c.name)} | {i.kind} | {md_escape(fmt_value(i.measured))} | "
                             f"{md_code(i.limit).replace('|', chr(92) + '|')} | {base} | {md_escape(i.note)} |")
        steps = decision.next_steps()  # each on one line (decision.next_steps): none closes the fence
        lines += ["", "### What to run next", "", md_escape(steps[0]), "", "```sh", *steps[1:], "```", ""]
    lines += ["### Every check", "", "| check | limit | measured | result |", "|---|---|---:|---|"]
    for c in decision.checks:
        for i in c.items:
            lines.append(f"| {md_escape(c.name)} | {md_code(i.limit).replace('|', chr(92) + '|')} | "
                         f"{md_escape(fmt_value(i.measured))} | {'pass' if i.passed else '**FAIL**'} |")
    lines += ["", "Engines: " + md_escape(", ".join(f"{e} {v}" for e, v in sorted(result.versions.items())))]
    if decision.baseline:  # its versions are the baseline file's text: a cache's, maybe
        lines += ["", f"Baseline {md_code(decision.baseline)}: {md_escape(decision.versions)}."]
    return "\n".join(lines) + "\n"


def append_step_summary(path: str, summary: str) -> str:
    """Append ``summary`` to GitHub's job summary file ``path``; "" when done, else what went wrong (for one warning
    line: the file is GitHub's, the verdict must not depend on it).

    Only a regular file (or a new one) is written: a named pipe, opened without waiting for a
    reader, or a device is refused, so a gate never hangs on it; a full disk is said, not raised.
    """
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NONBLOCK | os.O_CLOEXEC, 0o666)
    except OSError as exc:  # a pipe with no reader (ENXIO), a directory, a missing folder, a NUL in the name
        return f"{path}: cannot be opened ({exc.strerror or exc})"
    except ValueError as exc:
        return f"{path!r}: cannot be opened ({exc})"
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return f"{path}: not a regular file (a pipe, a device or a socket); nothing written to it"
        data = summary.encode("utf-8")
        while data:
            data = data[os.write(fd, data):]
        return ""
    except OSError as exc:  # a full disk: part of the summary may be there, the verdict is in the log
        return f"{path}: cannot write ({exc.strerror or exc})"
    finally:
        os.close(fd)


def benchmark_entries(decision: Decision) -> list[dict[str, Any]]:
    """Every measured number metric as a ``customSmallerIsBetter`` entry (module docstring)."""
    entries = []
    for c in decision.checks:
        row = c.result.row
        regressed = {i.metric: i for i in c.failures if i.kind == "regressed"}
        for metric, unit in UNITS.items():
            value = row.get(metric)
            if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
                extra = (f"gate {'pass' if c.passed else 'FAIL'}; verdict {row.get('verdict')}; {c.result.check.engine} "
                         f"{row.get('engine_version', '')}; dt {fmt_value(row.get('dt'))} s")
                if metric in regressed:
                    extra += f"; regressed: {regressed[metric].message()}"
                entries.append({"name": f"{c.name}: {metric}", "unit": unit, "value": float(value), "extra": extra})
    return entries


def benchmark_json(decision: Decision) -> str:
    """``benchmark_entries`` as the JSON text the benchmark action reads."""
    return json.dumps(benchmark_entries(decision), indent=1) + "\n"
