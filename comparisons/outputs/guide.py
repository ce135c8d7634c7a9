"""The tuning guide: the calibration answer for a scene and tolerances, the settings to paste, and the evidence.

    >>> from chatterbench.comparisons.studies.tune import tune
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space={"dt": (1e-3,)}, workers=1, refine_steps=0)
    >>> text = guide_markdown(result)             # Markdown: answer, snippet, cheaper failures, every candidate
    >>> text.splitlines()[0], "Recommended" in text
    ('# Tuning pybullet for bouncing-ball', True)
    >>> "<style>" in guide_html(result)           # one self-contained page, styled like the report
    True

The answer: the recommended candidate (``studies.tune``: the fewest steps per simulated
second that pass, ties to the simplest) or, when nothing passes, the best reachable one
(most matching episodes, then the smallest worst error over its tolerance); each check's
worst error over its tolerance; every failing candidate no more expensive than it, with the
check that failed and its measure; the snippet a user pastes (``EngineAdapter.snippet``:
MJCF attributes for MuJoCo, PyBullet calls); the figures (``guide_figures``: the trade-off of
every candidate, and from the chosen settings' evidence, ``studies.tune_evidence``, the
chatter ladder on the scene and the effective restitution against impact speed); every
candidate tried. Markdown names the figures by file (``FIGURE_FILES``, written beside it
by ``chatterbench tune --out``); HTML embeds them.
"""

from __future__ import annotations

import base64
import html
import math

import pandas as pd
from matplotlib.figure import Figure

from chatterbench.comparisons.pipeline.vocabulary import COLOURS, text_colour
from chatterbench.comparisons.studies.tune import short_label
from chatterbench.comparisons.studies.tune_checks import CHECKS
from chatterbench.engines.registry import adapter

from .figures import figure_bytes
from .ladder import ladder_figure
from .style import PAGE_CSS  # the report page's style sheet: the guide reads like the report
from .restitution_curve import restitution_curve_figure
from .tradeoff import tradeoff_figure

FIGURE_FILES = {"tradeoff": "tradeoff", "ladder": "ladder", "restitution_curve": "restitution_curve"}
BESIDE_SNIPPET = ("restitution_curve",)  # what the pasted settings do at every impact speed, drawn right after them
CAPTIONS = {
    "tradeoff": "Every candidate: cost (steps per simulated second) against its worst error over its tolerance; "
                "colour the verdict, shape the check that failed worst, the chosen one circled.",
    "ladder": "The chosen settings on the scene: each impact's incoming speed per wall visit, the reference's "
              "geometric ladder to its Zeno point and the engine's impacts over it, where each starts sticking.",
    "restitution_curve": "The chosen settings' effective restitution against impact speed: one strike per speed "
                         "(the contact law alone, line) and the scene's resolved impacts (numbered markers).",
}
CANDIDATE_COLUMNS = {"stage": "stage", "settings": "settings (dt; what differs from the defaults)", "verdict": "verdict", "matches": "matches",
                     "worst_ratio": "worst error / tolerance", "failed": "what failed",
                     "steps_per_sim_s": "steps per simulated s", "cost_per_sim_s": "wall s per simulated s",
                     "cost_repeats": "timed runs"}


def _fmt(v) -> str:
    if isinstance(v, float):
        return "inf" if math.isinf(v) else ("nan" if math.isnan(v) else f"{v:.3g}")
    return str(v)


def snippet(result) -> str:
    """What a user pastes for the chosen candidate: MJCF (MuJoCo) or Python (PyBullet); "" when none ran."""
    from chatterbench.comparisons.studies.tune_evidence import chosen_settings

    settings = chosen_settings(result)
    return "" if settings is None else adapter(result.engine).snippet(result.scene, settings)


def guide_figures(result, ev=None) -> dict[str, Figure]:
    """The guide's figures by name (``FIGURE_FILES``): the trade-off, and with the evidence ``ev`` the ladder and R(v)."""
    figs = {"tradeoff": tradeoff_figure(result)}
    if ev is not None:
        figs["ladder"] = ladder_figure(ev.comparison)
        if ev.curve is not None:
            figs["restitution_curve"] = restitution_curve_figure(ev.curve, ev.impacts, result.scene.name)
    return figs


def _candidates(frame: pd.DataFrame, defaults: dict) -> pd.DataFrame:
    """The guide's candidate table: the settings as dt and what differs from the defaults (the CSV has them all)."""
    out = frame.assign(matches=[f"{m}/{n}" for m, n in zip(frame["n_match"], frame["n_episodes"])],
                       settings=[short_label(r, defaults) for _, r in frame.iterrows()])
    out["failed"] = out["failed"].replace("", "-")
    return out[list(CANDIDATE_COLUMNS)]


def _answer(result) -> list[str]:
    """The answer's sentences (Markdown; the HTML page converts the code spans)."""
    c = result.chosen
    if c is None:
        return ["No candidate ran: every one was refused (see the table)."]
    cost = (f"{_fmt(c['steps_per_sim_s'])} steps per simulated second, {_fmt(c['cost_per_sim_s'])} s of wall clock "
            f"per simulated second (the least of {int(c['cost_repeats'])} timed run{'s' if c['cost_repeats'] != 1 else ''})")
    if result.best is not None:
        head = [f"**Recommended:** `{c['settings']}`: all {c['n_episodes']} episodes pass ({c['verdict']}); cost {cost}."]
    else:
        head = ["**No candidate passes these tolerances.**",
                f"Best reachable (most matching episodes, then the smallest worst error over its tolerance): `{c['settings']}`, "
                f"{c['n_match']} of {c['n_episodes']} episodes match, verdict {c['verdict']}; it fails: {c['failed']}; cost {cost}."]
    ratios = ", ".join(f"{short} {_fmt(c.get(f'{name}_ratio', math.nan))}" for name, (*_, short) in CHECKS.items())
    return head + [f"Each check's worst error over its tolerance (1 = at the tolerance): {ratios}."]


def guide_markdown(result, figures: dict | None = None) -> str:
    """The guide as Markdown (module docstring); ``figures``: names of the figure files written beside it."""
    x = result.extra
    space = x.get("space", {})
    searched = "; ".join(f"{k} in ({', '.join(f'{v:.6g}' if isinstance(v, float) else str(v) for v in vals)})"
                         for k, vals in space.items())
    lines = [f"# Tuning {result.engine} for {result.scene.name}", "",
             f"Tolerances: {result.tolerance.describe()}; every episode must pass.", "",
             f"Searched: {searched}; {len(result.table)} candidates in {_fmt(x.get('wall_time_s', math.nan))} s. Cost is "
             f"steps per simulated second (1 / dt); steps within {100 * x.get('tie_band', 0.1):g}% are a tie, broken by the "
             "fewest settings away from the engine's defaults, then the larger dt, then the wall-clock time (reported, "
             "never deciding by itself: on a busy machine it follows the load).", "", "## Answer", ""]
    lines += [line + "\n" for line in _answer(result)]
    text = snippet(result)
    if text:
        lang = "xml" if text.lstrip().startswith("<") else "python"
        lines += ["## Paste", "", "```" + lang, text.rstrip(), "```", ""]
    figures = list(figures or ())
    md_figure = lambda name: [f"![{name}]({FIGURE_FILES[name]}.png)", "", f"*{CAPTIONS[name]}*", ""]  # noqa: E731
    for name in (n for n in figures if n in BESIDE_SNIPPET):
        lines += md_figure(name)
    cheaper = result.cheaper()
    lines += [f"## Cheaper or as cheap candidates that fail ({len(cheaper)})", ""]
    lines += [_md_table(_candidates(cheaper, result.extra.get("defaults", {}))) if len(cheaper) else "None: nothing cheaper was tried and failed.", ""]
    for name in (n for n in figures if n not in BESIDE_SNIPPET):
        lines += md_figure(name)
    lines += [f"## Every candidate tried ({len(result.table)})", "", _md_table(_candidates(result.table, result.extra.get("defaults", {}))), ""]
    return "\n".join(lines)


def _md_table(frame: pd.DataFrame) -> str:
    head = "| " + " | ".join(CANDIDATE_COLUMNS[c] for c in frame.columns) + " |"
    rule = "| " + " | ".join("---" for _ in frame.columns) + " |"
    body = ["| " + " | ".join(f"`{v}`" if c == "settings" else _fmt(v) for c, v in row.items()) + " |"
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
                cells.append(f'<td class="{"text" if c in text else "num"}">{html.escape(_fmt(v))}</td>')
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _inline(markdown: str) -> str:
    """One Markdown sentence as HTML: ``code`` and **bold**, the rest escaped."""
    parts = markdown.split("`")
    out = "".join(f"<code>{html.escape(p)}</code>" if i % 2 else html.escape(p) for i, p in enumerate(parts))
    while "**" in out:
        out = out.replace("**", "<strong>", 1).replace("**", "</strong>", 1)
    return out


def guide_section_html(result, figures: dict[str, Figure] | None = None) -> str:
    """The guide as an HTML fragment (a report section, ``report --tune``): the same content, figures embedded."""
    esc = html.escape
    anchor = f"tuning-{esc(result.engine)}-{esc(result.scene.name)}"
    parts = [f'<h2 id="{anchor}">Tuning {esc(result.engine)} for {esc(result.scene.name)}</h2>',
             f'<p class="note">Tolerances: {esc(result.tolerance.describe())}; every episode must pass.</p>']
    parts += [f"<p>{_inline(s)}</p>" for s in _answer(result)]
    figures = figures if figures is not None else {"tradeoff": tradeoff_figure(result)}

    def html_figure(name: str) -> str:
        png = base64.b64encode(figure_bytes(figures[name], "png")).decode()
        return (f'<figure><img alt="{esc(name)}" src="data:image/png;base64,{png}">'
                f"<figcaption>{esc(CAPTIONS[name])}</figcaption></figure>")

    text = snippet(result)
    if text:  # the snippet and, beside it, what those settings do at every impact speed
        beside = "".join(f'<div style="flex: 1 1 45%; min-width: 0">{html_figure(n)}</div>' for n in figures if n in BESIDE_SNIPPET)
        parts += ["<h3>Paste</h3>", '<div style="display: flex; gap: 1.5em; align-items: flex-start">'
                  f'<pre style="flex: 1 1 55%; white-space: pre-wrap; background: #f6f6f6; padding: 0.6em"><code>{esc(text)}</code></pre>'
                  f"{beside}</div>"]
    cheaper = result.cheaper()
    parts.append(f"<h3>Cheaper or as cheap candidates that fail ({len(cheaper)})</h3>")
    parts.append(_html_table(_candidates(cheaper, result.extra.get("defaults", {}))) if len(cheaper) else "<p>None: nothing cheaper was tried and failed.</p>")
    parts += [html_figure(n) for n in figures if n not in BESIDE_SNIPPET]
    parts += [f"<h3>Every candidate tried ({len(result.table)})</h3>", _html_table(_candidates(result.table, result.extra.get("defaults", {})))]
    return "\n".join(parts)


def guide_html(result, figures: dict[str, Figure] | None = None) -> str:
    """The guide as one self-contained HTML page, in the report page's style."""
    title = f"tuning {html.escape(result.engine)} for {html.escape(result.scene.name)}"
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{title}</title>'
            f"<style>{PAGE_CSS}</style></head><body>" + guide_section_html(result, figures) + "</body></html>")
