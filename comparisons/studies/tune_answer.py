"""A tune's answer as data and words: ``recommended.json``, the frontier's sentence, and how far the search looked.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> from chatterbench.comparisons.studies.tune_answer import recommended, frontier_line
    >>> from chatterbench.comparisons.studies.tune_ladder import Ladder
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.01, space={"dt": (4e-3, 2e-3)}, workers=1,
    ...               refine_steps=0, ladder=Ladder(timing=(0.05,), restitution=(0.05,)))
    >>> frontier_line(result)                 # the asked 1% has no robust setting here; 5% has
    'no robust setting at stick 1%, restitution 5% in the searched space; robust: stick 5%, restitution 5% at 500 steps/s with dt=0.002'
    >>> rec = recommended(result)
    >>> rec["answer"] == frontier_line(result), rec["frontier"][0]["dt"], rec["tightest"]
    (True, 0.002, {'stick': 0.05, 'restitution': 0.05})

``recommended.json`` opens with ``answer`` (``frontier_line``: whether the asked tolerances
have a robust setting, then what is reachable), then the chosen candidate as ``compare
--engines E --dt DT --set K=V ...`` takes it (the recommendation, or the best reachable),
``frontier`` (``tune_frontier.frontier_entries``: ``tolerances``, ``dt``, ``settings``,
``cost_steps_per_s``, ``margin`` per point, cheapest first), ``tightest`` (the tightest
sticking and restitution tolerance reached robustly), ``ladder`` (the levels searched) and
``searched`` (runs, ranges, whether the whole lattice ran, what was skipped), and ``same_model``: for
an engine that steps another's model (MuJoCo Warp: MuJoCo's), each answer rerun in that engine at
the same settings (``tune_conformance``: ``against``, ``holds``, ``sentence``, ``answers``, one row
per answer), else null.
"""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from .tune import UNIT_STEPS, TuneResult
from .tune_frontier import frontier_sentence, json_value
from .tune_search import DT_RATIO, Grid, agrees

FRAME_COLUMNS = ["stick %", "exit %", "first_impact %", "restitution %", "dt", "settings", "steps_per_sim_s", "margin"]
UNCHECKED = "not run: the budget was spent before this pass's neighbourhood (--max-runs)"


def neighbourhood_fails(c: dict[str, Any], checked: bool = True) -> str:
    """Why a passing candidate is not robust: the neighbours that fail, or, for a pass whose neighbourhood the
    budget left unrun (``robust`` None where neighbourhoods are ``checked``), ``UNCHECKED``; "" otherwise."""
    if c.get("neighbourhood"):
        return c["neighbourhood"]
    return UNCHECKED if checked and agrees(c["verdict"]) and c.get("robust") is None else ""


def fragile_beside(result: TuneResult) -> tuple[dict[str, Any], str] | None:
    """The fragile pass shown beside the answer, and how it compares in cost: "cheaper", or "as cheap" when its steps
    per simulated second are the chosen candidate's or more (no robust answer: the best reachable may be dearer);
    None when there is none, or it is the chosen candidate itself."""
    c, f = result.chosen, result.fragile
    if c is None or f is None or f["settings"] == c["settings"]:
        return None
    return f, ("cheaper" if f["steps_per_sim_s"] < c["steps_per_sim_s"] else "as cheap")


def ladder_text(result: TuneResult) -> str:
    """The ladder's levels in a few words: ``stick 1%..20% x restitution 2%..30% (36 points)``."""
    points = result.extra.get("points") or (result.tolerance,)
    stick = sorted({p.stick for p in points})
    rest = sorted({p.restitution for p in points})
    span = lambda v: f"{100 * v[0]:.3g}%" + (f"..{100 * v[-1]:.3g}%" if len(v) > 1 else "")  # noqa: E731
    return f"stick {span(stick)} x restitution {span(rest)} ({len(points)} points)"


def frontier_line(result: TuneResult) -> str:
    """The answer's first sentence (``tune_frontier.frontier_sentence``)."""
    return frontier_sentence(result.tolerance, result.best is not None, result.frontier, result.extra.get("defaults", {}),
                             ladder_text(result))


def recommended(result: TuneResult) -> dict[str, Any] | None:
    """``recommended.json`` (module docstring); None when no candidate ran."""
    c = result.chosen
    if c is None:
        return None
    keys = [k for k in result.extra["space"] if k != "dt"]
    points = result.extra.get("points") or (result.tolerance,)
    out = {"answer": frontier_line(result), "engine": result.engine, "scene": result.scene.name, "dt": float(c["dt"]),
           "settings": {k: json_value(c[k]) for k in keys}, "robust": bool(result.best is not None),
           "margin": json_value(result.margin), "scene_restitution_ratio": json_value(c.get("scene_restitution_ratio", math.nan)),
           "cost_steps_per_s": json_value(c["steps_per_sim_s"]),
           "verdict": c["verdict"], "failed": c["failed"] or "",
           "neighbourhood_fails": neighbourhood_fails(c, result.extra["searched"]["robustness_checked"]),
           "tolerances": result.tolerance.as_dict(), "frontier": result.frontier,
           "tightest": result.extra.get("tightest", {"stick": None, "restitution": None}),
           "ladder": {"stick": sorted({p.stick for p in points}), "restitution": sorted({p.restitution for p in points})},
           "searched": {**result.extra["searched"], "wall_time_s": round(result.extra["wall_time_s"], 2)}}
    check = result.extra.get("same_model")
    out["same_model"] = None if check is None else {"against": check.against, "holds": check.holds,
                                                    "sentence": check.sentence(), "answers": check.records()}
    f = result.fragile
    out["fragile"] = None if f is None else {"dt": float(f["dt"]), "settings": {k: json_value(f[k]) for k in keys},
                                             "cost_steps_per_s": json_value(f["steps_per_sim_s"]),
                                             "neighbourhood_fails": f["neighbourhood"]}
    return out


def frontier_frame(result: TuneResult) -> pd.DataFrame:
    """The frontier as a table (``FRAME_COLUMNS``): the tolerances in percent, dt, what differs from the engine's
    defaults, steps per simulated second and the margin, cheapest first."""
    defaults = result.extra.get("defaults", {})
    rows = []
    for e in result.frontier:
        tol = e["tolerances"]
        changed = [f"{k.split('.', 1)[-1]}={v}" for k, v in e["settings"].items() if defaults.get(k) != v]
        rows.append({**{f"{k} %": 100 * tol[k] for k in ("stick", "exit", "first_impact", "restitution")},
                     "dt": e["dt"], "settings": ", ".join(changed) or "defaults",
                     "steps_per_sim_s": e["cost_steps_per_s"], "margin": e["margin"]})
    return pd.DataFrame(rows, columns=FRAME_COLUMNS)


def searched_text(result: TuneResult) -> str:
    """How far the search looked, in one sentence: runs, ranges, refinement or the whole lattice, what was skipped,
    budget (the guide and the terminal)."""
    x = result.extra["searched"]
    grid: Grid = result.extra["grid"]
    parts = [f"dt {x['dt'][0]:.3g}..{x['dt'][1]:.3g} s ({x['dt_coarse']} coarse values"
             + (f", {DT_RATIO:g}x apart at the finest)" if x["dt_finest_ratio"] else ")")]
    if grid.knob is not None:
        lo, hi = x[grid.knob]
        parts.append(f"{grid.knob.split('.', 1)[-1]} {lo:.3g}..{hi:.3g} ({x[grid.knob + '_coarse']} coarse values)")
    parts += [f"{k.split('.', 1)[-1]} {'/'.join(f'{v:g}' if isinstance(v, float) else str(v) for v in vals)}"
              for k, vals in grid.others.items()]
    cap = (f"; capped at {x['max_cost']:,.0f} steps per simulated s ({x['capped']} lattice settings dearer, not run)"
           if x.get("max_cost") is not None else "")
    return (f"{x['runs']} runs covering {', '.join(parts)}{cap}; {_coverage(x)}; judged at every point of the ladder "
            f"{ladder_text(result)}; budget {x['max_runs']} runs of up to {UNIT_STEPS:,} steps, "
            f"{x['budget_used']:g} used" + (" (spent)" if x["budget_spent"] else "")
            + ("" if x["robustness_checked"] else "; neighbourhoods not run")
            + (f"; {x['unchecked_passes']} passes left unchecked by the budget, so the frontier is an upper bound "
               "on cost there" if x.get("unchecked_passes") else ""))


def _coverage(x: dict[str, Any]) -> str:
    """Exhaustive (the whole lattice ran) or adaptive, and what the adaptive search skipped."""
    if x.get("exhaustive"):
        return f"exhaustive: every one of the {x['lattice']} lattice settings ran (the lattice fitted the budget)"
    levels = max([lv for lv in x["levels"] if lv > 0], default=0)
    skipped = x["lattice"] - x["lattice_run"]
    costlier = x.get("skipped_costlier", 0)
    return (f"adaptive: {x['lattice_run']} of {x['lattice']} lattice settings ran, refined {levels} of "
            f"{x['refine_depth']} levels where verdicts change at any ladder point and around the best; skipped "
            f"{skipped}: {costlier} dearer than every ladder point's robust answer, {skipped - costlier} not reached "
            "(in cells whose corners agreed at every point, or left by the budget)")
