"""The gate file's format, from ``comparisons/ci/gate.py``: its key tables, operators, metrics and documented example.

    >>> from gen_gate import gate_markdown
    >>> text = gate_markdown()
    >>> "<code>limits</code>" in text and "<code>stick&#95;error&#95;rel&#95;max</code>" in text  # _ as a reference
    True

The keys come from ``TOP_FIELDS`` and ``CHECK_FIELDS`` (what the reader checks), which of them are
required and which ``[defaults]`` may set from ``REQUIRED_KEYS`` and ``DEFAULT_KEYS``, the operators
from ``TEXT_OPS`` and ``NUMBER_OPS``, the names a text metric takes from ``TEXT_METRICS``, and the
example and the metrics' table from the module's docstring, which the gate's own doctest reads. A
metric of ``METRICS`` that the docstring's table does not name stops the build (``DocsError``).
"""

from __future__ import annotations

import re

from gen_markup import cell, code, fence, table

from chatterbench.comparisons.ci import gate


class DocsError(Exception):
    """The code and its reference page disagree (the build stops, naming what to fix)."""


def prose(text: str) -> str:
    """A docstring's reStructuredText line: ````name```` as code, the rest made safe."""
    parts = re.split(r"``(.+?)``", " ".join(text.split()))
    return "".join(code(p) if i % 2 else cell(p) for i, p in enumerate(parts))


def _docstring_block(title: str) -> str:
    """The literal block after the docstring line ``title::``, dedented."""
    lines = gate.__doc__.split(f"{title}::\n", 1)[1].splitlines()
    block = []
    for line in lines[1:]:
        if line and not line.startswith("    "):
            break
        block.append(line[4:])
    return "\n".join(block).strip("\n")


def _names(text: str) -> str:
    """A table's first column, ``exit_error_max [s]`` or ``verdict, status``: each name as code, the unit after."""
    names, unit = re.match(r"(.*?)((?: \[[^\]]*\])?)$", text).groups()
    return ", ".join(code(n) for n in names.split(", ") if n) + cell(unit)


def _metric_rows() -> list[list[str]]:
    """The docstring's metrics table (a reStructuredText simple table) as rows: metric, kind, operators or note."""
    doc = gate.__doc__
    body = doc.split("metric                      kind", 1)[1].split("\n==", 2)[1].split("\n", 1)[1]
    body = body.split("\n==", 1)[0]
    rows = []
    for line in body.splitlines():
        name, kind, note = line[:28].strip(), line[28:36].strip(), line[36:].strip()
        rows.append([_names(name), cell(kind), prose(note)])
    named = set(re.findall(r"\w+", body))
    missing = [m for m in gate.METRICS if m not in named]
    if missing:
        raise DocsError(f"metrics the gate takes and its docstring's table does not name: {missing}")
    return rows


def gate_markdown() -> str:
    """The reference: example, top-level keys, a check's keys, limits (operators, texts), metrics."""
    top = [[code(k), "table" if k == "defaults" else ("array of tables" if k == "check" else "text")]
           for k in gate.TOP_KEYS]
    check = [[code(k), "yes" if k in gate.REQUIRED_KEYS else "no", "yes" if k in gate.DEFAULT_KEYS else "no"]
             for k in gate.CHECK_KEYS]
    texts = [[code(m), ", ".join(code(v) for v in allowed)] for m, allowed in gate.TEXT_METRICS.items()]
    keys_line = gate.__doc__.split("Keys of a check:", 1)[1].split("\n\n", 1)[0]
    return "\n".join([
        "### An example, every key", "", fence(_docstring_block("Gate file format (TOML)"), "toml"), "",
        "### The top level", "", table(["key", "kind"], top), "",
        "### A `[[check]]`", "", prose("Keys of a check:" + keys_line), "",
        table(["key", "required", cell("may be set in [defaults]")], check), "",
        "### Limits", "",
        cell('Each limit is "METRIC OP VALUE". Operators on a text metric: ') + ", ".join(map(code, gate.TEXT_OPS))
        + cell("; on a number: ") + ", ".join(map(code, gate.NUMBER_OPS)) + ".", "",
        table(["text metric", "values"], texts), "",
        "### Metrics", "", table(["metric", "kind", "operators, or what it measures"], _metric_rows()),
    ])
