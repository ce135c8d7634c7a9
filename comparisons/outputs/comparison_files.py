"""Files written for a comparison under ``--out DIR`` (all atomic).

    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.comparison_files import write_comparison
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> paths = write_comparison(compare(load_scene("bouncing-ball"), settings=settings_for(("pybullet",), 1e-3)), tmp / "cmp")
    >>> sorted(p.name for p in paths if p.suffix == ".png")
    ['episode_errors.png', 'ladder.png', 'timeseries.png']

Layout of DIR:

- ``episodes.csv`` / ``episodes.parquet``: the comparison table (``pipeline.compare.COLUMNS``);
- ``impacts.csv``: every paired resolved impact, per engine (``pipeline.judge.IMPACT_PAIR_COLUMNS``):
  times, incoming speeds, effective restitution and its error;
- ``impacts_ENGINE.csv``: every impact the extraction found in the engine's samples
  (``pipeline.extract.IMPACT_COLUMNS``), unresolved micro-bounces of stuck stretches included
  (ENGINE: the engine's name, or a ``judge --engine`` label as ``file_word`` writes it);
- ``reference_episodes.csv``: plate entry, Zeno point, exit and scales of every reference episode;
- ``events_reference_feigin.csv``, ``events_reference_exhaustive.csv``, ``events_ENGINE.csv``:
  event logs in the reference format;
- ``conformance_mujoco_mujoco_warp.csv``: when both ran, MuJoCo Warp against MuJoCo C episode by
  episode (``pipeline.conformance.CONFORMANCE_COLUMNS``): verdicts, sticking, exit and impact differences;
- ``provenance.json``: scene, engine versions and settings, tolerances, wall-clock cost of
  each run, machine and date;
- ``timeseries.png`` / ``timeseries.svg``: the time-series chart;
- ``ladder.png`` / ``ladder.svg``: the chatter ladder (``ladder.py``): each impact's incoming
  speed per wall visit, the reference's geometric ladder and each engine's impacts over it;
- ``episode_errors.png`` / ``episode_errors.svg``: every episode's sticking, exit and
  restitution error per engine as a fraction of its scale, with the tolerance bands
  (``episode_errors.py``).
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

from chatterbench.comparisons.pipeline.atomic import write_frame, write_text
from chatterbench.comparisons.pipeline.conformance import conformance, same_model_pairs

from .episode_errors import episode_errors_figure
from .figures import write_figure
from .ladder import ladder_figure
from .timeseries import timeseries_figure


def _json_default(obj):
    try:
        return float(obj)
    except (TypeError, ValueError):
        return str(obj)


_PLAIN = re.compile(r"[A-Za-z0-9_.+-]{1,80}")  # an engine label written as it is in a file name


def file_word(label: str) -> str:
    """An engine label as a word of a file name under DIR: as it is when plain (``mujoco_warp``); else its letters,
    digits and ``_.+-`` kept, every other character ``_``, cut to 60 and tagged with a hash of the label, so a
    label never becomes a path (``../x``, ``/etc/x``, a newline) and two labels never share a file.

    >>> from chatterbench.comparisons.outputs.comparison_files import file_word
    >>> file_word("mujoco"), file_word("/../../outside/x")[:17]
    ('mujoco', '_.._.._outside_x-')
    """
    if _PLAIN.fullmatch(label) and label not in (".", ".."):
        return label
    digest = hashlib.sha256(label.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", label)[:60] + "-" + digest


def write_comparison(comparison, out: Path, figures: bool = True) -> list[Path]:
    """Write every file of a comparison under ``out``; returns the paths written."""
    out = Path(out)
    paths = [
        write_frame(out / "episodes.csv", comparison.table),
        write_frame(out / "episodes.parquet", comparison.table),
        write_frame(out / "impacts.csv", comparison.impacts),
        write_frame(out / "reference_episodes.csv", comparison.reference),
        write_frame(out / "events_reference_feigin.csv", comparison.feigin.log),
        write_frame(out / "events_reference_exhaustive.csv", comparison.exhaustive.log),
    ]
    for name, run in comparison.runs.items():
        paths.append(write_frame(out / f"events_{file_word(name)}.csv", run.log))
        paths.append(write_frame(out / f"impacts_{file_word(name)}.csv", run.found.impacts))
    for engine, other in same_model_pairs(comparison.runs):  # one model on two executors: where they part
        paths.append(write_frame(out / f"conformance_{file_word(engine)}_{file_word(other)}.csv",
                                 conformance(comparison, engine, other)))
    paths.append(write_text(out / "provenance.json", json.dumps(comparison.provenance, indent=2, default=_json_default)))
    if figures:
        for stem, fig in (("timeseries", timeseries_figure(comparison)), ("ladder", ladder_figure(comparison)),
                          ("episode_errors", episode_errors_figure(comparison))):
            paths.extend(write_figure(fig, out, stem))
    return paths
