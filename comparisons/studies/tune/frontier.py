"""The robust frontier of a tune: the cheapest robust setting at each tolerance level, and the levels worth naming.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> from chatterbench.comparisons.studies.tune.ladder import Ladder
    >>> space = {"dt": (0.0118, 0.00485, 0.00388), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.02, space=space, workers=1, refine_steps=0,
    ...               ladder=Ladder(timing=(0.1,), restitution=(0.1,)), phases=(), transfer=False)
    >>> [(p["tolerances"]["stick"], p["tolerances"]["restitution"], p["dt"]) for p in result.frontier]
    [(0.1, 0.05, 0.00388)]
    >>> result.best is None                   # nothing robust at the asked 2%
    True

Each ladder point (``tune.ladder``: a timing level x a restitution level) has an *answer*:
among the candidates on the search's lattice that are robust there (the candidate and every
neighbour of its neighbourhood pass, judged at that point's tolerances: ``tune.search``),
the fewest steps per simulated second (``steps_per_sim_s``), within ``--max-cost``; equal
steps go to the simplest: fewest settings away from the engine's defaults, then the settings'
text (so that the answer never depends on a timing). No tie band, no wall time and no
restitution under the scene's forces (which the judge does not check) decide here:
``tune.choice.choose`` weighs all three for the recommendation at the asked tolerances, which may
therefore be a simpler setting up to the tie band dearer than the frontier's point there. The *frontier* is the answers no other answer beats on all three at once:
a point is left out when another is as tight in timing and in restitution and as cheap.
``tightest`` is the tightest level reached robustly on each axis (at any level of the other).

Because the judge's measurements depend on the tolerances (``tune.ladder``), a setting robust
at one point is not promised to be robust at a looser one; each point's answer was judged at
that point, so ``compare --tolerance`` with its tolerances gives ``match`` there.
"""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from ...pipeline.tolerances import Tolerances
from .choice import first_of
from .ladder import at_point, level_text, margin_at

# recommended.json's frontier entries
FRONTIER_KEYS = ("tolerances", "dt", "settings", "cost_steps_per_s", "margin", "margin_check", "checked", "persistence")


def answers(table: pd.DataFrame, points: tuple[Tolerances, ...], max_cost: float = math.inf) -> dict[int, dict[str, Any]]:
    """Ladder point index -> its answer (module docstring), for the points that have one."""
    if "robust_at" not in table:
        return {}
    robust = table[table["robust_at"].map(lambda v: isinstance(v, tuple)) & (table["steps_per_sim_s"] <= max_cost)]
    out = {}
    for i in range(len(points)):
        ok = robust[robust["robust_at"].map(lambda v, i=i: i in v)]
        if len(ok):
            out[i] = first_of(ok, ["steps_per_sim_s"], [True])  # ties: choice.TIE_KEYS
    return out


def pareto(found: dict[int, dict[str, Any]], points: tuple[Tolerances, ...]) -> list[int]:
    """The answered points no other answered point beats: as tight on both axes and as cheap. Cheapest first."""
    def beaten(i: int) -> bool:
        a, c = points[i], found[i]["steps_per_sim_s"]
        return any(j != i and points[j].stick <= a.stick and points[j].restitution <= a.restitution
                   and found[j]["steps_per_sim_s"] <= c for j in found)
    keep = [i for i in found if not beaten(i)]
    return sorted(keep, key=lambda i: (found[i]["steps_per_sim_s"], points[i].stick, points[i].restitution))


def frontier_entries(found: dict[int, dict[str, Any]], points: tuple[Tolerances, ...], keys: list[str]
                     ) -> list[dict[str, Any]]:
    """``recommended.json``'s ``frontier``: one entry per frontier point (``FRONTIER_KEYS``), cheapest first.

    ``keys``: the searched settings (``engine.field``), written under ``settings`` as ``compare --set`` takes them.
    """
    out = []
    for i in pareto(found, points):
        row = found[i]
        out.append({"tolerances": points[i].as_dict(), "dt": float(row["dt"]),
                    "settings": {k: json_value(row[k]) for k in keys}, "cost_steps_per_s": float(row["steps_per_sim_s"]),
                    "margin": json_value(margin_at(row, i)), "margin_check": at_point(row, "limits", i, ""),
                    "checked": checked(row, i), "persistence": persistence(row, i, points[i])})
    return out


def checked(row: dict[str, Any], point: int) -> dict[str, Any] | None:
    """What the robustness of ``row`` at ladder point ``point`` rests on (``tune.search``'s ``band``): the band's dts
    (``dts``: their range, ``n_dts``: how many, ends and its own included), the impact ``phases`` (fractions of a
    step), its knob neighbours, the runs, and the share of them that passed there; None where nothing was checked."""
    band = row.get("band")
    if not isinstance(band, dict):
        return None
    return {"dts": [min(band["dts"]), max(band["dts"])], "n_dts": len(band["dts"]), "phases": band["phases"],
            "knob_neighbours": band["knobs"], "runs": band["runs"], "passed": json_value(band["passed"].get(point))}


def persistence(row: dict[str, Any], point: int, tol: Tolerances) -> dict[str, Any]:
    """The contact of ``row``'s run after each stick at ladder point ``point``: its largest open share of the rest
    (``open_fraction``, against the ``tolerance``) and contact onsets per second there (``onsets_per_s``)."""
    share, rate = at_point(row, "rests", point, (math.nan, math.nan))
    return {"open_fraction": json_value(share), "onsets_per_s": json_value(rate), "tolerance": tol.persistence}


def tightest(found: dict[int, dict[str, Any]], points: tuple[Tolerances, ...]) -> dict[str, float | None]:
    """The tightest sticking and restitution tolerance reached robustly (at any level of the other axis); None: none."""
    return {"stick": min((points[i].stick for i in found), default=None),
            "restitution": min((points[i].restitution for i in found), default=None)}


def tightest_point(found: dict[int, dict[str, Any]], points: tuple[Tolerances, ...], asked: Tolerances) -> int | None:
    """The frontier point nearest the ``asked`` tolerances (``pareto`` of ``found``): the least of its timing and
    restitution tolerances' largest ratio to the asked ones, then of the other, then the cheaper; None when nothing is robust. What tune
    writes when nothing is robust at the asked tolerances: a robust setting, never a fragile one."""
    front = pareto(found, points)
    if not front:
        return None
    def distance(i: int) -> tuple[float, ...]:
        ratios = sorted((points[i].stick / asked.stick, points[i].restitution / asked.restitution), reverse=True)
        return (*ratios, found[i]["steps_per_sim_s"])
    return min(front, key=distance)


def json_value(v: Any) -> Any:
    """A JSON value: numpy scalars as Python numbers, NaN and inf as None (``recommended.json``)."""
    v = v.item() if hasattr(v, "item") else v
    return None if isinstance(v, float) and not math.isfinite(v) else v


def _pct(v: float) -> str:
    return f"{100 * v:.3g}%"


def asked_text(tol: Tolerances) -> str:
    """The asked tolerances in a few words: ``5%`` when the four ladder tolerances are one number."""
    values = {tol.stick, tol.exit, tol.first_impact, tol.restitution}
    return _pct(tol.stick) if len(values) == 1 else level_text(tol)


def entry_text(entry: dict[str, Any], defaults: dict[str, Any]) -> str:
    """One frontier entry as a clause: ``stick 5%, restitution 20% at 3,003 steps/s with dt=0.000333, w0_dt=0.228``."""
    tol = Tolerances(**entry["tolerances"])
    changed = [f"{k.split('.', 1)[-1]}={v}" for k, v in entry["settings"].items() if defaults.get(k) != v]
    return (f"{level_text(tol)} at {entry['cost_steps_per_s']:,.0f} steps/s with "
            + ", ".join([f"dt={entry['dt']:g}", *changed]))


def frontier_sentence(asked: Tolerances, robust_at_asked: bool, entries: list[dict[str, Any]],
                      defaults: dict[str, Any], ladder: str) -> str:
    """The answer's first sentence: whether the asked tolerances have a robust setting, then what is reachable."""
    head = (f"robust at {asked_text(asked)}" if robust_at_asked else
            f"no robust setting at {asked_text(asked)} in the searched space")
    if not entries:
        return f"{head}; nothing is robust at any level of the ladder ({ladder})"
    return f"{head}; {'the robust frontier' if robust_at_asked else 'robust'}: " + "; ".join(
        entry_text(e, defaults) for e in entries)
