"""A tune's answer as data and words: ``recommended.json``, the frontier's sentence, and how far the search looked.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> from chatterbench.comparisons.studies.tune.answer import recommended, frontier_line
    >>> from chatterbench.comparisons.studies.tune.ladder import Ladder
    >>> space = {"dt": (4e-3, 2e-3), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.01, space=space, workers=1, refine_steps=0,
    ...               ladder=Ladder(timing=(0.05,), restitution=(0.05,)), phases=(), transfer=False)
    >>> frontier_line(result)                 # the asked 1% has no robust setting here; 5% has
    'no robust setting at stick 1%, restitution 5% in the searched space; robust: stick 5%, restitution 5% at 500 steps/s with dt=0.002'
    >>> rec = recommended(result)
    >>> rec["answer"] == frontier_line(result), rec["frontier"][0]["dt"], rec["tightest"]
    (True, 0.002, {'stick': 0.05, 'restitution': 0.05})
    >>> rec["robust"], rec["dt"], rec["written_tolerances"]["stick"]   # written: the tightest robust point, never a fragile one
    (False, 0.002, 0.05)
    >>> rec["frontier"][0]["files"]           # each point's own script and snippet (``tune --out DIR`` writes them)
    ['frontier/stick5-restitution5/scene.py', 'frontier/stick5-restitution5/snippet.py']

``recommended.json`` opens with ``answer`` (``frontier_line``: whether the asked tolerances
have a robust setting, then what is reachable), then the *written* candidate as ``compare
--engines E --dt DT --set K=V ...`` takes it, with its ``snippet`` (what the guide's Paste shows: every value
a user types): the band-robust recommendation at the asked
tolerances; where there is none, the tightest band-robust frontier point (``written``,
``written_tolerances``: its own tolerances), never a fragile setting, which is listed as
``best_reachable``; only where nothing is robust anywhere, the best reachable itself. Beside it:
``margin`` and ``margin_check`` (the check it is nearest failing), ``checked`` (its band: the
dts, phases, knob neighbours, runs and the share that passed), ``persistence`` (the contact
after each stick: open share and onsets per second), ``transfer`` (``studies.transfer``: the
scene's family, holds or not per variant). ``frontier`` (``tune.frontier.frontier_entries``:
``tolerances``, ``dt``, ``settings``, ``cost_steps_per_s``, ``margin``, ``margin_check``,
``checked``, ``persistence``, ``transfer`` per point, cheapest first, each with its ``snippet``,
every value a user types, and the ``files`` written for it: ``point_record``), ``tightest``
(the tightest sticking and restitution tolerance reached robustly), ``ladder`` (the levels
searched) and ``searched`` (runs, ranges, whether the whole lattice ran, what was skipped, the
band rule), and ``same_model``: for an engine that steps another's model (MuJoCo Warp:
MuJoCo's), each answer rerun in that engine at the same settings (``tune.conformance``:
``against``, ``holds``, ``sentence``, ``answers``, one row per answer), else null.
"""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from .frontier import checked, frontier_sentence, json_value, persistence
from .grid import DT_RATIO, Grid
from .ladder import at_point, level_text
from .result import TuneResult
from .runs import UNIT_STEPS
from .stall import STALL_ROWS, STALL_STEP
from .passes import agrees

FRAME_COLUMNS = ["stick %", "exit %", "first_impact %", "restitution %", "dt", "settings", "steps_per_sim_s", "margin",
                 "margin_check", "band passed", "open after stick", "onsets/s", "transfers"]
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
    """The answer's first sentence (``tune.frontier.frontier_sentence``)."""
    return frontier_sentence(result.tolerance, result.best is not None, result.frontier, result.extra.get("defaults", {}),
                             ladder_text(result))


def recommended(result: TuneResult) -> dict[str, Any] | None:
    """``recommended.json`` (module docstring); None when no candidate ran."""
    c = result.chosen
    if c is None:
        return None
    keys = [k for k in result.extra["space"] if k != "dt"]
    points = result.extra.get("points") or (result.tolerance,)
    point = result.extra["asked"] if result.written is None else result.written
    at = result.chosen_tolerance
    out = {"answer": frontier_line(result), "engine": result.engine, "scene": result.scene.name, "dt": float(c["dt"]),
           "settings": {k: json_value(c[k]) for k in keys},
           "snippet": point_snippet(result.engine, result.scene, float(c["dt"]), {k: json_value(c[k]) for k in keys}),
           "robust": bool(result.best is not None),
           "written": written_text(result), "written_tolerances": at.as_dict(),
           "margin": json_value(result.margin), "margin_check": at_point(c, "limits", point, ""),
           "checked": checked(c, point), "persistence": persistence(c, point, at),
           "transfer": result.extra.get("transfer", []),
           "scene_restitution_ratio": json_value(c.get("scene_restitution_ratio", math.nan)),
           "cost_steps_per_s": json_value(c["steps_per_sim_s"]),
           "verdict": c["verdict"], "failed": c["failed"] or "",
           "neighbourhood_fails": neighbourhood_fails(c, result.extra["searched"]["robustness_checked"]),
           "tolerances": result.tolerance.as_dict(), "frontier": [point_record(result, e) for e in result.frontier],
           "tightest": result.extra.get("tightest", {"stick": None, "restitution": None}),
           "ladder": {"stick": sorted({p.stick for p in points}), "restitution": sorted({p.restitution for p in points})},
           "searched": {**result.extra["searched"], "wall_time_s": round(result.extra["wall_time_s"], 2)}}
    check = result.extra.get("same_model")
    out["same_model"] = None if check is None else {"against": check.against, "holds": check.holds,
                                                    "sentence": check.sentence(), "answers": check.records()}
    r = result.best_reachable if result.written is not None else None
    out["best_reachable"] = None if r is None else {
        "dt": float(r["dt"]), "settings": {k: json_value(r[k]) for k in keys},
        "cost_steps_per_s": json_value(r["steps_per_sim_s"]), "verdict": r["verdict"],
        "neighbourhood_fails": neighbourhood_fails(r, result.extra["searched"]["robustness_checked"])}
    f = result.fragile
    out["fragile"] = None if f is None else {"dt": float(f["dt"]), "settings": {k: json_value(f[k]) for k in keys},
                                             "cost_steps_per_s": json_value(f["steps_per_sim_s"]),
                                             "neighbourhood_fails": f["neighbourhood"]}
    return out


def point_folder(tolerances: dict[str, float]) -> str:
    """Where ``tune --out DIR`` writes a frontier point's files, under ``DIR`` (``DIR/ENGINE`` for several engines):
    ``frontier/stick5-restitution20`` (the tolerances in percent)."""
    return f"frontier/stick{100 * tolerances['stick']:.4g}-restitution{100 * tolerances['restitution']:.4g}"


def point_snippet(engine: str, scene, dt: float, settings: dict[str, Any]) -> str:
    """What a user pastes for ``settings`` at ``dt`` (the engine's snippet: MJCF for MuJoCo with solref and solimp,
    Python for PyBullet with every call): every value typed, none derived by hand; "" for an engine without one."""
    from chatterbench.engines.registry import engine_snippet, make_settings

    return engine_snippet(engine, scene, make_settings(engine, float(dt), dict(settings)))


def point_record(result: TuneResult, entry: dict[str, Any]) -> dict[str, Any]:
    """A frontier entry as ``recommended.json`` writes it: with its ``snippet`` and the ``files`` written for it
    (``outputs.engine_files.write_frontier_files``: the model, the runnable script and the snippet)."""
    from chatterbench.engines.export import export_files_names

    folder = point_folder(entry["tolerances"])
    names = export_files_names(result.engine)
    text = point_snippet(result.engine, result.scene, entry["dt"], entry["settings"])
    suffix = names[0].rsplit(".", 1)[-1] if names else "txt"
    files = [f"{folder}/{n}" for n in names] + ([f"{folder}/snippet.{suffix}"] if text else [])
    return {**entry, "snippet": text, "files": files}


def written_text(result: TuneResult) -> str:
    """What ``recommended.json``'s top level (and the engine files) hold, in words."""
    if result.best is not None:
        return "the robust answer at the asked tolerances"
    if result.written is not None:
        return (f"the tightest robust frontier point ({level_text(result.chosen_tolerance)}): nothing is robust at the "
                "asked tolerances, and a fragile setting is never written (best_reachable lists the closest)")
    return "the best reachable candidate: nothing is robust at any level of the ladder"


def frontier_frame(result: TuneResult) -> pd.DataFrame:
    """The frontier as a table (``FRAME_COLUMNS``): the tolerances in percent, dt, what differs from the engine's
    defaults, steps per simulated second and the margin, cheapest first."""
    defaults = result.extra.get("defaults", {})
    rows = []
    for e in result.frontier:
        tol = e["tolerances"]
        changed = [f"{k.split('.', 1)[-1]}={v}" for k, v in e["settings"].items() if defaults.get(k) != v]
        band, rest = e.get("checked") or {}, e.get("persistence") or {}
        rows.append({**{f"{k} %": 100 * tol[k] for k in ("stick", "exit", "first_impact", "restitution")},
                     "dt": e["dt"], "settings": ", ".join(changed) or "defaults",
                     "steps_per_sim_s": e["cost_steps_per_s"], "margin": e["margin"],
                     "margin_check": e.get("margin_check") or "-",
                     "band passed": (f"{band['passed']:.0%} of {band['runs']} ({band['n_dts']} dts x "
                                     f"{len(band['phases'])} phases, {band['knob_neighbours']} knobs)")
                     if band.get("passed") is not None else "-",
                     "open after stick": _share(rest.get("open_fraction")), "onsets/s": _number(rest.get("onsets_per_s")),
                     "transfers": transfer_count(e.get("transfer"))})
    return pd.DataFrame(rows, columns=FRAME_COLUMNS)


def transfer_count(rows) -> str:
    """How many variants of the scene's family a setting holds on: ``4 of 5 hold``; "-" where none was checked."""
    if not rows:
        return "-"
    return f"{sum(1 for r in rows if r['holds'])} of {len(rows)} hold"


def transfer_lines(result: TuneResult) -> list[str]:
    """What transfers, one line per setting checked (``studies.transfer``): the written answer, then each frontier
    point, each with every variant of the scene's family, holds or not, with the numbers (the guide)."""
    from ..transfer import transfer_sentence
    from .frontier import entry_text

    defaults = result.extra.get("defaults", {})
    lines = []
    if result.extra.get("transfer"):
        lines.append(f"written answer: {transfer_sentence(result.extra['transfer'])}")
    for e in result.frontier:
        if e.get("transfer"):
            lines.append(f"{entry_text(e, defaults)}: {transfer_sentence(e['transfer'])}")
    return lines


def _share(v) -> str:
    return "-" if v is None else f"{v:.2%}"


def _number(v) -> str:
    return "-" if v is None else f"{v:.3g}"


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
    band = f" ({x['band_runs']} of them the band's checks, outside the budget)" if x.get("band_runs") else ""
    if x.get("shared_runs"):
        band += f" ({x['shared_runs']} of them another's run: settings it does not read)"
    return (f"{x['runs']} runs{band} covering {', '.join(parts)}{cap}; {_coverage(x)}; judged at every point of the ladder "
            f"{ladder_text(result)}; budget {x['max_runs']} runs of up to {UNIT_STEPS:,} steps, "
            f"{x['budget_used']:g} used" + (" (spent)" if x["budget_spent"] else "")
            + (f"; robust: passes at {x['band']['rule']}" if x.get("band") else "")
            + (f"; dt refined below the lattice by bisection to {100 * (x['band']['bisection_ratio'] - 1):.2g}% "
               "(between each answer and the next coarser lattice dt)" if (x.get("band") or {}).get("bisection_ratio")
               else "")
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
    stalled = x.get("skipped_stalled") or 0
    return (f"adaptive: {x['lattice_run']} of {x['lattice']} lattice settings ran, refined {levels} of "
            f"{x['refine_depth']} levels where verdicts change at any ladder point and around the best; skipped "
            f"{skipped}: {costlier} dearer than every ladder point's robust answer, "
            + (f"{stalled} finer than dt {x['stalled_dt']:.3g} s, where the grid stalled ({STALL_ROWS} steps of "
               f"{STALL_STEP:.3g}x of dt in a row got no closer to an answer), " if stalled else "")
            + f"{skipped - costlier - stalled} not reached (in cells whose corners agreed at every point, or left by "
            "the budget)")
