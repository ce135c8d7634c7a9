"""The work-precision chart of robust settings: each engine's cheapest robust cost against the tolerance it reaches.

    >>> from chatterbench.comparisons.outputs.frontier_chart import frontier_figure
    >>> point = lambda stick, rest, cost: {"tolerances": {"stick": stick, "restitution": rest}, "dt": 1 / cost,
    ...                                    "settings": {}, "cost_steps_per_s": cost, "margin": 0.5}
    >>> fig = frontier_figure({"mujoco": [point(0.2, 0.2, 206.0), point(0.05, 0.3, 629.0)], "pybullet": []},
    ...                       "bouncing-ball", asked={"stick": 0.05, "restitution": 0.05})
    >>> [ax.get_xlabel().split(" ")[0] for ax in fig.axes], len(fig.axes[0].lines) >= 1
    (['timing', 'restitution'], True)

Input: ``recommended.json``'s ``frontier`` per engine (``studies.tune.frontier``: each entry's
``tolerances``, ``cost_steps_per_s``), so a chart can be drawn from the files of several
``tune`` runs (``chatterbench report --tune DIR``) as from one. Two panels, one per axis of
the ladder, since timing and restitution fail for different reasons: x the tolerance reached
on that axis (the sticking tolerance; exit and first impact move with it), log; y the steps
per simulated second of the cheapest robust setting reaching it, log. One line per engine,
its colour from ``style.engine_colour`` and its own marker shape (``MARKERS``; a later engine's smaller, so
that two engines' points at one place both show): the staircase of its frontier's points seen on that
axis (filled: the cheapest point reaching each tolerance on it), the other points hollow
(dearer there, but tighter on the other axis), each labelled with the tolerance it reaches
on the other axis and its cost (the point at the asked tolerances: "(asked)", bold); an engine with no robust point is named in the legend. Dashed: the asked
tolerance on each axis.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter, NullLocator

from chatterbench.reference.errors import InputError
from chatterbench.reference.tables import read_text

from .style import engine_colour

MAX_JSON_BYTES = 4 * 2**20  # [bytes] of a recommended.json: tune writes a few KiB
MAX_FRONTIER_POINTS = 100  # entries of one frontier: tune's ladder has at most 6 x 6 points (its levels and the asked)

MARKERS = ("o", "s", "D", "^", "v", "P", "X")  # one shape per engine, so that a point under another engine's shows
AXES = (("stick", "timing (sticking tolerance; exit and first impact move with it)", "restitution", "r"),
        ("restitution", "restitution tolerance |e / R - 1|", "stick", "stick"))


def staircase(entries: Sequence[dict[str, Any]], axis: str) -> list[dict[str, Any]]:
    """The entries no cheaper (or as cheap and tighter) entry beats on ``axis``, tightest first (costliest first)."""
    def key(e):
        return e["tolerances"][axis], e["cost_steps_per_s"]
    out = []
    for e in sorted(entries, key=key):
        if not out or e["cost_steps_per_s"] < out[-1]["cost_steps_per_s"]:
            out.append(e)
    return out


def _pct(v: float) -> str:
    return f"{100 * v:.3g}%"


def frontier_figure(frontiers: Mapping[str, Sequence[dict[str, Any]]], scene: str,
                    asked: Mapping[str, float] | None = None, labels: bool = True) -> Figure:
    """The chart (module docstring); ``frontiers``: engine -> its frontier entries; ``asked``: the asked tolerances;
    ``labels`` False: no point labelled (many engines: the atlas's table lists the points)."""
    fig = Figure(figsize=(10.5, 4.8), layout="constrained")
    axes = fig.subplots(1, 2)
    labelled: list[tuple] = []  # per axes, each point's label: (tolerance, cost, text, colour, at the asked tolerances)
    for ax, (axis, label, other, short) in zip(axes, AXES):
        marks: list[tuple] = []
        labelled.append((ax, marks))
        for k, (engine, entries) in enumerate(frontiers.items()):
            colour, marker = engine_colour(engine), MARKERS[k % len(MARKERS)]
            size = 9.0 - 2.0 * (k % 3)  # a later engine's marker smaller, so a point under it still shows
            steps = staircase(entries, axis)
            if not steps:
                ax.plot([], [], color=colour, label=f"{engine}: nothing robust in the searched space")
                continue
            x = [e["tolerances"][axis] for e in steps]
            y = [e["cost_steps_per_s"] for e in steps]
            ax.step(x, y, where="post", color=colour, lw=1.8, label=f"{engine}: the cheapest reaching each tolerance",
                    zorder=2 + k)
            ax.plot(x, y, marker, color=colour, ms=size, mec="white", mew=0.6, ls="none", zorder=3 + k)
            others = [e for e in entries if e not in steps]  # dearer here, but tighter on the other axis
            ax.plot([e["tolerances"][axis] for e in others], [e["cost_steps_per_s"] for e in others], marker, mfc="none",
                    color=colour, ms=size, mew=1.4, ls="none", zorder=3 + k)
            for e in entries if labels else ():
                at_asked = asked is not None and all(e["tolerances"].get(a) == asked.get(a) for a in ("stick", "restitution"))
                text = f"{short} {_pct(e['tolerances'][other])}, {e['cost_steps_per_s']:,.0f}/s" + (" (asked)" if at_asked else "")
                marks.append((e["tolerances"][axis], e["cost_steps_per_s"], text, colour, at_asked))
        if any(frontiers.values()):
            ax.plot([], [], "o", mfc="none", color="0.3", label="other frontier points (tighter on the other axis)")
        else:
            ax.text(0.5, 0.5, "nothing robust in the searched space", transform=ax.transAxes, ha="center", fontsize=9,
                    color="0.4")
        if asked and axis in asked:
            ax.axvline(asked[axis], color="0.4", ls="--", lw=1, label=f"asked: {_pct(asked[axis])}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        _tolerance_ticks(ax, frontiers, axis, asked)
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:,.0f}"))
        ax.yaxis.set_minor_formatter(NullFormatter())  # labels at 1, 2 and 5 only, as numbers
        ax.set_xlabel(label, fontsize=8)
        ax.set_ylabel("steps per simulated second (cost)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="major", alpha=0.25)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 3), fontsize=7, frameon=False)
    fig.suptitle(f"{scene}: the cheapest band-robust setting against the tolerance it reaches\n(band-robust: passes "
                 "at every dt of [0.8, 1.25] x dt, at every impact phase and at the knobs' neighbours)", fontsize=9)
    if any(marks for _, marks in labelled):
        fig.draw_without_rendering()  # the layout done: the axes' final size, in which the labels are spaced
        for ax, marks in labelled:
            _label_points(ax, marks)
    return fig


LABEL_GAP = 9.0  # [points] between the labels of one tolerance (7-point text)


def _label_points(ax, marks: Sequence[tuple]) -> None:
    """Each point's label right of it; the labels of one tolerance, lowest first, pushed up so that none overlaps the
    one below (before: each engine's a fixed 11 points lower than the one before, so the seventh engine's fell 61
    points below its point, over another's label and off the axes)."""
    to_px, pt = ax.transData.transform, ax.figure.dpi / 72.0
    for x in sorted({m[0] for m in marks}):
        top = -float("inf")
        for _, y, text, colour, bold in sorted((m for m in marks if m[0] == x), key=lambda m: m[1]):
            at = float(to_px((x, y))[1])
            top = max(at - 0.5 * LABEL_GAP * pt, top + LABEL_GAP * pt)  # its centre: at its point, or above the last
            ax.annotate(text, (x, y), textcoords="offset points", xytext=(6, (top - at) / pt), va="center", fontsize=7,
                        color=colour, fontweight="bold" if bold else "normal")


def _tolerance_ticks(ax, frontiers, axis: str, asked) -> None:
    """Ticks at the tolerances drawn, in percent; the axis padded a little on each side."""
    values = sorted({e["tolerances"][axis] for entries in frontiers.values() for e in entries}
                    | ({asked[axis]} if asked and axis in asked else set()))
    if not values:
        values = [0.01, 0.3]
    ax.set_xticks(values, [_pct(v) for v in values], fontsize=7)
    ax.xaxis.set_minor_locator(NullLocator())
    lo, hi = min(values), max(values)
    ax.set_xlim(lo / 1.4, hi * 1.9 if hi > lo else hi * 2.0)  # room on the right for the last point's label
    costs = [e["cost_steps_per_s"] for entries in frontiers.values() for e in entries] or [10.0, 1e5]  # none: a range
    ax.set_ylim(min(costs) / 1.6, max(costs) * 1.6)


@dataclass(frozen=True)
class TunedFrontier:
    """One engine's frontier as a ``recommended.json`` holds it (``chatterbench report --tune DIR``)."""

    scene: str
    engine: str
    frontier: tuple[dict[str, Any], ...]  # studies.tune.frontier.FRONTIER_KEYS each
    asked: dict[str, float]  # the asked tolerances (recommended.json's ``tolerances``)
    source: str  # the file it came from


def read_frontiers(dirs: Sequence[str | Path]) -> tuple[TunedFrontier, ...]:
    """Every ``recommended.json`` of each ``tune --out`` directory: ``DIR/recommended.json`` (one engine) or
    ``DIR/ENGINE/recommended.json`` (several), in that order; files without a ``frontier`` are left out.

    Each is read as a regular file of at most ``MAX_JSON_BYTES`` (``reference.tables.read_text``), reached
    without following a link (a linked file or engine folder is refused by name: ``reference.tables.open_in``), and
    its frontier checked entry by entry: a file that is not what ``tune`` writes is an ``InputError``
    naming it and the field, never a failure inside the chart; so is a frontier of more than
    ``MAX_FRONTIER_POINTS`` entries (every one is drawn and labelled).
    """
    out = []
    for d in dirs:
        for path in _tuned_files(Path(d)):
            text = read_text(path, f"--tune {d}: {path.relative_to(d)}", limit=MAX_JSON_BYTES, kind="JSON", folder=d)
            try:
                rec = json.loads(text)
            except (ValueError, RecursionError) as exc:
                raise InputError(f"--tune {d}: {path.relative_to(d)} is not the JSON `chatterbench tune` writes "
                                 f"({str(exc).splitlines()[0][:200]})") from None
            if isinstance(rec, dict) and isinstance(rec.get("frontier"), list):
                where = f"--tune {d}: {path.relative_to(d)}"
                if len(rec["frontier"]) > MAX_FRONTIER_POINTS:  # each is drawn and labelled: 12,000 took minutes
                    raise InputError(f"{where}: a frontier of {len(rec['frontier']):,} points, more than the "
                                     f"{MAX_FRONTIER_POINTS} the report draws (`chatterbench tune` writes at most one per "
                                     "point of its ladder, 36)")
                out.append(TunedFrontier(scene=str(rec.get("scene", "")), engine=str(rec.get("engine", "")),
                                         frontier=tuple(_checked_entry(e, f"{where}: frontier[{i}]")
                                                        for i, e in enumerate(rec["frontier"])),
                                         asked=_checked_asked(rec.get("tolerances"), f"{where}: tolerances"),
                                         source=str(path)))
    return tuple(out)


def _tuned_files(folder: Path) -> list[Path]:
    """``folder/recommended.json`` and ``folder/ENGINE/recommended.json`` where they are, links included (the reader
    refuses those by name); hidden names (a tune's staging folder) left out."""
    found = [folder / "recommended.json"] if os.path.lexists(folder / "recommended.json") else []
    try:
        entries = sorted(os.scandir(folder), key=lambda e: e.name)
    except OSError:  # not a folder: guide_section's reader has said so
        return found
    for entry in entries:
        inner = Path(entry.path) / "recommended.json"
        if not entry.name.startswith(".") and (entry.is_symlink() or entry.is_dir()) and os.path.lexists(inner):
            found.append(inner)
    return found


def _positive(value: Any, what: str) -> float:
    """``value`` as a finite positive number, or an ``InputError`` naming ``what`` and the allowed range."""
    if value is None:
        raise InputError(f"{what}: missing (`chatterbench tune` writes a number > 0)")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise InputError(f"{what}: {str(value)[:40]!r} is not a number > 0 (`chatterbench tune` writes one)")
    return float(value)


def _checked_entry(entry: Any, what: str) -> dict[str, Any]:
    """A frontier entry with the fields the report shows checked: ``tolerances.stick``, ``.restitution``, the cost,
    ``dt`` and ``settings`` (a table, or absent)."""
    if not isinstance(entry, dict) or not isinstance(entry.get("tolerances"), dict):
        raise InputError(f"{what}: not an entry with 'tolerances' and 'cost_steps_per_s' (`chatterbench tune` writes one)")
    for axis in ("stick", "restitution"):
        _positive(entry["tolerances"].get(axis), f"{what}.tolerances.{axis}")
    _positive(entry.get("cost_steps_per_s"), f"{what}.cost_steps_per_s")
    _positive(entry.get("dt"), f"{what}.dt")  # the report prints it as a number: before, KeyError or a format error
    if not isinstance(entry.get("settings") or {}, dict):
        raise InputError(f"{what}.settings: not a table of the engine's settings (`chatterbench tune` writes one)")
    return entry


def _checked_asked(tolerances: Any, what: str) -> dict[str, float]:
    """The asked tolerances the chart marks: the numeric ones > 0 of ``stick`` and ``restitution``."""
    if not isinstance(tolerances, dict):
        return {}
    return {axis: _positive(tolerances[axis], f"{what}.{axis}") for axis in ("stick", "restitution") if axis in tolerances}


def scene_frontiers(frontiers: Sequence[TunedFrontier], scene: str) -> dict[str, Sequence[dict[str, Any]]]:
    """``scene``'s frontiers by engine, as ``frontier_figure`` takes them (an engine tuned twice: named by its file)."""
    mine = [f for f in frontiers if f.scene == scene]
    names = [f.engine for f in mine]
    return {(f.engine if names.count(f.engine) == 1 else f"{f.engine} ({f.source})"): f.frontier for f in mine}
