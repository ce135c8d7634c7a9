"""The comparison report: every scene on every engine, in one self-contained HTML page and a Markdown twin.

    >>> report = build_report(["feigin-pair", "bouncing-ball"], engines=("mujoco", "pybullet"))
    >>> paths = write_report(report, Path("report"))      # report/index.html, report/report.md
    >>> report.summary[["scene", "engine", "verdict", "exit_error_max"]]

``index.html`` opens with the summary table (scene x engine: verdict, episodes matched,
worst exit and sticking errors, cost), then per scene the time-series chart and the
episode table, then, when a sweep dataset is given, its work-precision chart and stability
maps, and ends with what produced it (engine versions and settings, reference chatter
modes, tolerances, machine, date, command).

Promises: ``index.html`` is one file that needs nothing else: figures are base64 PNG
``data:`` URIs, the style sheet is inline, there is no script and no network address.
``report.md`` carries the same tables (no figures) for pasting into issues and pull
requests. The summary's columns are the sweep rows' (``rows.summarize``), so a number in
the report is the number a gate (``gate.py``) checks.
"""

from __future__ import annotations

import base64
import html
import math
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Sequence

import pandas as pd

from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import load_scene

from .atomic import write_text
from .pipeline.compare import Comparison, compare
from .pipeline.summary import summarize
from .pipeline.tolerances import Tolerances
from .pipeline.vocabulary import COLOURS, MEANINGS, NAMES, text_colour

SUMMARY_COLUMNS = ["scene", "engine", "verdict", "n_match", "n_episodes", "stick_error_max", "stick_error_rel_max",
                   "exit_error_max", "exit_error_rel_max", "restitution_error_max", "penetration_max", "cost_per_sim_s",
                   "status"]
EPISODE_COLUMNS = ["engine", "wall", "ref_t_stick", "t_stick", "stick_error_zeno", "stick_error_rel", "ref_t_exit", "t_exit",
                   "exit_error", "exit_error_rel", "exit_error_steps", "restitution_error", "resolved_impacts",
                   "ref_resolved_impacts", "n_impacts", "verdict"]
# headers shown for the columns above; errors are printed in ms, times in s
HEADERS = {
    "scene": "scene", "engine": "engine", "verdict": "verdict", "n_match": "matched", "n_episodes": "episodes",
    "exit_error_max": "worst exit error [ms]", "stick_error_max": "worst sticking error [ms]",
    "exit_error_rel_max": "worst exit error / sliding", "stick_error_rel_max": "worst sticking error / chatter",
    "restitution_error_max": "worst restitution error", "penetration_max": "deepest penetration [mm]",
    "stick_error_rel": "/ chatter", "exit_error_rel": "/ sliding", "exit_error_steps": "exit error [steps]",
    "restitution_error": "restitution error", "resolved_impacts": "resolved", "ref_resolved_impacts": "ref. resolved",
    "cost_per_sim_s": "cost [s per sim. s]", "status": "run", "wall": "wall",
    "ref_t_stick": "ref. sticks [s]", "t_stick": "sticks [s]", "stick_error_zeno": "sticking error [ms]",
    "ref_t_exit": "ref. exits [s]", "t_exit": "exits [s]", "exit_error": "exit error [ms]",
    "n_impacts": "impacts", "ref_n_impacts": "ref. impacts",
}
MS_COLUMNS = {"exit_error_max", "stick_error_max", "stick_error_zeno", "exit_error", "penetration_max"}
FRACTION_COLUMNS = {"stick_error_rel_max", "exit_error_rel_max", "restitution_error_max", "stick_error_rel", "exit_error_rel",
                    "restitution_error", "exit_error_steps"}
TIME_COLUMNS = {"ref_t_stick", "t_stick", "ref_t_exit", "t_exit"}

Progress = Callable[[str], None]


@dataclass(frozen=True)
class SweepSection:
    """A sweep dataset to chart in the report: its rows and where they came from."""

    source: str  # the dataset's path, as given
    rows: pd.DataFrame  # summary.ROW_COLUMNS plus one column per swept parameter


@dataclass(frozen=True)
class Report:
    """What ``build_report`` ran: one comparison per scene and the summary over them."""

    comparisons: tuple[Comparison, ...]
    summary: pd.DataFrame  # one row per (scene, engine): summary.summarize columns
    engines: tuple[str, ...]
    dt: float | None  # [s] the timestep asked for; None: each engine's default
    overrides: tuple[str, ...]  # the KEY=VALUE items applied to every scene and engine
    wall_time_s: float  # [s] the whole report's runs
    created: str  # ISO date, UTC
    command: str = ""  # the command line that produced it, for the provenance
    sweep: SweepSection | None = None
    tuning: tuple[str, ...] = ()  # HTML sections written by `chatterbench tune --out DIR` (guide_section.html)


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def build_report(
    scenes: Sequence[str] = tuple(CATALOGUE),
    engines: Sequence[str] = ("mujoco", "pybullet"),
    dt: float | None = None,
    scene_overrides: Sequence[str] = (),
    engine_overrides: Sequence[str] = (),
    tol: Tolerances | None = None,
    sweep: SweepSection | None = None,
    progress: Progress | None = _stderr,
    command: str = "",
) -> Report:
    """Compare every scene on every engine; the scenes are all loaded (validated) before any run.

    Parameters
    ----------
    scenes : built-in scene names or scene TOML paths (default: the whole catalogue).
    dt : engine timestep [s]; default: each engine's default settings.
    scene_overrides, engine_overrides : ``KEY=VALUE`` items (``duration=1.6``;
        ``mujoco.w0_dt=0.05``) applied to every scene / engine.
    progress : called with one line per scene and engine as the runs finish; None: silent.
    """
    say = progress or (lambda line: None)
    loaded = [load_scene(s, list(scene_overrides)) for s in scenes]
    start = time.perf_counter()
    comparisons, rows = [], []
    for i, scene in enumerate(loaded, 1):
        say(f"[{i}/{len(loaded)}] {scene.name}: reference and {', '.join(engines)} ...")
        t0 = time.perf_counter()
        c = compare(scene, engines=tuple(engines), dt=dt, overrides=list(engine_overrides), tol=tol)
        comparisons.append(c)
        for name, run in c.runs.items():
            row = summarize(c, name, {})
            rows.append(row)
            say(f"      {scene.name} / {name}: {row['verdict']} ({row['n_match']}/{row['n_episodes']} episodes match), "
                f"{run.wall_time:.2f} s stepping")
        say(f"      {scene.name} done in {time.perf_counter() - t0:.1f} s "
            f"(reference {c.provenance['reference']['wall_time_s']:.2f} s)")
    summary = pd.DataFrame(rows)
    return Report(
        comparisons=tuple(comparisons), summary=summary, engines=tuple(engines), dt=dt,
        overrides=tuple(scene_overrides) + tuple(engine_overrides), wall_time_s=time.perf_counter() - start,
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"), command=command, sweep=sweep,
    )


# -- cells -------------------------------------------------------------------------------

def _cell(column: str, value: Any) -> str:
    """Plain-text form of one table cell (errors in ms, times in s)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if column in MS_COLUMNS:
        return f"{value * 1e3:.3g}"
    if column in TIME_COLUMNS:
        return f"{value:.4f}"
    if column in FRACTION_COLUMNS:
        return f"{value:.2g}"
    if column == "cost_per_sim_s":
        return f"{value:.3g}"
    if isinstance(value, float) and value.is_integer() and column.startswith("n_"):
        return str(int(value))
    return str(value)


def _summary_frame(report: Report) -> pd.DataFrame:
    return report.summary[SUMMARY_COLUMNS] if len(report.summary) else pd.DataFrame(columns=SUMMARY_COLUMNS)


def _tolerance_line(c: Comparison) -> str:
    return (f"a match has {c.tolerances.describe()}, each against the episode's own chatter and sliding durations "
            "(the reference's Zeno point - first impact, exit - Zeno point)")


def _engine_rows(report: Report) -> list[dict[str, Any]]:
    """One row per engine: version and the settings it ran with (from the first scene that ran it)."""
    out = []
    for name in report.engines:
        for c in report.comparisons:
            info = c.provenance.get("engines", {}).get(name)
            if info:
                settings = {k: v for k, v in info["settings"].items() if k not in ("fault", "mujoco_version")}
                out.append({"engine": name, "version": info["version"],
                            "settings": ", ".join(f"{k}={_setting(v)}" for k, v in settings.items())})
                break
    return out


def _setting(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_setting(x) for x in v) + "]"
    return str(v)


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _provenance_items(report: Report) -> list[tuple[str, str]]:
    from importlib.metadata import PackageNotFoundError, version

    try:
        own = version("chatterbench")
    except PackageNotFoundError:  # running from a source tree that is not installed
        own = "not installed"
    first = report.comparisons[0].provenance if report.comparisons else {}
    items = [
        ("produced by", f"chatterbench {own}"),
        ("command", report.command or "(library call)"),
        ("date", report.created),
        ("machine", first.get("machine", "")),
        ("reference chatter modes", ", ".join(first.get("reference", {}).get("chatter_modes", []))
         + " (feigin: plate entry then sliding; exhaustive: every impact up to the Zeno point)"),
        ("timestep", "each engine's default" if report.dt is None else f"{report.dt:g} s"),
        ("overrides", ", ".join(report.overrides) if report.overrides else "none"),
        ("tolerances", ", ".join(f"{k} = {v}" for k, v in first.get("tolerances", {}).items())
         + " (fractions of the scene's time scale T; energy_gain relative)"),
        ("wall time", f"{report.wall_time_s:.1f} s for {_plural(len(report.comparisons), 'scene')}"),
    ]
    return items


# -- figures -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Figure:
    """One rendered figure: PNG bytes, caption, and a stable id (``timeseries-SCENE``, ...)."""

    id: str
    caption: str
    png: bytes


def _render(fig) -> bytes:
    import matplotlib.pyplot as plt

    from .outputs import figure_bytes

    try:
        return figure_bytes(fig, "png")
    finally:
        plt.close(fig)


def scene_figures(report: Report) -> list[Figure]:
    """The time-series chart of every scene, rendered."""
    from .charts import timeseries_figure

    return [Figure(f"timeseries-{c.scene.name}", f"{c.scene.name}: y(t) of the reference and each engine; "
                   "shaded: the reference's sliding (plate entry to exit)", _render(timeseries_figure(c)))
            for c in report.comparisons]


def _stability_pairs(rows: pd.DataFrame, engine: str, params: Sequence[str], limit: int = 4) -> list[tuple[str, str]]:
    """(x, y) parameter pairs worth a stability map for ``engine``.

    The maps of the sweeps issue first: dt x restitution, dt x mass ratio, each of the
    engine's settings x restitution; then dt x any other varying parameter. The masses are
    drawn as their ratio when it varies.
    """
    sub = rows[rows["engine"] == engine]
    varying = [p for p in params if p in sub and sub[p].dropna().nunique() > 1]
    if "mass_ratio" in varying:
        varying = [p for p in varying if p not in ("mass1", "mass2")]
    if len(varying) < 2:
        return []
    x = "dt" if "dt" in varying else varying[0]
    settings = [p for p in varying if p.startswith(engine + ".")]
    pairs = [(x, y) for y in ("restitution", "mass_ratio") if y in varying and y != x]
    if "restitution" in varying:
        pairs += [(s, "restitution") for s in settings]
    pairs += [(x, y) for y in varying if y != x and (x, y) not in pairs and (y, "restitution") not in pairs]
    return pairs[:limit]


def sweep_figures(section: SweepSection) -> tuple[list[Figure], list[str]]:
    """The sweep's work-precision chart and stability maps, rendered; plus notes on what was skipped.

    The charts come from ``sweep_charts`` (``work_precision_figure``, ``stability_map_figure``);
    a chart that cannot be drawn from these rows becomes a note, not an error.
    """
    try:
        from . import sweep_charts
    except ImportError as exc:  # the charts module is optional in a trimmed install
        return [], [f"sweep charts unavailable: {exc}"]
    rows = section.rows
    figures, notes = [], []
    params = sweep_charts.parameter_columns(rows)
    engines = sorted(rows["engine"].astype(str).unique())
    # each chart shows the slice a user starts from: parameters it does not draw are held at
    # their defaults where the sweep ran them (the caption says which), else folded worst-case
    scene_params = [c for c in params if c.split(".")[0] not in engines]
    slices = [sweep_charts.at_defaults(rows, e, ["dt"], scene_params) for e in engines]
    held = {k: v for _, h in slices for k, v in h.items()}
    try:
        figures.append(Figure("work-precision", "work-precision: worst error against wall-clock cost per engine, "
                              "one point per timestep" + _held(held),
                              _render(sweep_charts.work_precision_figure(pd.concat([s for s, _ in slices])))))
    except sweep_charts.ChartError as exc:
        notes.append(f"work-precision chart: {exc}")
    for engine in engines:
        pairs = _stability_pairs(rows, engine, params)
        if not pairs:
            notes.append(f"stability map ({engine}): needs two swept parameters; this sweep varies fewer for {engine}")
        for x, y in pairs:
            sub, held = sweep_charts.at_defaults(rows, engine, (x, y))
            try:
                figures.append(Figure(f"stability-{engine}-{x}-{y}", f"stability map, {engine}: verdict over {x} and {y}"
                                      + _held(held), _render(sweep_charts.stability_map_figure(sub, x, y, engine))))
            except sweep_charts.ChartError as exc:
                notes.append(f"stability map ({engine}, {x} x {y}): {exc}")
    return figures, notes


def _held(held: dict[str, Any]) -> str:
    """Caption tail naming the parameters a chart holds at their defaults."""
    if not held:
        return ""
    return "; held at the defaults: " + ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                                                  for k, v in held.items())


# -- HTML --------------------------------------------------------------------------------

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 1300px;
       padding: 0 1em; color: #222; line-height: 1.4; }
h1 { margin-bottom: 0.2em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td.text, th.text { text-align: left; }
td.verdict { font-weight: 600; text-align: center; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
.note { color: #555; font-size: 0.9em; } code { background: #f6f6f6; padding: 0 0.2em; }
table.prov th { width: 13em; }
"""


def _verdict_style(verdict: str) -> str:
    return f"background:{COLOURS.get(verdict, '#ffffff')};color:{text_colour(verdict)}"


def _html_table(frame: pd.DataFrame, columns: Sequence[str], link_scene: bool = False) -> str:
    text_cols = {"scene", "engine", "verdict", "status", "wall"}
    head = "".join(f'<th class="{"text" if c in text_cols else "num"}">{html.escape(HEADERS.get(c, c))}</th>' for c in columns)
    body = []
    for _, row in frame.iterrows():
        cells = []
        for c in columns:
            value = html.escape(_cell(c, row[c]))
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
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        "<title>chatterbench report</title>", f"<style>{_CSS}</style></head><body>",
        "<h1>chatterbench report</h1>",
        f'<p class="note">{_plural(len(report.comparisons), "scene")} on {", ".join(report.engines)} against the exact '
        f"event-driven reference (Feigin 1967), {html.escape(report.created)}. Errors are engine minus reference; "
        "worst = largest magnitude over the scene's episodes.</p>",
        '<h2 id="summary">Summary</h2>',
        _html_table(_summary_frame(report), SUMMARY_COLUMNS, link_scene=True),
        _verdict_legend(),
    ]
    for c in report.comparisons:
        name = c.scene.name
        parts.append(f'<h2 id="scene-{html.escape(name)}">{html.escape(name)}</h2>')
        if c.scene.description:
            parts.append(f"<p>{html.escape(c.scene.description)}</p>")
        parts.append(f'<p class="note">R = {c.scene.restitution:g}, walls: {", ".join(c.scene.gap.walls)}, '
                     f"duration {c.scene.duration:.4g} s; {html.escape(_tolerance_line(c))}.</p>")
        parts.append(_img(figures[f"timeseries-{name}"]))
        parts.append(_html_table(c.table, EPISODE_COLUMNS))
        failed = {n: r.trajectory.message for n, r in c.runs.items() if r.trajectory.message}
        for n, msg in failed.items():
            parts.append(f'<p class="note">{html.escape(n)}: {html.escape(msg.splitlines()[0])}</p>')
    if report.sweep is not None:
        figs, notes = sweep_figures(report.sweep)
        parts.append('<h2 id="sweep">Sweep</h2>')
        parts.append(f'<p class="note">dataset {html.escape(report.sweep.source)}: {len(report.sweep.rows)} rows '
                     f'({", ".join(sorted(report.sweep.rows["engine"].astype(str).unique()))}).</p>')
        parts.extend(_img(f) for f in figs)
        parts.extend(f'<p class="note">{html.escape(n)}</p>' for n in notes)
    parts.extend(report.tuning)  # tuning guides, as `chatterbench tune` wrote them
    parts.append('<h2 id="provenance">What produced this report</h2><table class="prov"><tbody>')
    for key, value in _provenance_items(report):
        shown = f"<code>{html.escape(value)}</code>" if key == "command" else html.escape(value)
        parts.append(f'<tr><th class="text">{html.escape(key)}</th><td class="text">{shown}</td></tr>')
    parts.append("</tbody></table>")
    parts.append(_html_table(pd.DataFrame(_engine_rows(report)), ["engine", "version", "settings"]).replace(
        'class="num"', 'class="text"'))
    parts.append("</body></html>")
    return "\n".join(parts)


# -- Markdown ----------------------------------------------------------------------------

def _md_table(frame: pd.DataFrame, columns: Sequence[str]) -> str:
    lines = ["| " + " | ".join(HEADERS.get(c, c) for c in columns) + " |",
             "| " + " | ".join("---" if c in ("scene", "engine", "wall", "verdict", "status") else "---:" for c in columns) + " |"]
    for _, row in frame.iterrows():
        lines.append("| " + " | ".join(_cell(c, row[c]).replace("|", "\\|") for c in columns) + " |")
    if len(frame) == 0:
        lines.append("| " + " | ".join(["-"] * len(columns)) + " |")
    return "\n".join(lines)


def report_markdown(report: Report) -> str:
    """The report's tables in Markdown (GitHub flavour), for issues and pull requests."""
    out = ["# chatterbench report", "",
           f"{_plural(len(report.comparisons), 'scene')} on {', '.join(report.engines)} against the exact reference. "
           "Errors are engine minus reference, worst = largest magnitude over the scene's episodes.", "",
           "## Summary", "", _md_table(_summary_frame(report), SUMMARY_COLUMNS), ""]
    for c in report.comparisons:
        out += [f"## {c.scene.name}", "", f"{_tolerance_line(c)}.", "", _md_table(c.table, EPISODE_COLUMNS), ""]
    out += ["## What produced this report", ""]
    for key, value in _provenance_items(report):
        out.append(f"- {key}: `{value}`" if key == "command" else f"- {key}: {value}")
    for row in _engine_rows(report):
        out.append(f"- {row['engine']} {row['version']}: {row['settings']}")
    return "\n".join(out) + "\n"


def write_report(report: Report, out: Path) -> list[Path]:
    """Write ``index.html`` and ``report.md`` under ``out`` (atomically); returns the paths."""
    out = Path(out)
    return [write_text(out / "index.html", report_html(report)), write_text(out / "report.md", report_markdown(report))]
