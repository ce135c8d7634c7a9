"""``recommended.json``'s keys, read from the code that writes it, each with what it holds.

    >>> from gen_recommended import recommended_markdown, written_keys
    >>> written_keys()[:3]
    ('answer', 'engine', 'scene')
    >>> "<code>frontier</code>" in recommended_markdown()
    True

The keys are found in the source of ``studies.tune.answer.recommended`` (the dict it builds and the
keys it adds after) and, for each frontier point, ``studies.tune.frontier.FRONTIER_KEYS`` with
the keys ``tune.answer.point_record`` and ``studies.transfer`` add. What each holds is written
here (``TOP``, ``POINT``); a key the code writes that has no line here, or a line for a key the
code no longer writes, stops the build (``DocsError``), so the page always lists exactly what
``tune --out`` writes.
"""

from __future__ import annotations

import ast
import inspect

from gen_markup import cell, code, table

from chatterbench.comparisons.studies import transfer
from chatterbench.comparisons.studies.tune import answer as tune_answer
from chatterbench.comparisons.studies.tune.frontier import FRONTIER_KEYS


class DocsError(Exception):
    """The code and its reference page disagree (the build stops, naming what to fix)."""


TOP = {
    "answer": "the answer in one sentence, as the terminal prints it: whether the asked tolerances have a band-robust "
              "setting, then what is reachable (the frontier's points)",
    "engine": "the engine tuned", "scene": "the scene's name",
    "dt": "the written setting's timestep [s]",
    "settings": "the written setting's searched knobs, as compare --set takes them (ENGINE.FIELD: value)",
    "snippet": "every value a user types for the written setting (MuJoCo: MJCF with solref and solimp; PyBullet: its "
               "calls); empty for an engine without a snippet",
    "robust": "true when a band-robust setting passes at the asked tolerances",
    "written": "which candidate the top level holds, in words: the robust answer, the tightest robust frontier point, "
               "or the best reachable when nothing is robust anywhere",
    "written_tolerances": "the tolerances the written setting was judged at (the asked ones, or its frontier point's)",
    "margin": "the worst measured error over its tolerance for the written setting (below 1 passes)",
    "margin_check": "the check that margin is measured on",
    "checked": "what its robustness rests on: the band's dts (range and count), the impact phases, the knob "
               "neighbours, the runs and the share that passed; null where nothing was checked",
    "persistence": "the contact after each stick: the largest open share of the rest, contact onsets per second, "
                   "and the persistence tolerance",
    "transfer": "the answer rerun on the scene's family (energy x0.25, x0.5, x2; masses x0.2, x5): one row per "
                "variant with its verdict, holds, onsets per second, open share, restitution error and reason",
    "scene_restitution_ratio": "effective restitution over R at the scene's own impacts, under its own forces",
    "cost_steps_per_s": "steps per simulated second (1 / dt for a fixed step)",
    "verdict": "the written setting's verdict at its tolerances", "failed": "what failed, if anything",
    "neighbourhood_fails": "the neighbours that fail (a fragile pass), else empty",
    "tolerances": "the asked tolerances, every key compare's --tolerance takes",
    "frontier": "the robust frontier: one entry per point (the table below), cheapest first",
    "tightest": "the tightest sticking and restitution tolerance reached robustly, each at any level of the other "
                "(null: none)",
    "ladder": "the tolerance levels searched: stick and restitution, in fractions",
    "searched": "how far the search looked: runs, band runs, the budget, the dt range, the lattice and how much of it "
                "ran, what was skipped, whether it was exhaustive, the band rule, batched runs, shared_runs (rows that took "
                "another candidate's run: settings that run does not read), wall time [s]",
    "same_model": "for an engine that steps another's model (MuJoCo Warp: MuJoCo's), each answer rerun there: "
                  "against, holds, sentence, answers (one row per answer); null otherwise",
    "best_reachable": "where nothing is robust at the asked tolerances: the closest fragile candidate (dt, settings, "
                      "cost, verdict, the neighbours that fail), never written as the answer; else null",
    "fragile": "a cheaper (or as cheap) pass whose neighbours fail, shown beside the answer; null when none",
}
POINT = {
    "tolerances": "the point's tolerances, every key compare's --tolerance takes",
    "dt": "its timestep [s]", "settings": "its searched knobs (ENGINE.FIELD: value)",
    "cost_steps_per_s": "steps per simulated second", "margin": "the worst measured error over its tolerance",
    "margin_check": "the check the margin is measured on",
    "checked": "the band it passed: dts, phases, knob neighbours, runs, the share that passed",
    "persistence": "the contact after each stick at that point (open share, onsets per second, tolerance)",
    "transfer": "the point rerun on the scene's family, as the top level's transfer",
    "snippet": "every value a user types for this point", "files": "the files tune --out wrote for it, relative to "
                                                               "the folder (frontier/stickS-restitutionR/...)",
}


def written_keys() -> tuple[str, ...]:
    """recommended.json's top-level keys, in the order ``recommended`` writes them."""
    tree = ast.parse(inspect.getsource(tune_answer.recommended))
    function = tree.body[0]
    out = next(n for n in ast.walk(function) if isinstance(n, ast.Assign)
               and isinstance(n.targets[0], ast.Name) and n.targets[0].id == "out")
    keys = [k.value for k in out.value.keys]
    keys += [n.targets[0].slice.value for n in ast.walk(function) if isinstance(n, ast.Assign)
             and isinstance(n.targets[0], ast.Subscript) and isinstance(n.targets[0].value, ast.Name)
             and n.targets[0].value.id == "out"]
    return tuple(dict.fromkeys(keys))


def point_keys() -> tuple[str, ...]:
    """A frontier point's keys: ``FRONTIER_KEYS``, ``transfer`` where ``studies.transfer`` adds it, and what
    ``point_record`` adds (its returned dict's own keys)."""
    added = ast.parse(inspect.getsource(transfer))
    by_transfer = [n.targets[0].slice.value for n in ast.walk(added) if isinstance(n, ast.Assign)
                   and isinstance(n.targets[0], ast.Subscript) and isinstance(n.targets[0].value, ast.Name)
                   and n.targets[0].value.id == "entry" and isinstance(n.targets[0].slice, ast.Constant)]
    record = ast.parse(inspect.getsource(tune_answer.point_record))
    returned = next(n.value for n in ast.walk(record) if isinstance(n, ast.Return))
    by_record = [k.value for k in returned.keys if k is not None]
    return tuple(dict.fromkeys([*FRONTIER_KEYS, *by_transfer, *by_record]))


def _rows(keys: tuple[str, ...], meanings: dict[str, str], where: str) -> list[list[str]]:
    undocumented = [k for k in keys if k not in meanings]
    gone = [k for k in meanings if k not in keys]
    if undocumented or gone:
        raise DocsError(f"recommended.json{where}: keys written with no line in docs/hooks/gen_recommended.py: "
                        f"{undocumented}; lines for keys no longer written: {gone}")
    return [[code(k), cell(meanings[k])] for k in keys]


def recommended_markdown() -> str:
    """The two tables: the top level, then a frontier point."""
    return "\n".join(["### The top level", "", table(["key", "what it holds"], _rows(written_keys(), TOP, "")), "",
                      "### Each point of `frontier`", "",
                      table(["key", "what it holds"], _rows(point_keys(), POINT, "'s frontier points"))])
