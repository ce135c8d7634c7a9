"""The report as files: one self-contained HTML page (figures inline, no script, no network) and its Markdown twin.

    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> from chatterbench.comparisons.outputs.report_page import build_report, write_report
    >>> from chatterbench.engines.registry import settings_for
    >>> report = build_report(["bouncing-ball"], engines=("pybullet",), dt=1e-3, progress=None,
    ...                       settings=settings_for(("pybullet",), 1e-3))
    >>> [p.name for p in write_report(report, tmp / "report")]
    ['index.html', 'report.md']
"""

from __future__ import annotations

import base64
import dataclasses
import html
from pathlib import Path
from typing import Sequence

import pandas as pd

from chatterbench.comparisons.pipeline.atomic import write_text
from chatterbench.comparisons.pipeline.inert_text import md_code, md_escape
from chatterbench.comparisons.pipeline.conformance import describe, same_model_pairs
from chatterbench.comparisons.pipeline.vocabulary import COLOURS, MEANINGS, NAMES, text_colour

from .figures import figure_bytes
from .style import PAGE_CSS

from .report import (EPISODE_COLUMNS, HEADERS, SUMMARY_COLUMNS, Figure, Report, cell, engine_rows, frontier_figures,
                     plural, provenance_items, summary_frame, tolerance_line, build_report, scene_figures, sweep_figures,
                     sweep_rows)

__all__ = ["build_report", "md_escape", "report_html", "report_markdown", "write_report"]


# -- HTML (style sheet: ``style.PAGE_CSS``, shared with the tuning guide) -----------------------------------------

# the page's promise, kept by the browser too: nothing runs, nothing is fetched; images only from the page itself
CONTENT_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'"

def _verdict_style(verdict: str) -> str:
    return f"background:{COLOURS.get(verdict, '#ffffff')};color:{text_colour(verdict)}"


def _html_table(frame: pd.DataFrame, columns: Sequence[str], link_scene: bool = False) -> str:
    text_cols = {"scene", "engine", "verdict", "status", "wall"}
    head = "".join(f'<th class="{"text" if c in text_cols else "num"}">{html.escape(HEADERS.get(c, c))}</th>' for c in columns)
    body = []
    for _, row in frame.iterrows():
        cells = []
        for c in columns:
            value = html.escape(cell(c, row[c]))
            if c == "verdict":
                cells.append(f'<td class="verdict" style="{_verdict_style(str(row[c]))}">{value}</td>')
            elif c == "scene" and link_scene:
                cells.append(f'<td class="text"><a href="#scene-{value}">{value}</a></td>')
            else:
                cells.append(f'<td class="{"text" if c in text_cols else "num"}">{value}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    if not body:
        body.append(f'<tr><td class="text" colspan="{len(columns)}">no episodes: neither the reference nor the engines '
                    "stick within the run</td></tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _img(fig: Figure) -> str:
    data = base64.b64encode(fig.png).decode("ascii")
    return (f'<figure id="{html.escape(fig.id)}"><img src="data:image/png;base64,{data}" alt="{html.escape(fig.caption)}">'
            f"<figcaption>{html.escape(fig.caption)}</figcaption></figure>")


def _verdict_legend() -> str:
    items = "".join(f'<tr><td class="verdict" style="{_verdict_style(v)}">{v}</td><td class="text">{html.escape(MEANINGS[v])}</td></tr>'
                    for v in NAMES)
    return f"<details><summary>what the verdicts mean</summary><table><tbody>{items}</tbody></table></details>"


def report_html(report: Report) -> str:
    """The report as one self-contained HTML document (figures embedded as base64 PNG)."""
    figures = {f.id: f for f in scene_figures(report)}
    frontiers = {f.id: f for f in frontier_figures(report)}  # from --tune DIR: the robust frontier per scene
    checks = {k.scene: k for k in report.cross_checks}
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f'<meta http-equiv="Content-Security-Policy" content="{CONTENT_POLICY}">',
        "<title>chatterbench report</title>", f"<style>{PAGE_CSS}</style></head><body>",
        "<h1>chatterbench report</h1>",
        f'<p class="note">{plural(len(report.comparisons), "scene")} on {", ".join(report.engines)} against the exact '
        f"event-driven reference (Feigin 1967), {html.escape(report.created)}. Errors are engine minus reference; "
        "worst = the largest in magnitude over the scene's episodes, with its sign (negative: the engine sticks, exits or "
        "first hits early, or keeps less than R of its speed).</p>",
        '<h2 id="summary">Summary</h2>',
        _html_table(summary_frame(report), SUMMARY_COLUMNS, link_scene=True),
        _verdict_legend(),
    ]
    for c in report.comparisons:
        name = c.scene.name
        parts.append(f'<h2 id="scene-{html.escape(name)}">{html.escape(name)}</h2>')
        if c.scene.description:
            parts.append(f"<p>{html.escape(c.scene.description)}</p>")
        parts.append(f'<p class="note">R = {c.scene.restitution:g}, walls: {", ".join(c.scene.gap.walls)}, '
                     f"duration {c.scene.duration:.4g} s; {html.escape(tolerance_line(c))}.</p>")
        parts.append(_img(figures[f"timeseries-{name}"]))
        parts.append(_img(figures[f"ladder-{name}"]))
        parts.append(_img(figures[f"episode-errors-{name}"]))
        parts.append(_html_table(c.table, EPISODE_COLUMNS))
        if name in checks:  # Siconos, a second nonsmooth reference, against Feigin's model
            parts.append(f'<p class="note cross-check">{html.escape(checks[name].line())}</p>')
        for a, b in same_model_pairs(c.runs):  # one model on two executors (MuJoCo C, MuJoCo Warp): where they part
            parts.append(f'<p class="note">Conformance: {html.escape(describe(c, a, b))}</p>')
        failed = {n: r.trajectory.message for n, r in c.runs.items() if r.trajectory.message}
        for n, msg in failed.items():
            parts.append(f'<p class="note">{html.escape(n)}: {html.escape(msg.splitlines()[0])}</p>')
        if f"frontier-{name}" in frontiers:
            parts.append(_img(frontiers.pop(f"frontier-{name}")))
    for i, section in enumerate(report.sweeps, 1):
        figs, notes = sweep_figures(section, report.engines)
        if i > 1:  # ids stay unique on the page
            figs = [dataclasses.replace(f, id=f"sweep{i}-{f.id}") for f in figs]
        rows = sweep_rows(section, report.engines)
        parts.append(f'<h2 id="sweep-{i}">Sweep: {html.escape(section.source)}</h2>')
        parts.append(f'<p class="note">{len(rows)} rows of {html.escape(", ".join(report.engines))} '
                     f'(of {len(section.rows)} in the dataset).</p>')
        parts.extend(_img(f) for f in figs)
        parts.extend(f'<p class="note">{html.escape(n)}</p>' for n in notes)
    parts.extend(_img(f) for f in frontiers.values())  # tuned scenes the report did not run
    parts.extend(report.tuning)  # tuning guides, as `chatterbench tune` wrote them, made inert (cli/report.py)
    if report.atlas is not None:  # every engine's band-robust frontier on every scene (``atlas_section``)
        from .atlas_section import atlas_html

        parts.append(atlas_html(report.atlas, lambda fig, id_, caption: _img(Figure(id_, caption, figure_bytes(fig, "png")))))
    parts.append('<h2 id="provenance">What produced this report</h2><table class="prov"><tbody>')
    for key, value in provenance_items(report):
        shown = f"<code>{html.escape(value)}</code>" if key == "command" else html.escape(value)
        parts.append(f'<tr><th class="text">{html.escape(key)}</th><td class="text">{shown}</td></tr>')
    parts.append("</tbody></table>")
    parts.append(_html_table(pd.DataFrame(engine_rows(report)), ["engine", "version", "settings"]).replace(
        'class="num"', 'class="text"'))
    parts.append("</body></html>")
    return "\n".join(parts)


# -- Markdown ----------------------------------------------------------------------------

def _md_table(frame: pd.DataFrame, columns: Sequence[str]) -> str:
    lines = ["| " + " | ".join(HEADERS.get(c, c) for c in columns) + " |",
             "| " + " | ".join("---" if c in ("scene", "engine", "wall", "verdict", "status") else "---:" for c in columns) + " |"]
    for _, row in frame.iterrows():  # a name from a file (scene, engine, message) shown as written: md_escape
        lines.append("| " + " | ".join(md_escape(cell(c, row[c])) for c in columns) + " |")
    if len(frame) == 0:
        lines.append("| " + " | ".join(["-"] * len(columns)) + " |")
    return "\n".join(lines)


def _point_text(entry: dict) -> str:
    """A frontier point as the user types it: its tolerances, cost, dt and every setting (``threshold=0.1``,
    ``w0_dt=0.228``), each value escaped for Markdown (the file is a user's)."""
    tol = entry["tolerances"]
    knobs = [f"{str(k).split('.', 1)[-1]}={v}" for k, v in (entry.get("settings") or {}).items()]
    return md_escape(f"stick {100 * tol['stick']:.3g}%, restitution {100 * tol['restitution']:.3g}% at "
                     f"{entry['cost_steps_per_s']:,.0f} steps/s with " + ", ".join([f"dt={entry['dt']:g}", *knobs]))


def _frontier_lines(report: Report, scene: str) -> list[str]:
    """A scene's tuned frontiers as text (the chart is in index.html): per engine, its points, cheapest first."""
    out = []
    for f in (f for f in report.frontiers if f.scene == scene):
        points = "; ".join(_point_text(e) for e in f.frontier) or "nothing robust in the searched space"
        out.append(f"Robust frontier of {md_escape(f.engine)} (from {md_escape(f.source)}): {points}\n")
    return out


def report_markdown(report: Report) -> str:
    """The report's tables in Markdown (GitHub flavour), for issues and pull requests."""
    out = ["# chatterbench report", "",
           f"{plural(len(report.comparisons), 'scene')} on {md_escape(', '.join(report.engines))} against the exact reference. "
           "Errors are engine minus reference, worst = the largest in magnitude over the scene's episodes, with its sign "
           "(negative: the engine sticks, exits or first hits early, or keeps less than R of its speed).", "",
           "## Summary", "", _md_table(summary_frame(report), SUMMARY_COLUMNS), ""]
    for c in report.comparisons:
        out += [f"## {md_escape(c.scene.name)}", "", f"{tolerance_line(c)}.", "", _md_table(c.table, EPISODE_COLUMNS), ""]
        out += [f"{md_escape(k.line())}\n" for k in report.cross_checks if k.scene == c.scene.name]
        out += [f"Conformance: {md_escape(describe(c, a, b))}\n" for a, b in same_model_pairs(c.runs)]
        out += _frontier_lines(report, c.scene.name)
    for section in report.sweeps:  # the charts are in index.html; here the verdicts they draw
        rows = sweep_rows(section, report.engines)
        counts = rows.groupby(["engine", "verdict"]).size().unstack(fill_value=0)
        out += [f"## Sweep: {md_escape(section.source)}", "", f"{len(rows)} rows of {md_escape(', '.join(report.engines))}; "
                "runs per verdict (the work-precision chart and stability maps are in index.html):", "",
                "| engine | " + " | ".join(map(md_escape, counts.columns)) + " |", "|---|" + "---:|" * len(counts.columns)]
        out += [f"| {md_escape(engine)} | " + " | ".join(str(int(v)) for v in row) + " |"
                for engine, row in counts.iterrows()]
        out.append("")
    ran = {c.scene.name for c in report.comparisons}
    for scene in sorted({f.scene for f in report.frontiers} - ran):  # tuned scenes the report did not run
        out += [f"## {md_escape(scene)} (tuned)", "", *_frontier_lines(report, scene)]
    if report.atlas is not None:
        from .atlas_section import atlas_md

        out += [atlas_md(report.atlas)]
    out += ["## What produced this report", ""]
    for key, value in provenance_items(report):  # the command and the --set overrides are a user's text
        out.append(f"- {key}: {md_code(value)}" if key == "command" else
                   f"- {key}: {md_escape(value) if key in ('overrides', 'machine') else value}")
    for row in engine_rows(report):  # a plugin's name, version and settings: its own text
        out.append(f"- {md_escape(row['engine'])} {md_escape(row['version'])}: {md_escape(row['settings'])}")
    return "\n".join(out) + "\n"


def write_report(report: Report, out: Path) -> list[Path]:
    """Write ``index.html`` and ``report.md`` under ``out`` (atomically); returns the paths."""
    out = Path(out)
    return [write_text(out / "index.html", report_html(report)), write_text(out / "report.md", report_markdown(report))]
