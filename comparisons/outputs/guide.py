"""The tuning guide: the calibration answer for a scene and tolerances, the settings to paste, and the evidence.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.guide import guide_markdown, guide_html
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0, phases=(),
    ...               transfer=False)
    >>> text = guide_markdown(result)             # Markdown: answer, snippet, cheaper failures, every candidate
    >>> text.splitlines()[0], "Recommended" in text
    ('# Tuning pybullet for bouncing-ball', True)
    >>> "<style>" in guide_html(result)           # one self-contained page, styled like the report
    True

The answer: whether the asked tolerances have a robust setting and what is reachable
(``studies.tune.answer.frontier_line``), the recommended candidate (``studies.tune.choice``: the fewest
steps per simulated second that pass, ties to the simplest) or, when nothing passes, the best
reachable one (most matching episodes, then the smallest worst error over its tolerance); the
robust frontier (``studies.tune.frontier``) as a table and a chart (``frontier_chart``); each check's
worst error over its tolerance; every failing candidate no more expensive than it, with the
check that failed and its measure; the snippet a user pastes (``EngineAdapter.snippet``:
MJCF attributes for MuJoCo, PyBullet calls); the figures (``guide_figures``: the trade-off of
every candidate, and from the chosen settings' evidence, ``studies.tune.evidence``, the
chatter ladder on the scene and the effective restitution against impact speed); every
candidate tried. Markdown names the figures by file (``FIGURE_FILES``, written beside it
by ``chatterbench tune --out``); HTML embeds them. The answer's sentences are ``guide_answer``'s.
"""

from __future__ import annotations

import base64
import html
import math

import pandas as pd
from matplotlib.figure import Figure

from chatterbench.comparisons.pipeline.inert_text import md_escape
from chatterbench.comparisons.pipeline.vocabulary import COLOURS, text_colour
from chatterbench.comparisons.studies.tune.answer import FRAME_COLUMNS, frontier_frame, searched_text, transfer_lines
from chatterbench.comparisons.studies.tune.runs import short_label
from chatterbench.engines.export import export_files_names, measurement
from chatterbench.engines.registry import engine_snippet

from .figures import figure_bytes
from .frontier_chart import frontier_figure
from .guide_answer import TRANSFER_NOTE, answer_sentences, fmt, frontier_note
from .ladder import ladder_figure
from .style import PAGE_CSS  # the report page's style sheet: the guide reads like the report
from .restitution_curve import restitution_curve_figure
from .tradeoff import tradeoff_figure

FIGURE_FILES = {"frontier": "frontier", "tradeoff": "tradeoff", "ladder": "ladder", "restitution_curve": "restitution_curve"}
IN_FRONTIER = ("frontier",)  # drawn in the frontier's section, under its table
BESIDE_SNIPPET = ("restitution_curve",)  # what the pasted settings do at every impact speed, drawn right after them
CAPTIONS = {
    "frontier": "The work-precision chart of robust settings: the steps per simulated second of the cheapest robust "
                "setting against the tolerance it reaches, timing (left) and restitution (right), each point labelled "
                "with the tolerance it reaches on the other axis; dashed: the asked tolerance.",
    "tradeoff": "The searched region as a map: dt (cost = 1 / dt) against the main knob, one panel per combination of "
                "the other settings; each run owns its lattice cell (coarse runs large, refined ones small), coloured by "
                "its verdict; the answer circled, fragile passes (isolated: a neighbour fails) crossed.",
    "ladder": "The chosen settings on the scene: each impact's incoming speed per wall visit, the reference's "
              "geometric ladder to its Zeno point and the engine's impacts over it, where each starts sticking.",
    "restitution_curve": "The chosen settings' effective restitution against impact speed, each speed struck at 10 places "
                         "in a step, 8 through it and its 2 ends (where in a step an impact falls moves e): with no force (the contact law alone: median "
                         "line, min to max band), under the scene's own forces at each impact the judge resolves (median "
                         "markers, min to max bars, labelled with the range), the run's resolved impacts (open markers, "
                         "numbered) and the restitution tolerance around R (grey band).",
}
CANDIDATE_COLUMNS = {"stage": "stage", "settings": "settings (dt; what differs from the defaults)", "verdict": "verdict", "matches": "matches",
                     "robust": "robust", "neighbourhood": "neighbours that fail",
                     "worst_ratio": "worst error / tolerance", "failed": "what failed",
                     "steps_per_sim_s": "steps per simulated s", "cost_per_sim_s": "wall s per simulated s",
                     "cost_repeats": "timed runs"}


def snippet(result) -> str:
    """What a user pastes for the chosen candidate: MJCF (MuJoCo) or Python (PyBullet); "" when none ran."""
    from chatterbench.comparisons.studies.tune.evidence import chosen_settings

    settings = chosen_settings(result)
    return "" if settings is None else engine_snippet(result.engine, result.scene, settings)


def _check_text(engine: str) -> str:
    """What the measurement checks, and the files beside the guide that run the whole scene."""
    files = " and ".join(f"`{engine}/{name}`" for name in export_files_names(engine))
    return ("With the placeholders filled as above, these lines measure one impact's e = -v_out / v_in; it should be "
            "the R(v) figure's value at that impact speed (R within the restitution tolerance where the figure says so). "
            f"{files} beside this guide run the whole scene at these settings and print every impact the same way.")


def _check_markdown(result) -> list[str]:
    """The measurement that checks the pasted settings in the user's own model (``engines.export.measurement``)."""
    check = measurement(result.engine)
    return ["## Check it in your own model", "", _check_text(result.engine), "", "```python", check.rstrip(), "```", ""] if check else []


def guide_figures(result, ev=None) -> dict[str, Figure]:
    """The guide's figures by name (``FIGURE_FILES``): the trade-off, and with the evidence ``ev`` the ladder and R(v)."""
    figs = {"frontier": frontier_figure({result.engine: result.frontier}, result.scene.name,
                                        {"stick": result.tolerance.stick, "restitution": result.tolerance.restitution}),
            "tradeoff": tradeoff_figure(result)}
    if ev is not None:
        figs["ladder"] = ladder_figure(ev.comparison)
        if ev.curve is not None:
            figs["restitution_curve"] = restitution_curve_figure(ev.curve, ev.impacts, result.scene.name, ev.strikes,
                                                                 result.tolerance.restitution)
    return figs


LISTED_CANDIDATES = 40  # the candidates the guide's table lists (the cheapest searched ones); candidates.csv has all


def listed_candidates(result) -> tuple[pd.DataFrame, str]:
    """The rows of the guide's table of candidates and what it leaves out, in words: the searched candidates (not the
    band's checks) cheapest first, at most ``LISTED_CANDIDATES``, so that a page with several guides stays small."""
    table = result.table
    band = table["phase"].notna() if "phase" in table else pd.Series(False, index=table.index)
    searched = table[~band].sort_values("steps_per_sim_s", kind="stable")
    listed = searched.head(LISTED_CANDIDATES)
    note = (f"The {len(listed)} cheapest of the {len(searched)} searched candidates"
            + (f" and none of the band's {int(band.sum())} checks" if band.any() else "")
            + "; `candidates.csv` beside this guide has every run.")
    return listed, note


def _closest_note(n: int) -> str:
    """What the table of cheaper failures leaves out (``LISTED_CANDIDATES`` of ``n``, the closest to the answer)."""
    return (f"The {LISTED_CANDIDATES} closest to the answer's cost of the {n} (dearest first); `candidates.csv` beside "
            "this guide has every run.")


def _candidates(frame: pd.DataFrame, defaults: dict) -> pd.DataFrame:
    """The guide's candidate table: the settings as dt and what differs from the defaults (the CSV has them all)."""
    out = frame.assign(matches=[f"{m}/{n}" for m, n in zip(frame["n_match"], frame["n_episodes"])],
                       settings=[short_label(r, defaults) for _, r in frame.iterrows()])
    out["failed"] = out["failed"].replace("", "-")
    out["robust"] = out["robust"].map({True: "yes", False: "fragile"}).fillna("-") if "robust" in out else "-"
    out["neighbourhood"] = out["neighbourhood"].replace("", "-") if "neighbourhood" in out else "-"
    return out[list(CANDIDATE_COLUMNS)]


def _frontier_markdown(result, figures: list[str]) -> list[str]:
    """The frontier's section: its sentence, its table and its chart (Markdown)."""
    lines = ["## Robust frontier", "", frontier_note(result), ""]
    frame = frontier_frame(result)
    if len(frame):
        lines += [_plain_md_table(frame[FRAME_COLUMNS]), ""]
    for name in (n for n in figures if n in IN_FRONTIER):
        lines += [f"![{name}]({FIGURE_FILES[name]}.png)", "", f"*{CAPTIONS[name]}*", ""]
    transfers = transfer_lines(result)
    if transfers:
        lines += ["## What transfers", "", TRANSFER_NOTE, ""] + [f"- {line}" for line in transfers] + [""]
    return lines


def guide_markdown(result, figures: dict | None = None, ev=None) -> str:
    """The guide as Markdown (module docstring); ``figures``: names of the figure files written beside it; ``ev``: the
    chosen settings' evidence (``tune.evidence.evidence``), whose strikes and run impacts the restitution claim gives."""
    x = result.extra
    searched = searched_text(result) if "searched" in x else f"{len(result.table)} candidates"
    lines = [f"# Tuning {md_escape(result.engine)} for {md_escape(result.scene.name)}", "",  # names from a user's file
             f"Tolerances: {result.tolerance.describe()}; every episode must pass.", "",
             f"Searched: {searched}; the search took {fmt(x.get('wall_time_s', math.nan))} s (reference, runs and "
             "timing). The answer is the cheapest robust "
             "setting among these runs, not beyond them. Cost is "
             f"steps per simulated second (1 / dt); steps within {100 * x.get('tie_band', 0.1):g}% are a tie, broken by the "
             "fewest settings away from the engine's defaults, then the larger dt, then the wall-clock time (reported, "
             "never deciding by itself: on a busy machine it follows the load).", "", "## Answer", ""]
    lines += [line + "\n" for line in answer_sentences(result, ev)]
    lines += _frontier_markdown(result, list(figures or ()))
    if (check := result.extra.get("same_model")) is not None:
        lines += [f"## {_same_model_heading(check)}", "", check.sentence() + ".", "", _plain_md_table(_same_model_frame(check)),
                  ""]
    if text := snippet(result):
        lang = "xml" if text.lstrip().startswith("<") else "python"
        lines += ["## Paste", "", "```" + lang, text.rstrip(), "```", ""]
        lines += _check_markdown(result)
    figures = list(figures or ())
    md_figure = lambda name: [f"![{name}]({FIGURE_FILES[name]}.png)", "", f"*{CAPTIONS[name]}*", ""]  # noqa: E731
    for name in (n for n in figures if n in BESIDE_SNIPPET):
        lines += md_figure(name)
    cheaper = result.cheaper()
    lines += [f"## Cheaper or as cheap candidates that fail ({len(cheaper)})", ""]
    if len(cheaper) > LISTED_CANDIDATES:
        lines += [_closest_note(len(cheaper)), ""]
    lines += [_md_table(_candidates(cheaper.iloc[::-1].head(LISTED_CANDIDATES), result.extra.get("defaults", {}))) if len(cheaper)
              else "None: nothing cheaper was tried and failed.", ""]
    for name in (n for n in figures if n not in BESIDE_SNIPPET + IN_FRONTIER):
        lines += md_figure(name)
    listed, note = listed_candidates(result)
    lines += [f"## Every candidate tried ({len(result.table)})", "", note, "",
              _md_table(_candidates(listed, result.extra.get("defaults", {}))), ""]
    return "\n".join(lines)


def _same_model_heading(check) -> str:
    return f"The answers in {check.against}, the engine whose model {check.engine} steps"


def _same_model_frame(check) -> pd.DataFrame:
    """``tune.conformance``'s rows as the guide shows them: tolerances in percent, one column per engine's verdict."""
    t = check.table
    return pd.DataFrame({"answer": t["point"], "stick %": 100 * t["stick"], "restitution %": 100 * t["restitution"],
                         "dt": t["dt"], "settings": t["settings"], check.engine: t["verdict"], check.against: t["other_verdict"],
                         "episodes that disagree": [f"{d} of {n}" for d, n in zip(t["disagree"], t["episodes"])],
                         "largest sticking difference [s]": t["stick_difference_max"].map(_or_none),
                         "largest exit difference [s]": t["exit_difference_max"].map(_or_none),
                         "alike": t["same"].map({True: "yes", False: "no"})})


def _or_none(v: float):
    """A difference, or "none" where no episode has the event in both engines."""
    return "none" if pd.isna(v) else v


def _cell(column: str, v) -> str:
    """A frontier cell: settings as code, a cost as a whole number with thousands separators (3,003, not 3e+03)."""
    if column == "settings":
        return f"`{v}`"
    if column == "steps_per_sim_s" and isinstance(v, float) and math.isfinite(v):
        return f"{v:,.0f}"
    return fmt(v)


def _plain_md_table(frame: pd.DataFrame) -> str:
    """A table of plain cells (the frontier's) in Markdown: its own column names, settings as code."""
    rows = ["| " + " | ".join(_cell(c, v) for c, v in row.items()) + " |" for _, row in frame.iterrows()]
    return "\n".join(["| " + " | ".join(frame.columns) + " |", "| " + " | ".join("---" for _ in frame.columns) + " |", *rows])


def _md_table(frame: pd.DataFrame) -> str:
    head = "| " + " | ".join(CANDIDATE_COLUMNS[c] for c in frame.columns) + " |"
    rule = "| " + " | ".join("---" for _ in frame.columns) + " |"
    body = ["| " + " | ".join(f"`{v}`" if c == "settings" else fmt(v) for c, v in row.items()) + " |"
            for _, row in frame.iterrows()]
    return "\n".join([head, rule, *body])


def _html_table(frame: pd.DataFrame) -> str:
    text = {"stage", "settings", "verdict", "failed", "matches"}
    head = "".join(f'<th class="{"text" if c in text else "num"}">{html.escape(CANDIDATE_COLUMNS[c])}</th>' for c in frame.columns)
    rows = []
    for _, row in frame.iterrows():
        cells = []
        for c, v in row.items():
            if c == "verdict":
                style = f"background:{COLOURS.get(v, '#ffffff')};color:{text_colour(v) if v in COLOURS else '#000'}"
                cells.append(f'<td class="verdict" style="{style}">{html.escape(str(v))}</td>')
            elif c == "settings":
                cells.append(f'<td class="text"><code>{html.escape(str(v))}</code></td>')
            else:
                cells.append(f'<td class="{"text" if c in text else "num"}">{html.escape(fmt(v))}</td>')
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _plain_html_table(frame: pd.DataFrame) -> str:
    """A table of plain cells (the frontier's), numbers right-aligned, settings as code."""
    head = "".join(f'<th class="{"text" if c == "settings" else "num"}">{html.escape(c)}</th>' for c in frame.columns)
    rows = ["<tr>" + "".join(f'<td class="text"><code>{html.escape(str(v))}</code></td>' if c == "settings"
                             else f'<td class="num">{html.escape(fmt(v))}</td>' for c, v in row.items()) + "</tr>"
            for _, row in frame.iterrows()]
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _inline(markdown: str) -> str:
    """One Markdown sentence as HTML: ``code`` and **bold**, the rest escaped."""
    parts = markdown.split("`")
    out = "".join(f"<code>{html.escape(p)}</code>" if i % 2 else html.escape(p) for i, p in enumerate(parts))
    while "**" in out:
        out = out.replace("**", "<strong>", 1).replace("**", "</strong>", 1)
    return out


def guide_section_html(result, figures: dict[str, Figure] | None = None, ev=None,
                       png: dict[str, bytes] | None = None) -> str:
    """The guide as an HTML fragment (a report section, ``report --tune``): the same content, figures embedded
    (``png``: those already rendered, by name; the others are rendered here)."""
    esc = html.escape
    anchor = f"tuning-{esc(result.engine)}-{esc(result.scene.name)}"
    parts = [f'<h2 id="{anchor}">Tuning {esc(result.engine)} for {esc(result.scene.name)}</h2>',
             f'<p class="note">Tolerances: {esc(result.tolerance.describe())}; every episode must pass.</p>']
    if "searched" in result.extra:
        parts.append(f'<p class="note">Searched: {esc(searched_text(result))}; the answer is the cheapest robust setting '
                     "among these runs, not beyond them.</p>")
    parts += [f"<p>{_inline(s)}</p>" for s in answer_sentences(result, ev)]
    figures = figures if figures is not None else {"tradeoff": tradeoff_figure(result)}
    parts += ["<h3>Robust frontier</h3>", f"<p>{_inline(frontier_note(result))}</p>"]
    if result.frontier:
        parts.append(_plain_html_table(frontier_frame(result)))

    def html_figure(name: str) -> str:
        drawn = png[name] if png and name in png else figure_bytes(figures[name], "png")
        encoded = base64.b64encode(drawn).decode()
        wide = ' style="width: 100%"' if name in BESIDE_SNIPPET else ""  # the R(v) figure at the page's full width
        return (f'<figure><img alt="{esc(name)}"{wide} src="data:image/png;base64,{encoded}">'
                f"<figcaption>{esc(CAPTIONS[name])}</figcaption></figure>")

    parts += [html_figure(n) for n in figures if n in IN_FRONTIER]
    transfers = transfer_lines(result)
    if transfers:
        parts += ["<h3>What transfers</h3>", f"<p>{esc(TRANSFER_NOTE)}</p>",
                  "<ul>" + "".join(f"<li>{esc(line)}</li>" for line in transfers) + "</ul>"]
    if (check := result.extra.get("same_model")) is not None:
        parts += [f"<h3>{esc(_same_model_heading(check))}</h3>", f"<p>{esc(check.sentence())}.</p>",
                  _plain_html_table(_same_model_frame(check))]

    def code_block(code: str) -> str:
        return f'<pre style="white-space: pre-wrap; background: #f6f6f6; padding: 0.6em"><code>{esc(code)}</code></pre>'

    text = snippet(result)
    if text:  # the snippet and, under it at the page's full width, what those settings do at every impact speed
        parts += ["<h3>Paste</h3>", code_block(text)]
        parts += [html_figure(n) for n in figures if n in BESIDE_SNIPPET]
        check = measurement(result.engine)
        if check:
            parts += ["<h3>Check it in your own model</h3>", f"<p>{_inline(_check_text(result.engine))}</p>", code_block(check)]
    cheaper = result.cheaper()
    parts.append(f"<h3>Cheaper or as cheap candidates that fail ({len(cheaper)})</h3>")
    if len(cheaper) > LISTED_CANDIDATES:
        parts.append(f"<p>{_inline(_closest_note(len(cheaper)))}</p>")
    parts.append(_html_table(_candidates(cheaper.iloc[::-1].head(LISTED_CANDIDATES), result.extra.get("defaults", {})))
                 if len(cheaper) else "<p>None: nothing cheaper was tried and failed.</p>")
    parts += [html_figure(n) for n in figures if n not in BESIDE_SNIPPET + IN_FRONTIER]
    listed, note = listed_candidates(result)
    parts += [f"<h3>Every candidate tried ({len(result.table)})</h3>", f"<p>{_inline(note)}</p>",
              _html_table(_candidates(listed, result.extra.get("defaults", {})))]
    return "\n".join(parts)


def guide_html(result, figures: dict[str, Figure] | None = None, ev=None, section: str | None = None) -> str:
    """The guide as one self-contained HTML page, in the report page's style; ``section``: ``guide_section_html``'s
    fragment when the caller has already rendered it (its figures are encoded once)."""
    body = section if section is not None else guide_section_html(result, figures, ev)
    return html_page(f"tuning {result.engine} for {result.scene.name}", body)


def html_page(title: str, body: str) -> str:
    """``body`` (an HTML fragment) as one self-contained page in the report page's style; ``title`` is plain text."""
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f"<style>{PAGE_CSS}</style></head><body>{body}</body></html>")
