"""Everything ``chatterbench tune --out DIR`` writes: per engine the answer, its guide, its runs and figures; the frontier of all.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.tune_files import write_tune_files
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...               ladder=None, phases=(), transfer=False)
    >>> written = write_tune_files([result], Path(tempfile.mkdtemp()))
    >>> written[:3], "frontier.png/.svg" in written
    (['recommended.json', 'guide.md', 'guide.html'], True)

One engine: ``DIR/recommended.json`` (``studies.tune.answer.recommended``, its ``frontier``
included), ``guide.md``, ``guide.html`` and ``guide_section.html`` (``guide.py``; the last for
``chatterbench report --tune DIR``), ``candidates.csv`` (every run, ``TUNE_COLUMNS`` with the
ladder points each passes at, is robust at and was not judged at as ``stick%/restitution%``
pairs, e.g. ``5/20 10/30``), the figures (``guide.FIGURE_FILES``, PNG and SVG), the engine's files at the
chosen settings (``engine_files``: the written answer; where nothing is robust at the asked tolerances, the
tightest robust frontier point's, never a fragile setting's) and each frontier point's own model, runnable script
and snippet under ``frontier/stick5-restitution20/`` (``engine_files.write_frontier_files``, listed in
``recommended.json``'s frontier entries as ``files``). Several engines: each engine's set under ``DIR/ENGINE`` as
one engine writes it, and under ``DIR`` the frontier of all of them in one chart
(``frontier.png/.svg``, one line per engine) with a guide that leads with each engine's
answer and embeds each engine's guide (``guide.md``, ``guide.html``, ``guide_section.html``).
The JSON is written first: the guide's files are made from what it says.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Sequence

import pandas as pd

from chatterbench.comparisons.pipeline.atomic import write_frame, write_text
from chatterbench.comparisons.pipeline.inert_text import md_escape
from chatterbench.comparisons.studies.tune.answer import frontier_line, recommended
from chatterbench.comparisons.studies.tune.evidence import evidence

from .engine_files import write_engine_files, write_frontier_files
from .figures import figure_files, write_figure
from .frontier_chart import frontier_figure
from .guide import CAPTIONS, FIGURE_FILES, guide_figures, guide_html, guide_markdown, guide_section_html, html_page


def level_labels(points, indices) -> str:
    """Ladder point indices as ``stick%/restitution%`` pairs (``5/20 10/30``); "" for none, "-" when not run."""
    if indices is None or isinstance(indices, float):
        return "-"
    return " ".join(f"{100 * points[i].stick:g}/{100 * points[i].restitution:g}" for i in indices)


def candidates_frame(result) -> pd.DataFrame:
    """``result.table`` for ``candidates.csv``: the ladder columns as text."""
    points = result.extra.get("points") or (result.tolerance,)
    table = result.table.copy()
    for column in ("passes", "robust_at", "unjudged"):
        if column in table:
            table[column] = [level_labels(points, v) for v in table[column]]
    if "margins" in table:
        table["margins"] = [" ".join(f"{m:.3g}" for m in v) if isinstance(v, tuple) else "-" for v in table["margins"]]
    return table


def write_engine_set(result, out: Path) -> tuple[list[str], str]:
    """One engine's files under ``out`` (module docstring); returns their names relative to ``out``, and its guide
    section (the HTML fragment of ``guide_section.html``, for the guide of several engines)."""
    rec = recommended(result)
    ev = evidence(result)  # reruns the chosen settings: strikes at every resolved impact, the ladder
    figures = guide_figures(result, ev)
    written = []
    if rec is not None:  # first: the guide's files are written from what it says
        write_text(out / "recommended.json", json.dumps(rec, indent=2) + "\n")
        written.append("recommended.json")
    write_text(out / "guide.md", guide_markdown(result, figures, ev))
    files = {name: figure_files(fig) for name, fig in figures.items()}  # each drawn once, for the page and the files
    # the section rendered once: the page and `report --tune DIR` embed it
    section = guide_section_html(result, figures, ev, png={name: f["png"] for name, f in files.items()})
    write_text(out / "guide.html", guide_html(result, section=section))
    write_text(out / "guide_section.html", section)
    write_frame(out / "candidates.csv", candidates_frame(result))
    written += ["guide.md", "guide.html", "guide_section.html", "candidates.csv"]
    for name, fig in figures.items():
        write_figure(fig, out, FIGURE_FILES[name], files[name])
        written.append(f"{FIGURE_FILES[name]}.png/.svg")
    written += write_engine_files(result, out)  # engine files at recommended.json's settings
    return written + write_frontier_files(result, out), section


def write_tune_files(results: Sequence, out: Path) -> list[str]:
    """What ``tune --out`` writes for ``results`` (one per engine, one scene); returns the names written."""
    out = Path(out)
    if len(results) == 1:
        return write_engine_set(results[0], out)[0]
    written, sections = [], []
    for result in results:
        names, section = write_engine_set(result, out / result.engine)
        written += [f"{result.engine}/{name}" for name in names]
        sections.append(section)
    first = results[0]
    fig = frontier_figure({r.engine: r.frontier for r in results}, first.scene.name,
                          {"stick": first.tolerance.stick, "restitution": first.tolerance.restitution})
    files = figure_files(fig)
    write_figure(fig, out, "frontier", files)
    section = _combined_section(results, files["png"], sections)
    write_text(out / "guide_section.html", section)
    write_text(out / "guide.html", html_page(f"tuning {first.scene.name}", section))
    write_text(out / "guide.md", _combined_markdown(results))
    return written + ["frontier.png/.svg", "guide_section.html", "guide.html", "guide.md"]


def _combined_markdown(results: Sequence) -> str:
    first = results[0]
    lines = [f"# Tuning {md_escape(', '.join(r.engine for r in results))} for {md_escape(first.scene.name)}", "",
             f"Tolerances: {first.tolerance.describe()}; every episode must pass.", ""]
    for r in results:
        lines += [f"- **{md_escape(r.engine)}**: {frontier_line(r)} ([its guide]({r.engine}/guide.md), "
                  f"[recommended.json]({r.engine}/recommended.json))", ""]
    lines += ["![frontier](frontier.png)", "", f"*{CAPTIONS['frontier']} One line per engine.*", ""]
    return "\n".join(lines)


def _combined_section(results: Sequence, frontier_png: bytes, sections: list[str]) -> str:
    import base64

    first = results[0]
    png = base64.b64encode(frontier_png).decode()
    parts = [f'<h2 id="tuning-{html.escape(first.scene.name)}">Tuning {html.escape(", ".join(r.engine for r in results))} '
             f"for {html.escape(first.scene.name)}</h2>",
             f'<p class="note">Tolerances: {html.escape(first.tolerance.describe())}; every episode must pass.</p>',
             "<ul>" + "".join(f"<li><strong>{html.escape(r.engine)}</strong>: {html.escape(frontier_line(r))}</li>"
                              for r in results) + "</ul>",
             f'<figure><img alt="frontier" src="data:image/png;base64,{png}"><figcaption>'
             f"{html.escape(CAPTIONS['frontier'])} One line per engine.</figcaption></figure>"]
    return "\n".join(parts + sections)
