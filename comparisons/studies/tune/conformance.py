"""A tuning answer of an engine that steps another engine's model, checked against that engine at the same settings.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import Tolerances, tune
    >>> from chatterbench.comparisons.studies.tune.conformance import same_model_check
    >>> tol = Tolerances(stick=0.2, exit=0.2, first_impact=0.2, restitution=0.2)
    >>> space = {"dt": (1e-3,), "mujoco_warp.w0_dt": (0.228,), "mujoco_warp.impedance": (0.95,)}  # d = 0.99 flickers (buzz)
    >>> result = tune(load_scene("bouncing-ball"), "mujoco_warp", tol, space=space, workers=1, refine_steps=0, ladder=None,
    ...               check_robust=False)
    >>> check = same_model_check(result)                   # MuJoCo C at MuJoCo Warp's answer
    >>> check.against, check.table[["point", "verdict", "other_verdict", "disagree", "same"]].values.tolist()
    ('mujoco', [['answer', 'match', 'match', 0, True]])
    >>> check.sentence()                                  # doctest: +ELLIPSIS
    "mujoco at mujoco_warp's settings: 1 of 1 answers alike ...; largest |sticking difference| ... s, |exit difference| none, |impact count difference| 1"

MuJoCo Warp (float32) steps MuJoCo's own ``MjSpec`` model (``EngineAdapter.same_model_as``), so
``tune --engines mujoco_warp`` answers for MuJoCo Warp itself, and a user who moves the answer to
MuJoCo C (float64), or back, asks whether it holds there. ``same_model_check`` reruns each answer of
the tune, the chosen candidate at the asked tolerances (``point`` "answer": the recommendation, or
the best reachable one) and each point of the robust frontier at its own tolerances ("frontier
k"; a point that is the answer itself, once), in both engines at the same dt and knobs (the other engine's settings of the same names),
judges both runs at that point's tolerances (``pipeline.compare``) and pairs their episodes
(``pipeline.conformance``). Nothing here changes the tune's answer.

Columns (``CHECK_COLUMNS``): ``point``; ``stick`` and ``restitution``, the point's tolerances
[-]; ``dt`` [s]; ``settings`` (the knobs, engine prefix dropped); ``verdict`` (the tuned engine's
verdicts, one word when they all agree, else joined with "/"), ``other_verdict``; ``passes``,
``other_passes`` (every episode ``match`` or ``none``); ``episodes`` (paired episodes),
``disagree`` (episodes the judge would tell apart: ``conformance``'s promise); the largest
|sticking start|, |exit| differences [s] (NaN: no episode sticks or exits in both) and |impact count|
difference over the episodes; ``same``: both engines pass, or both fail, and no episode disagrees;
``summary``: ``conformance.describe``'s paragraph (differences: tuned engine - other).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import pandas as pd

from chatterbench.engines.registry import adapter, make_settings, unavailable_reason

from ...pipeline.compare import compare
from ...pipeline.conformance import conformance, describe
from ...pipeline.tolerances import Tolerances
from .frontier import json_value
from .passes import agrees

CHECK_COLUMNS = ["point", "stick", "restitution", "dt", "settings", "verdict", "other_verdict", "passes", "other_passes",
                 "episodes", "disagree", "stick_difference_max", "exit_difference_max", "impact_count_difference_max",
                 "same", "summary"]


@dataclass(frozen=True)
class SameModelCheck:
    """The tuned engine's answers rerun in ``against`` (module docstring): one row per answer."""

    engine: str
    against: str  # the engine whose model ``engine`` steps (``EngineAdapter.same_model_as``)
    table: pd.DataFrame  # CHECK_COLUMNS

    @property
    def holds(self) -> bool:
        """Every answer: the two engines alike (``same``)."""
        return bool(self.table["same"].all()) if len(self.table) else True

    def sentence(self) -> str:
        """One line: whether each answer holds in the other engine, the worst differences."""
        t = self.table
        if not len(t):
            return f"{self.against} at {self.engine}'s settings: no answer to check (no candidate ran)"
        alike = int(t["same"].sum())
        worst = {c: _worst(t[c]) for c in ("stick_difference_max", "exit_difference_max", "impact_count_difference_max")}
        sizes = ", ".join(f"|{name} difference| " + ("none" if math.isnan(v) else f"{v:.3g}{unit}") for name, v, unit in (
            ("sticking", worst["stick_difference_max"], " s"), ("exit", worst["exit_difference_max"], " s"),
            ("impact count", worst["impact_count_difference_max"], "")))
        parts = [f"{self.against} at {self.engine}'s settings: {alike} of {len(t)} answers alike in both engines "
                 f"(same verdicts, no episode the judge tells apart); largest {sizes}"]
        for row in t[~t["same"]].itertuples():
            parts.append(f"{row.point} (dt={row.dt:g}, {row.settings}; stick {100 * row.stick:g}%, restitution "
                         f"{100 * row.restitution:g}%): {self.engine} {row.verdict}, {self.against} {row.other_verdict}, "
                         f"{row.disagree} of {row.episodes} episodes disagree")
        return "; ".join(parts)

    def records(self) -> list[dict[str, Any]]:
        """The rows for ``recommended.json`` (``tune.frontier.json_value``: NaN as None)."""
        return [{k: json_value(v) for k, v in row.items()} for row in self.table.to_dict("records")]


def same_model_of(engine: str) -> str:
    """The engine whose model ``engine`` steps, when it is installed here ("" when none or absent)."""
    other = adapter(engine).same_model_as
    return other if other and not unavailable_reason(other) else ""


def other_settings(engine: str, against: str, dt: float, knobs: dict[str, Any]) -> Any:
    """``against``'s settings at ``dt`` [s] with ``engine``'s knobs (``engine.FIELD``) of the fields it has too."""
    fields = {f.name for f in dataclasses.fields(make_settings(against))}
    values = {f"{against}.{k.split('.', 1)[1]}": v for k, v in knobs.items() if k.split(".", 1)[1] in fields}
    return make_settings(against, dt, values)


def _answers(result) -> list[tuple[str, Tolerances, float, dict[str, Any]]]:
    """(point, tolerances, dt, knobs) of the chosen candidate and of each frontier point."""
    keys = [k for k in result.extra["space"] if k != "dt"]
    out = []
    if (c := result.chosen) is not None:
        out.append(("answer", result.tolerance, float(c["dt"]), {k: json_value(c[k]) for k in keys}))
    for k, e in enumerate(result.frontier, 1):
        out.append((f"frontier {k}", Tolerances(**e["tolerances"]), float(e["dt"]), dict(e["settings"])))
    seen, kept = set(), []
    for point in out:  # a frontier point that is the answer itself (same settings and tolerances) is checked once
        key = (point[1], point[2], tuple(sorted(point[3].items())))
        if key not in seen:
            seen.add(key)
            kept.append(point)
    return kept


def _verdicts(table: pd.DataFrame, engine: str) -> tuple[str, bool]:
    verdicts = table.loc[table["engine"] == engine, "verdict"].tolist()
    word = "/".join(dict.fromkeys(verdicts)) or "no episode"
    return word, all(agrees(v) for v in verdicts)  # no episode: nothing that disagrees with the reference


def _worst(column: pd.Series) -> float:
    values = column.abs().dropna()
    return float(values.max()) if len(values) else math.nan


def same_model_check(result, against: str | None = None) -> SameModelCheck | None:
    """Each answer of ``result`` (``tune.TuneResult``) rerun in ``against`` (default: the engine whose model the tuned
    one steps, ``same_model_of``) and in the tuned engine, judged at the answer's tolerances and paired (module
    docstring); None when there is no other engine to check against."""
    engine = result.engine
    against = against if against is not None else same_model_of(engine)
    if not against:
        return None
    ref = result.extra.get("solution")
    rows = []
    for point, tol, dt, knobs in _answers(result):
        settings = {engine: make_settings(engine, dt, knobs), against: other_settings(engine, against, dt, knobs)}
        both = compare(result.scene, engines=(against, engine), settings=settings, tol=tol, solution=ref)
        pairs = conformance(both, against, engine)
        verdict, passes = _verdicts(both.table, engine)
        other_verdict, other_passes = _verdicts(both.table, against)
        disagree = int(pairs["disagree"].sum())
        rows.append({"point": point, "stick": tol.stick, "restitution": tol.restitution, "dt": dt,
                     "settings": ", ".join(f"{k.split('.', 1)[1]}={v}" for k, v in knobs.items()) or "defaults",
                     "verdict": verdict, "other_verdict": other_verdict, "passes": passes, "other_passes": other_passes,
                     "episodes": len(pairs), "disagree": disagree,
                     "stick_difference_max": _worst(pairs["stick_difference"]),
                     "exit_difference_max": _worst(pairs["exit_difference"]),
                     "impact_count_difference_max": _worst(pairs["impact_count_difference"]),
                     "same": passes == other_passes and disagree == 0, "summary": describe(both, against, engine)})
    return SameModelCheck(engine, against, pd.DataFrame(rows, columns=CHECK_COLUMNS))
