"""The comparison report: every scene on every engine, in one self-contained HTML page and a Markdown twin.

    >>> from chatterbench.comparisons.outputs.report import build_report
    >>> from chatterbench.engines.registry import settings_for
    >>> report = build_report(["bouncing-ball"], engines=("pybullet",), dt=1e-3, progress=None,
    ...                       settings=settings_for(("pybullet",), 1e-3))
    >>> report.summary[["scene", "engine", "verdict"]].values.tolist()    # on time, then its contact keeps opening
    [['bouncing-ball', 'pybullet', 'buzz']]

``report_page.py`` writes it (``write_report``).

``index.html`` opens with the summary table (scene x engine: verdict, episodes matched,
worst exit and sticking errors, cost), then per scene the time-series chart, the chatter
ladder, the per-episode error figure, the episode table and the reference cross-check (Siconos
against Feigin's model, ``pipeline.cross_check``; or why it did not run), then, when a sweep dataset is given, its work-precision chart and stability
maps, and ends with what produced it (engine versions and settings, reference chatter
modes, tolerances, machine, date, command).

Promises: ``index.html`` is one file that needs nothing else: figures are base64 PNG
``data:`` URIs, the style sheet is inline, there is no script and no network address.
``report.md`` carries the same tables (no figures) for pasting into issues and pull
requests. The summary's columns are the sweep rows' (``pipeline.summary``), so a number in
the report is the number a gate (``ci/gate.py``) checks; its errors are signed
(``summary.SIGNED_COLUMNS``: the worst by magnitude, with its sign, whose magnitude is the
gate's ``_max`` metric), so early is told from late.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any, Callable, Mapping, Sequence

import pandas as pd

from chatterbench.engines.registry import DEFAULT_ENGINES
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import SceneError, load_scene

from chatterbench.comparisons.pipeline.budget import Budget, check_comparison
from chatterbench.comparisons.pipeline.compare import Comparison, compare, engine_settings
from chatterbench.comparisons.pipeline.cross_check import CrossCheck, comparison_cross_check
from chatterbench.comparisons.pipeline.summary import signed_worst, summarize
from chatterbench.comparisons.pipeline.tolerances import Tolerances, explain

from .episode_errors import episode_errors_figure
from .figures import figure_bytes
from .frontier_chart import TunedFrontier, frontier_figure, scene_frontiers
from .stability_map import stability_map_figure
from .sweep_data import ChartError, at_defaults, parameter_columns
from .ladder import ladder_figure
from .timeseries import timeseries_figure
from .work_precision import work_precision_figure

# the errors are signed (summary.SIGNED_COLUMNS: the worst by magnitude, with its sign; its magnitude is the gate's _max)
SUMMARY_COLUMNS = ["scene", "engine", "verdict", "n_match", "n_episodes", "stick_error_worst", "stick_error_rel_worst",
                   "exit_error_worst", "exit_error_rel_worst", "restitution_error_worst", "penetration_max", "cost_per_sim_s",
                   "status"]
EPISODE_COLUMNS = ["engine", "wall", "ref_t_stick", "t_stick", "stick_error_zeno", "stick_error_rel", "ref_t_exit", "t_exit",
                   "exit_error", "exit_error_rel", "exit_error_steps", "restitution_error", "resolved_impacts",
                   "ref_resolved_impacts", "n_impacts", "onset_rate", "open_fraction", "verdict"]
# headers shown for the columns above; errors are printed in ms, times in s
HEADERS = {
    "scene": "scene", "engine": "engine", "verdict": "verdict", "n_match": "matched", "n_episodes": "episodes",
    "exit_error_max": "worst exit error [ms]", "stick_error_max": "worst sticking error [ms]",
    "exit_error_rel_max": "worst exit error / sliding", "stick_error_rel_max": "worst sticking error / chatter",
    "restitution_error_max": "worst restitution error", "penetration_max": "deepest penetration [mm]",
    "exit_error_worst": "worst exit error [ms]", "stick_error_worst": "worst sticking error [ms]",
    "exit_error_rel_worst": "worst exit error / sliding", "stick_error_rel_worst": "worst sticking error / chatter",
    "restitution_error_worst": "worst restitution error",
    "stick_error_rel": "/ chatter", "exit_error_rel": "/ sliding", "exit_error_steps": "exit error [steps]",
    "restitution_error": "restitution error", "resolved_impacts": "resolved", "ref_resolved_impacts": "ref. resolved",
    "cost_per_sim_s": "cost [s per sim. s]", "status": "run", "wall": "wall",
    "ref_t_stick": "ref. sticks [s]", "t_stick": "sticks [s]", "stick_error_zeno": "sticking error [ms]",
    "ref_t_exit": "ref. exits [s]", "t_exit": "exits [s]", "exit_error": "exit error [ms]",
    "n_impacts": "impacts", "ref_n_impacts": "ref. impacts",
    "onset_rate": "contact onsets after the stick [1/s]", "open_fraction": "open after the stick",
}
MS_COLUMNS = {"exit_error_max", "stick_error_max", "stick_error_zeno", "exit_error", "penetration_max", "exit_error_worst",
              "stick_error_worst"}
FRACTION_COLUMNS = {"onset_rate", "open_fraction", "stick_error_rel_max", "exit_error_rel_max", "restitution_error_max", "stick_error_rel", "exit_error_rel",
                    "restitution_error", "exit_error_steps", "stick_error_rel_worst", "exit_error_rel_worst",
                    "restitution_error_worst"}
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
    summary: pd.DataFrame  # one row per (scene, engine): summary.summarize columns and summary.SIGNED_COLUMNS
    engines: tuple[str, ...]
    dt: float | None  # [s] the timestep asked for; None: each engine's default
    overrides: tuple[str, ...]  # the KEY=VALUE items applied to every scene and engine
    wall_time_s: float  # [s] the whole report's runs
    created: str  # ISO date, UTC
    command: str = ""  # the command line that produced it, for the provenance
    sweeps: tuple[SweepSection, ...] = ()  # every ``--sweep`` dataset, in the order given
    tuning: tuple[str, ...] = ()  # HTML sections written by `chatterbench tune --out DIR` (guide_section.html)
    cross_checks: tuple[CrossCheck, ...] = ()  # per scene, Siconos against Feigin's model (``pipeline.cross_check``)
    frontiers: tuple[TunedFrontier, ...] = ()  # the robust frontiers of `--tune DIR` (``frontier_chart.read_frontiers``)
    atlas: Any = None  # the atlas section (``atlas_section.AtlasSection``): the packaged dataset's, or `--atlas DIR`'s


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def build_report(
    scenes: Sequence[str] = tuple(CATALOGUE),
    engines: Sequence[str] = DEFAULT_ENGINES,
    dt: float | None = None,
    scene_overrides: Sequence[str] = (),
    engine_overrides: Sequence[str] = (),
    tol: Tolerances | None = None,
    sweeps: Sequence[SweepSection] = (),
    progress: Progress | None = _stderr,
    command: str = "",
    timeout: float | None = None,
    budget: Budget | None = None,
    stage: Progress | None = None,
    settings: Mapping[str, Any] | None = None,
) -> Report:
    """Compare every scene on every engine; the scenes are all loaded (validated) before any run.

    Parameters
    ----------
    scenes : built-in scene names or scene TOML paths (default: the whole catalogue).
    dt : the timestep asked for [s] (``--dt``), for the page's text and the Siconos cross-check; None: each engine's
        default. The engines run at their ``settings``.
    scene_overrides : ``KEY=VALUE`` items (``duration=1.6``) applied to every scene.
    engine_overrides : the ``--set ENGINE.KEY=VALUE`` text the settings were made from, for the provenance.
    progress : called with one line per scene and engine as the runs finish; None: silent.
    timeout : wall-clock limit [s] of each engine run, run isolated in a child (``compare``);
        a crash or hang is that engine's failure verdict and the report goes on. None: in-process.
    budget : every scene's reference and engine runs are checked against it before the first run.
    stage : called with ``SCENE: reference`` and ``SCENE: ENGINE`` as each run starts (a progress bar).
    settings : engine name -> settings object (``chatterbench report`` makes them from ``--dt`` and ``--set``, once:
        ``registry.settings_for``); engines without one run at their defaults.
    """
    say = progress or (lambda line: None)
    loaded = [load_scene(s, list(scene_overrides)) for s in scenes]
    names = [scene.name for scene in loaded]  # sections and figures are found by scene name: one section each
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise SceneError(f"scenes: {', '.join(map(repr, twice))} given more than once (by name or by a file's name = "
                         "...); a report has one section per scene name: give each once, or rename one")
    made = engine_settings(engines, settings)  # once, for every scene
    if budget is not None:
        for scene in loaded:
            check_comparison(scene, made, budget)
    start = time.perf_counter()
    comparisons, rows, checks = [], [], []
    for i, scene in enumerate(loaded, 1):
        say(f"[{i}/{len(loaded)}] {scene.name}: reference and {', '.join(engines)} ...")
        t0 = time.perf_counter()
        on = (lambda what, name=scene.name: stage(f"{name}: {what}")) if stage is not None else None
        c = compare(scene, engines=tuple(engines), settings=made, tol=tol, timeout=timeout, progress=on)
        comparisons.append(c)
        checks.append(comparison_cross_check(c, dt, tol))  # Siconos against Feigin's model at the report's dt
        say(f"      {scene.name} reference cross-check (Siconos): {checks[-1].verdict or 'not run'}")
        for name, run in c.runs.items():
            row = {**summarize(c, name, {}), **signed_worst(c.table[c.table["engine"] == name])}
            rows.append(row)
            say(f"      {scene.name} / {name}: {row['verdict']} ({row['n_match']}/{row['n_episodes']} episodes match), "
                f"{run.wall_time:.2f} s stepping")
        say(f"      {scene.name} done in {time.perf_counter() - t0:.1f} s "
            f"(reference {c.provenance['reference']['wall_time_s']:.2f} s)")
    summary = pd.DataFrame(rows)
    return Report(
        comparisons=tuple(comparisons), summary=summary, engines=tuple(engines), dt=dt,
        overrides=tuple(scene_overrides) + tuple(engine_overrides), wall_time_s=time.perf_counter() - start,
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"), command=command, sweeps=tuple(sweeps),
        cross_checks=tuple(checks),
    )


# -- cells (the page's formatting of a value) -------------------------------------------------------------------------------

def cell(column: str, value: Any) -> str:
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


def summary_frame(report: Report) -> pd.DataFrame:
    return report.summary[SUMMARY_COLUMNS] if len(report.summary) else pd.DataFrame(columns=SUMMARY_COLUMNS)


def tolerance_line(c: Comparison) -> str:
    return (f"a match has {c.tolerances.describe()}, each against the episode's own chatter and sliding durations "
            "(the reference's Zeno point - first impact, exit - Zeno point)")


def engine_rows(report: Report) -> list[dict[str, Any]]:
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


def plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def provenance_items(report: Report) -> list[tuple[str, str]]:
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
        ("tolerances", explain(report.comparisons[0].tolerances if report.comparisons else Tolerances())),
        ("wall time", f"{report.wall_time_s:.1f} s for {plural(len(report.comparisons), 'scene')}"),
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
    return figure_bytes(fig, "png")


def scene_figures(report: Report) -> list[Figure]:
    """The time-series chart, the chatter ladder and the per-episode errors of every scene, rendered."""
    out = []
    for c in report.comparisons:
        out.append(Figure(f"timeseries-{c.scene.name}", f"{c.scene.name}: y(t) of the reference and each engine, "
                          "where each starts sticking and exits; shaded: the reference's sliding (Zeno point to exit); "
                          "zoom: the end of the first chatter", _render(timeseries_figure(c))))
        out.append(Figure(f"ladder-{c.scene.name}", f"{c.scene.name}: chatter ladder, each impact's incoming speed "
                          "per wall visit; filled: the engine impacts whose restitution is judged",
                          _render(ladder_figure(c))))
        out.append(Figure(f"episode-errors-{c.scene.name}", f"{c.scene.name}: every episode's sticking, exit and "
                          "restitution error per engine, as fractions of the episode's scales; grey: the tolerance",
                          _render(episode_errors_figure(c))))
    return out


def frontier_figures(report: Report) -> list[Figure]:
    """Per scene with a tuned frontier (``Report.frontiers``), the work-precision chart of robust settings, one line
    per engine (``frontier_chart.frontier_figure``), rendered; the report's scenes first, in order."""
    order = [c.scene.name for c in report.comparisons]
    scenes = order + sorted({f.scene for f in report.frontiers} - set(order))
    out = []
    for scene in scenes:
        by_engine = scene_frontiers(report.frontiers, scene)
        if not by_engine:
            continue
        asked = next(f.asked for f in report.frontiers if f.scene == scene)
        out.append(Figure(f"frontier-{scene}", f"{scene}: the cheapest band-robust setting of each engine tuned "
                          "(chatterbench tune --out DIR, given to the report with --tune DIR) against the tolerance it reaches, timing "
                          "(left) and restitution (right); each point labelled with the other axis's tolerance; dashed: "
                          "the tolerance asked of the first tune", _render(frontier_figure(by_engine, scene, asked))))
    return out


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


def sweep_rows(section: SweepSection, engines: Sequence[str] | None = None) -> pd.DataFrame:
    """The sweep's rows of ``engines`` (None: all), as the report draws and counts them."""
    rows = section.rows
    return rows if engines is None else rows[rows["engine"].astype(str).isin(list(engines))]


def sweep_figures(section: SweepSection, engines: Sequence[str] | None = None) -> tuple[list[Figure], list[str]]:
    """The sweep's work-precision chart and stability maps of ``engines`` (None: all), rendered; plus notes.

    The charts come from ``work_precision`` and ``stability_map``; a chart that cannot be
    drawn from these rows becomes a note, not an error.
    """
    rows = sweep_rows(section, engines)
    if rows.empty:
        return [], [f"no rows of {', '.join(engines or ())} in this dataset"]
    figures, notes = [], []
    params = parameter_columns(rows)
    engines = sorted(rows["engine"].astype(str).unique())
    # each chart shows the slice a user starts from: parameters it does not draw are held at
    # their defaults where the sweep ran them (the caption says which), else folded worst-case
    scene_params = [c for c in params if c.split(".")[0] not in engines]
    slices = [at_defaults(rows, e, ["dt"], scene_params) for e in engines]
    held = {k: v for _, h in slices for k, v in h.items()}
    try:
        figures.append(Figure("work-precision", "work-precision: the judge's worst errors (fractions of each "
                              "episode's scales; dashed: the tolerance) against wall-clock cost per engine, one point "
                              "per value of its cost lever (dt, or an integrator's accuracy)" + _held(held),
                              _render(work_precision_figure(pd.concat([s for s, _ in slices])))))
    except ChartError as exc:
        notes.append(f"work-precision chart: {exc}")
    for engine in engines:
        pairs = _stability_pairs(rows, engine, params)
        if not pairs:
            notes.append(f"stability map ({engine}): needs two swept parameters; this sweep varies fewer for {engine}")
        for x, y in pairs:
            sub, held = at_defaults(rows, engine, (x, y))
            try:
                figures.append(Figure(f"stability-{engine}-{x}-{y}", f"stability map, {engine}: verdict over {x} and {y}"
                                      + _held(held), _render(stability_map_figure(sub, x, y, engine))))
            except ChartError as exc:
                notes.append(f"stability map ({engine}, {x} x {y}): {exc}")
    return figures, notes


def _held(held: dict[str, Any]) -> str:
    """Caption tail naming the parameters a chart holds at their defaults."""
    if not held:
        return ""
    return "; held at the defaults: " + ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                                                  for k, v in held.items())
