"""The engine-tuning guide: a recommendation a user can paste, with its evidence.

    >>> from chatterbench.comparisons.studies.tune import tune
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space={"dt": (1e-3,)}, workers=1, refine_steps=0)
    >>> text = guide_markdown(result)             # Markdown: snippet, errors, cost, failures nearby
    >>> text.splitlines()[0], "Recommended" in text
    ('# Tuning pybullet for bouncing-ball', True)
    >>> fig = tradeoff_figure(result)             # cost vs error of every candidate, the choice marked

The snippet is MJCF for MuJoCo (the model ``export_mjcf`` writes for the scene with the
recommended settings, whose ``<option>`` and ``solreflimit``/``solref`` attributes carry
the tuning) and ``setPhysicsEngineParameter``/``changeDynamics`` calls for PyBullet.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from chatterbench.comparisons.pipeline.vocabulary import COLOURS, rank
from chatterbench.engines.registry import adapter, make_settings

from .figures import figure_bytes

REFUSED_COLOUR = "#bdbdbd"  # a candidate whose settings the scene cannot run (not a verdict)


def _settings_of(result, row):
    overrides = [f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in row.items()
                 if "." in k and k.split(".")[0] == result.engine]
    return make_settings(result.engine, float(row["dt"]), overrides)


def snippet(result, row: dict) -> str:
    """Paste-able settings for the candidate ``row``: MJCF (MuJoCo) or Python (PyBullet)."""
    return adapter(result.engine).snippet(result.scene, _settings_of(result, row))


def tradeoff_figure(result) -> Figure:
    """Cost per simulated second against the timing score (worst timing error over its tolerance), every
    candidate, the choice marked; candidates with no timing error measured sit on the top edge."""
    table = result.table
    fig = Figure(figsize=(8, 5), layout="constrained")
    ax = fig.subplots()
    score = table["timing_score"]
    top = float(np.nanmax(score)) * 2 if score.notna().any() else 10.0
    for verdict, grp in sorted(table.groupby("verdict"), key=lambda g: rank(g[0])):
        y = grp["timing_score"].fillna(top)
        ax.scatter(grp["cost_per_sim_s"], y, s=28, color=COLOURS.get(verdict, REFUSED_COLOUR), label=verdict,
                   marker="o" if verdict == "match" else "x")
    ax.axhline(1.0, color="0.3", ls="--", lw=1, label="tolerance")
    if result.best is not None:
        ax.scatter([result.best["cost_per_sim_s"]], [result.best["timing_score"]], s=220, facecolors="none",
                   edgecolors="black", linewidths=2, label="recommended")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall-clock s per simulated s")
    ax.set_ylabel("worst timing error / its tolerance")
    ax.set_title(f"tune {result.engine} on {result.scene.name}: every candidate")
    ax.legend(fontsize=8)
    return fig


def _fmt(v) -> str:
    return "nan" if isinstance(v, float) and math.isnan(v) else (f"{v:.3g}" if isinstance(v, float) else str(v))


def guide_markdown(result) -> str:
    """The guide as Markdown (see the module docstring)."""
    lines = [f"# Tuning {result.engine} for {result.scene.name}", ""]
    lines.append(f"Tolerances: {result.tolerance.describe()}; every episode.")
    lines.append("")
    table = result.table
    if result.best is None:
        lines.append("**No candidate met the tolerance.**")
        if result.best_reachable is not None:
            b = result.best_reachable
            lines.append(f"Best reachable (smallest timing score): `{b['settings']}` with worst exit error {_fmt(b['exit_error_max'])} s "
                         f"and worst sticking error {_fmt(b['stick_error_max'])} s, timing score {_fmt(b['timing_score'])} "
                         f"(verdict {b['verdict']}), at {_fmt(b['cost_per_sim_s'])} s per simulated s.")
    else:
        b = result.best
        lines += [f"**Recommended:** `{b['settings']}`", "",
                  f"- worst |exit error| {_fmt(b['exit_error_max'])} s, worst |sticking start error| (Zeno point) "
                  f"{_fmt(b['stick_error_max'])} s, {b['n_match']} of {b['n_episodes']} episodes `match`;",
                  f"- cost {_fmt(b['cost_per_sim_s'])} wall-clock s per simulated s.", "",
                  "Paste:", "", "```" + ("xml" if result.engine == "mujoco" else "python"), snippet(result, b).rstrip(), "```", ""]
        # nearby settings that fail: the cheaper candidates around the choice
        cheaper = table[(table["cost_per_sim_s"] < b["cost_per_sim_s"]) & (table["verdict"] != "match")]
        if len(cheaper):
            lines += ["Cheaper settings that fail, and how:", "",
                      "| settings | verdict | stick error / chatter | exit error / sliding | restitution error | cost |",
                      "| --- | --- | --- | --- | --- | --- |"]
            for r in cheaper.head(8).itertuples():
                lines.append(f"| `{r.settings}` | {r.verdict} | {_fmt(r.stick_error_rel_max)} | {_fmt(r.exit_error_rel_max)} | "
                             f"{_fmt(r.restitution_error_max)} | {_fmt(r.cost_per_sim_s)} |")
            lines.append("")
    lines += ["Every candidate tried:", "", "| stage | settings | verdict | matches | worst exit error [s] | worst stick error [s] | cost |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in table.itertuples():
        lines.append(f"| {r.stage} | `{r.settings}` | {r.verdict} | {r.n_match}/{r.n_episodes} | "
                     f"{_fmt(r.exit_error_max)} | {_fmt(r.stick_error_max)} | {_fmt(r.cost_per_sim_s)} |")
    return "\n".join(lines) + "\n"


def guide_section_html(result) -> str:
    """The guide as an HTML fragment (a report section): the same content, figure embedded."""
    import base64
    import html

    esc = html.escape
    parts = [f'<h2 id="tuning-{esc(result.engine)}-{esc(result.scene.name)}">Tuning {esc(result.engine)} for {esc(result.scene.name)}</h2>',
             f"<p>Tolerances: {esc(result.tolerance.describe())}; every episode.</p>"]
    if result.best is None:
        parts.append("<p><strong>No candidate met the tolerance.</strong></p>")
        if result.best_reachable is not None:
            b = result.best_reachable
            parts.append(f"<p>Best reachable: <code>{esc(b['settings'])}</code>, worst exit error {_fmt(b['exit_error_max'])} s, "
                         f"worst sticking error {_fmt(b['stick_error_max'])} s ({esc(str(b['verdict']))}).</p>")
    else:
        b = result.best
        parts.append(f"<p><strong>Recommended:</strong> <code>{esc(b['settings'])}</code>: worst |exit error| "
                     f"{_fmt(b['exit_error_max'])} s, worst |sticking start error| {_fmt(b['stick_error_max'])} s, "
                     f"{b['n_match']} of {b['n_episodes']} episodes match, {_fmt(b['cost_per_sim_s'])} s per simulated s.</p>")
        parts.append(f"<pre>{esc(snippet(result, b))}</pre>")
    fig = tradeoff_figure(result)
    png = base64.b64encode(figure_bytes(fig, "png")).decode()
    parts.append(f'<img alt="tuning trade-off" src="data:image/png;base64,{png}">')
    shown = result.table[["stage", "settings", "verdict", "n_match", "n_episodes", "exit_error_max", "stick_error_max", "cost_per_sim_s"]]
    parts.append(shown.to_html(index=False, float_format=lambda v: f"{v:.3g}", border=0))
    return "\n".join(parts)


def guide_html(result) -> str:
    """The guide as one self-contained HTML page."""
    import html

    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>tuning {html.escape(result.engine)} for {html.escape(result.scene.name)}</title></head><body>"
            + guide_section_html(result) + "</body></html>")
