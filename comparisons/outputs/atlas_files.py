"""The atlas's tables and charts, from its finished cases (``studies.atlas``).

    >>> from chatterbench.comparisons.outputs.atlas_files import atlas_frame
    >>> case = {"scene": "bouncing-ball", "engine": "drake", "engine_version": "1.51.1", "status": "failed",
    ...         "message": "RuntimeError: boom", "wall_s": 1.5, "runs": 0}
    >>> atlas_frame([case])[["scene", "engine", "status", "robust_at_asked", "frontier_points"]].to_dict("records")
    [{'scene': 'bouncing-ball', 'engine': 'drake', 'status': 'failed', 'robust_at_asked': False, 'frontier_points': 0}]

``atlas_frame``: one row per case (``ATLAS_COLUMNS``): whether a band-robust setting meets
the asked tolerances, the tightest tolerances reached robustly on each axis (the sticking
tolerance, exit and first impact moving with it; the restitution tolerance |e / R - 1|), the
written setting (the asked tolerances' robust answer, else the tightest robust frontier
point), its cost in steps per simulated second, its contact's *persistence* after each stick
(the largest open share of the rest, onsets per second), the frontier's size, the case's runs
and wall time [s]. ``frontier_frame``: one row per frontier point (``FRONTIER_COLUMNS``): the
cheapest band-robust setting at each ladder point it reaches. Each scene's chart is the
work-precision chart of robust settings (``frontier_chart.frontier_figure``, one line per
engine); the overview (``overview_figure``) is a scene x engine map of the tightest sticking
tolerance reached robustly, each cell naming it and the cost of the robust setting at the asked tolerances.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Iterable, Sequence

import pandas as pd
from matplotlib.figure import Figure

from .frontier_chart import frontier_figure
from ..pipeline.inert_text import md_escape

ATLAS_COLUMNS = ["scene", "engine", "status", "robust_at_asked", "tightest_stick", "tightest_restitution", "written",
                 "dt", "settings", "cost_steps_per_s", "open_fraction", "onsets_per_s", "frontier_points", "runs",
                 "wall_s", "engine_version", "message"]
FRONTIER_COLUMNS = ["scene", "engine", "stick", "restitution", "cost_steps_per_s", "dt", "settings", "margin",
                    "margin_check", "band_runs", "band_passed", "open_fraction", "onsets_per_s"]


def _settings_text(settings: dict[str, Any] | None) -> str:
    return ", ".join(f"{k}={v}" for k, v in (settings or {}).items())


def _num(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and v is not None else math.nan


def atlas_frame(cases: Iterable[dict[str, Any]]) -> pd.DataFrame:
    """One row per case (module docstring), scene then engine as the cases come."""
    rows = []
    for c in cases:
        rec = c.get("recommended") or {}
        tight = rec.get("tightest") or {}
        rest = rec.get("persistence") or {}
        written = rec.get("written_tolerances") or {}
        robust_written = bool(rec.get("robust")) or bool(rec.get("frontier"))
        rows.append({"scene": c["scene"], "engine": c["engine"], "status": c["status"],
                     "robust_at_asked": bool(rec.get("robust", False)),
                     "tightest_stick": _num(tight.get("stick")), "tightest_restitution": _num(tight.get("restitution")),
                     "written": (f"stick {100 * written['stick']:.3g}%, restitution {100 * written['restitution']:.3g}%"
                                 if written and robust_written else ""),
                     "dt": _num(rec.get("dt")) if robust_written else math.nan,
                     "settings": _settings_text(rec.get("settings")) if robust_written else "",
                     "cost_steps_per_s": _num(rec.get("cost_steps_per_s")) if robust_written else math.nan,
                     "open_fraction": _num(rest.get("open_fraction")) if robust_written else math.nan,
                     "onsets_per_s": _num(rest.get("onsets_per_s")) if robust_written else math.nan,
                     "frontier_points": len(rec.get("frontier") or []), "runs": int(c.get("runs") or 0),
                     "wall_s": _num(c.get("wall_s")), "engine_version": str(c.get("engine_version", "")),
                     "message": str(c.get("message", ""))})
    return pd.DataFrame(rows, columns=ATLAS_COLUMNS).astype({"robust_at_asked": bool, "frontier_points": int, "runs": int})


def frontier_frame(cases: Iterable[dict[str, Any]]) -> pd.DataFrame:
    """One row per frontier point of every case (module docstring), each case's cheapest first."""
    rows = []
    for c in cases:
        for e in (c.get("recommended") or {}).get("frontier") or []:
            checked, rest = e.get("checked") or {}, e.get("persistence") or {}
            rows.append({"scene": c["scene"], "engine": c["engine"], "stick": _num(e["tolerances"]["stick"]),
                         "restitution": _num(e["tolerances"]["restitution"]),
                         "cost_steps_per_s": _num(e["cost_steps_per_s"]), "dt": _num(e["dt"]),
                         "settings": _settings_text(e.get("settings")), "margin": _num(e.get("margin")),
                         "margin_check": str(e.get("margin_check") or ""),
                         "band_runs": int(checked.get("runs") or 0), "band_passed": _num(checked.get("passed")),
                         "open_fraction": _num(rest.get("open_fraction")), "onsets_per_s": _num(rest.get("onsets_per_s"))})
    return pd.DataFrame(rows, columns=FRONTIER_COLUMNS)


def scene_frontiers(cases: Iterable[dict[str, Any]], scene: str) -> dict[str, list[dict[str, Any]]]:
    """``frontier_figure``'s input for ``scene``: engine -> its frontier entries (a failed case: none)."""
    return {c["engine"]: list((c.get("recommended") or {}).get("frontier") or []) for c in cases if c["scene"] == scene}


def scene_figure(cases: Sequence[dict[str, Any]], scene: str, asked: dict[str, float] | None) -> Figure:
    """A scene's work-precision chart of robust settings, one line per engine; its points labelled where at most two
    engines have any (more would cover each other: ``frontier.csv`` and the table list them)."""
    frontiers = scene_frontiers(cases, scene)
    return frontier_figure(frontiers, scene, asked=asked, labels=sum(1 for f in frontiers.values() if f) <= 2)


LEVELS = (0.01, 0.02, 0.05, 0.1, 0.2)  # the ladder's sticking levels: the overview's colour steps


def overview_figure(atlas: pd.DataFrame) -> Figure:
    """The scene x engine map (module docstring): colour the tightest sticking tolerance reached robustly (darker:
    tighter), grey where nothing is robust or the case failed; text: the cost of the robust setting at the asked
    tolerances [steps per simulated s] (or none) and the tightest tolerances reached on each axis."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    scenes = list(dict.fromkeys(atlas["scene"]))
    engines = list(dict.fromkeys(atlas["engine"]))
    fig = Figure(figsize=(max(2.0 * len(engines) + 2.2, 7.0), 1.0 * max(len(scenes), 1) + 1.6), layout="constrained")
    ax = fig.subplots()
    cmap = ListedColormap(["#08519c", "#3182bd", "#6baed6", "#9ecae1", "#c6dbef"])
    norm = BoundaryNorm([0.005, 0.015, 0.03, 0.075, 0.15, 0.3], cmap.N)
    grid = [[math.nan] * len(engines) for _ in scenes]
    for _, r in atlas.iterrows():
        i, j = scenes.index(r["scene"]), engines.index(r["engine"])
        grid[i][j] = r["tightest_stick"]
        if r["status"] != "ok":
            text, colour = "the case failed", "0.35"
        elif math.isnan(r["tightest_stick"]):
            text, colour = "nothing robust", "0.35"
        else:
            asked = (f"asked: {r['cost_steps_per_s']:,.0f} steps/s" if r["robust_at_asked"]
                     else "asked: none robust")
            text = (f"{asked}\ntightest: stick {100 * r['tightest_stick']:.3g}%,\n"
                    f"restitution {100 * r['tightest_restitution']:.3g}%")
            colour = "white" if r["tightest_stick"] <= 0.02 else "black"
        ax.text(j, i, text, ha="center", va="center", fontsize=7, color=colour)
    import numpy as np

    done = {(r["scene"], r["engine"]) for _, r in atlas.iterrows()}
    for i, scene in enumerate(scenes):
        for j, engine in enumerate(engines):
            if (scene, engine) not in done:
                ax.text(j, i, "not in the atlas", ha="center", va="center", fontsize=7, color="0.45", style="italic")
    data = np.ma.masked_invalid(np.array(grid, dtype=float))
    ax.set_facecolor("0.88")
    mesh = ax.pcolormesh(np.arange(len(engines) + 1) - 0.5, np.arange(len(scenes) + 1) - 0.5, data, cmap=cmap,
                         norm=norm, edgecolors="white", linewidth=2)
    ax.set_xticks(range(len(engines)), engines, fontsize=8)
    ax.set_yticks(range(len(scenes)), scenes, fontsize=8)
    ax.set_xlim(-0.5, len(engines) - 0.5)
    ax.set_ylim(len(scenes) - 0.5, -0.5)
    ax.tick_params(length=0)
    bar = fig.colorbar(mesh, ax=ax, ticks=LEVELS, shrink=0.9)
    bar.ax.set_yticklabels([f"{100 * v:g}%" for v in LEVELS], fontsize=7)
    bar.set_label("tightest sticking tolerance\nreached band-robustly", fontsize=7)
    fig.suptitle("The atlas: the tightest band-robust tolerances of each engine on each scene,\n"
                 "and the cost of the robust setting at the asked tolerances (grey: nothing robust, or failed)", fontsize=9)
    return fig


def _pct(v: float) -> str:
    return "-" if not math.isfinite(v) else f"{100 * v:.3g}%"


def _cost(v: float) -> str:
    return "-" if not math.isfinite(v) else f"{v:,.0f}"


TABLE_HEADERS = ("scene", "engine", "robust at the asked tolerances", "tightest stick", "tightest restitution",
                 "written setting", "steps/s", "open share after the stick", "onsets/s", "frontier points", "runs",
                 "wall [s]")


def table_cells(atlas: pd.DataFrame) -> list[list[str]]:
    """The atlas table's rows as plain text (``TABLE_HEADERS``), for Markdown and HTML to escape each their way."""
    rows = []
    for _, r in atlas.iterrows():
        if r["status"] != "ok":
            rows.append([r["scene"], r["engine"], f"failed: {r['message']}", *["-"] * 6, "0", str(r["runs"]),
                         f"{r['wall_s']:.0f}"])
            continue
        setting = (f"dt={r['dt']:g}" + (f", {r['settings']}" if r["settings"] else "")) if r["written"] else "-"
        rows.append([r["scene"], r["engine"], "yes" if r["robust_at_asked"] else "no", _pct(r["tightest_stick"]),
                     _pct(r["tightest_restitution"]), setting, _cost(r["cost_steps_per_s"]), _number(r["open_fraction"]),
                     _number(r["onsets_per_s"]), str(r["frontier_points"]), str(r["runs"]), f"{r['wall_s']:.0f}"])
    return rows


POINT_HEADERS = ("scene", "engine", "frontier points: stick / restitution tolerance, steps per simulated second")


def point_cells(cases: Iterable[dict[str, Any]]) -> list[list[str]]:
    """Per case with a frontier, its points cheapest first as ``5/2%: 425`` (the charts leave them unlabelled where
    many engines share one)."""
    rows = []
    for c in cases:
        points = [f"{100 * e['tolerances']['stick']:g}/{100 * e['tolerances']['restitution']:g}%: "
                  f"{e['cost_steps_per_s']:,.0f}" for e in (c.get("recommended") or {}).get("frontier") or []]
        if points:
            rows.append([c["scene"], c["engine"], "; ".join(points)])
    return rows


def points_markdown(cases: Iterable[dict[str, Any]]) -> str:
    """``point_cells`` as a Markdown table, every cell escaped."""
    lines = ["| " + " | ".join(POINT_HEADERS) + " |", "| --- | --- | --- |"]
    return "\n".join(lines + ["| " + " | ".join(md_escape(c) for c in row) + " |" for row in point_cells(cases)])


def atlas_table_markdown(atlas: pd.DataFrame) -> str:
    """The atlas table in Markdown, every cell escaped (``md_escape``)."""
    lines = ["| " + " | ".join(TABLE_HEADERS) + " |",
             "| --- | --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    lines += ["| " + " | ".join(md_escape(c) for c in row) + " |" for row in table_cells(atlas)]
    return "\n".join(lines)


def atlas_markdown(atlas: pd.DataFrame, provenance: dict[str, Any], figures: Sequence[str] = ()) -> str:
    """The atlas as Markdown: its provenance, its charts, then one table row per case, every input field escaped."""
    lines = ["# The atlas: band-robust frontiers", "", md_escape(provenance_sentence(provenance)), ""]
    lines += [f"![{md_escape(Path(f).stem)}]({f})" for f in figures] + ([""] if figures else [])
    return "\n".join(lines) + atlas_table_markdown(atlas) + "\n"


def atlas_file_markdown(atlas: pd.DataFrame, cases: Sequence[dict[str, Any]], provenance: dict[str, Any],
                        figures: Sequence[str]) -> str:
    """atlas.md: ``atlas_markdown`` and each case's frontier points."""
    return atlas_markdown(atlas, provenance, figures) + "\n" + points_markdown(cases) + "\n"


def _number(v: float) -> str:
    """A share or a rate in 3 digits; "-" where none was measured."""
    return "-" if not math.isfinite(v) else f"{v:.3g}"


def provenance_sentence(p: dict[str, Any]) -> str:
    """Where the atlas comes from, in one sentence: the command, the machine, the date, the versions, the wall time."""
    versions = ", ".join(f"{k} {v}" for k, v in (p.get("versions") or {}).items())
    return (f"Made by: {p.get('command', '?')} ({p.get('code', 'code version not recorded')}); on {p.get('machine', '?')}, started {p.get('started', '?')}"
            + _wall_words(p)
            + f"; versions: {versions}; tolerances asked: "
            + json.dumps({k: v for k, v in ((p.get("search") or {}).get("tolerances") or {}).items()
                          if k in ("stick", "exit", "first_impact", "restitution")}))


def _wall_words(p: dict[str, Any]) -> str:
    """The atlas's wall time in words: its own (``elapsed_s``, when recorded) and its cases' summed (``wall_s``),
    which overlap when cases ran side by side (``cases_at_once``)."""
    wall, elapsed, at_once = p.get("wall_s"), p.get("elapsed_s"), p.get("cases_at_once")
    cases = (f"{wall / 60:.1f} min of wall time over its cases" if _real(wall) else "")
    if not _real(elapsed):
        return f", {cases}" if cases else ""
    side = f", up to {at_once} side by side" if isinstance(at_once, int) and at_once > 1 else ""
    return f", {elapsed / 60:.1f} min of wall time" + (f" ({cases}{side})" if cases else "")


def _real(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def write_atlas_files(out: Path, cases: Sequence[dict[str, Any]], provenance: dict[str, Any]) -> list[str]:
    """The atlas's tables and charts under ``out`` (``atlas.parquet``/``.csv``, ``frontier.parquet``/``.csv``,
    ``atlas.md``, ``figures/SCENE.png/.svg`` and ``figures/overview.png/.svg``); returns the names written."""
    from chatterbench.comparisons.pipeline.atomic import write_frame, write_text

    from .figures import write_figure

    atlas, frontier = atlas_frame(cases), frontier_frame(cases)
    written = []
    for name, frame in (("atlas", atlas), ("frontier", frontier)):
        for suffix in ("parquet", "csv"):
            write_frame(out / f"{name}.{suffix}", frame)
            written.append(f"{name}.{suffix}")
    asked = (provenance.get("search") or {}).get("tolerances")
    figures = []
    if len(atlas):
        write_figure(overview_figure(atlas), out / "figures", "overview")
        figures.append("figures/overview.png")
    for scene in dict.fromkeys(atlas["scene"]):
        write_figure(scene_figure(cases, scene, asked), out / "figures", f"frontier-{scene}")
        figures.append(f"figures/frontier-{scene}.png")
    write_text(out / "atlas.md", atlas_file_markdown(atlas, cases, provenance, figures))
    return written + ["atlas.md"] + [f.replace(".png", ".png/.svg") for f in figures]


def grid_markdown(cases: Iterable[dict[str, Any]], scenes: Sequence[str], engines: Sequence[str],
                  asked: str = "5%/5%") -> str:
    """The atlas as one Markdown grid, a row per scene and a column per engine (the README's table). A cell is the
    case's tightest band-robust point, ``stick / restitution`` tolerance, then the steps per simulated second of its
    written setting: ``ASKED at N`` where it is robust at the asked tolerances, ``written at N`` where the written
    setting is the tightest robust point instead; ``none`` where nothing is robust, ``failed`` where the case failed,
    ``not run`` where the atlas has no such case. Every cell escaped."""
    by = {(c["scene"], c["engine"]): c for c in cases}

    def cell(scene: str, engine: str) -> str:
        c = by.get((scene, engine))
        if c is None:
            return "not run"
        if c.get("status") != "ok":
            return "failed"
        rec = c.get("recommended") or {}
        tight = rec.get("tightest") or {}
        if tight.get("stick") is None:
            return "none"
        where = asked if rec.get("robust") else "written"
        return (f"{_pct(tight['stick'])} / {_pct(tight['restitution'])}; "
                f"{where} at {_cost(_num(rec.get('cost_steps_per_s')))}")

    lines = ["| scene | " + " | ".join(md_escape(e) for e in engines) + " |",
             "|---|" + "---|" * len(engines)]
    lines += [f"| {md_escape(s)} | " + " | ".join(md_escape(cell(s, e)) for e in engines) + " |" for s in scenes]
    return "\n".join(lines)
