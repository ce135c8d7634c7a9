"""The tuning guide's answer in words: the recommendation or what is reachable, each check's margin, the frontier's
note, and where the chosen settings give R under the scene's forces (Markdown sentences; ``guide`` lays them out).

    >>> from chatterbench.comparisons.outputs.guide_answer import fmt
    >>> fmt(0.012345), fmt(float("inf")), fmt(3)      # every number of the guide: 3 significant digits
    ('0.0123', 'inf', '3')
"""

from __future__ import annotations

import math

import pandas as pd

from chatterbench.comparisons.studies.tune.answer import fragile_beside, frontier_line
from chatterbench.comparisons.studies.tune.checks import CHECKS, misses_of, strike_summary
from chatterbench.comparisons.studies.tune.choice import passing
from chatterbench.comparisons.studies.tune.ladder import level_text
from chatterbench.engines.export import export_files_names


def fmt(v) -> str:
    """A number as the guide writes it: 3 significant digits, inf and nan spelled out; anything else as text."""
    if isinstance(v, float):
        return "inf" if math.isinf(v) else ("nan" if math.isnan(v) else f"{v:.3g}")
    return str(v)


def answer_sentences(result, ev=None) -> list[str]:
    """The answer's sentences (Markdown; the HTML page converts the code spans)."""
    c = result.chosen
    if c is None:
        return ["No candidate ran: every one was refused (see the table)."]
    cost = (f"{fmt(c['steps_per_sim_s'])} steps per simulated second, {fmt(c['cost_per_sim_s'])} s of wall clock "
            f"per simulated second (the least of {int(c['cost_repeats'])} timed run{'s' if c['cost_repeats'] != 1 else ''})")
    band = result.extra["searched"].get("band") or {}
    rule = band.get("rule", "dt x 0.8 and x 1.25 and the knobs' neighbours")
    if result.best is not None:
        head = [f"**Recommended (band-robust):** `{c['settings']}`: {_episodes_pass(c['n_episodes'])} ({c['verdict']}), "
                f"and so does every run of its band: {rule} (the map's knob: its adjacent searched values; every other "
                "real-valued knob: half-way to its adjacent searched values); "
                f"margin {fmt(result.margin)} (its worst measured error over its tolerance among the judge's checks); "
                f"cost {cost}."]
        if result.frontier:
            head.append(f"{_sentence(result)}.")
        n_fragile = len(result.cheaper(fragile=True))
        if n_fragile:
            head.append(f"{n_fragile} cheaper or as cheap candidates pass but are fragile (a neighbour fails): see the "
                        "table of every candidate, column \"neighbours that fail\".")
    elif result.written is not None:
        r = result.best_reachable
        head = [f"**No robust setting passes these tolerances in the searched space.** {_sentence(result)}.",
                f"**Written (band-robust at {level_text(result.chosen_tolerance)}, the tightest robust frontier point):** "
                f"`{c['settings']}`, robust there: {rule}; margin {fmt(result.margin)} at those tolerances; cost "
                f"{cost}. The model, script and snippet below are this setting's."]
        if r is not None:
            why = (f"its neighbours fail: {r['neighbourhood']}" if r.get("neighbourhood") else f"it fails: {r['failed']}")
            head.append(f"Best reachable at the asked tolerances (fragile, never written): `{r['settings']}`, "
                        f"{r['n_match']} of {r['n_episodes']} episodes match; {why}.")
    else:
        why = (f"its neighbours fail: {c['neighbourhood']}" if c.get("neighbourhood") else f"it fails: {c['failed']}")
        head = [f"**No robust setting passes these tolerances in the searched space.** {_sentence(result)}.",
                f"Best reachable: `{c['settings']}`, {c['n_match']} of {c['n_episodes']} episodes match, verdict "
                f"{c['verdict']}; {why}; cost {cost}."]
    if (beside := fragile_beside(result)) is not None:
        f, than = beside
        head.append(f"**Fragile ({than}, but an isolated pass):** `{f['settings']}` passes at "
                    f"{fmt(f['steps_per_sim_s'])} steps per simulated second (the {'answer' if result.best is not None else 'best reachable'}: "
                    f"{fmt(c['steps_per_sim_s'])}), but its neighbours fail ({f['neighbourhood']}): "
                    "a small change of the model can land on a failure.")
    return head + [_ratios_sentence(c)] + _restitution_claim(result, ev)


def _episodes_pass(n: int) -> str:
    """"all 3 episodes pass", "its one episode passes", or what passing means with none (the answer's words)."""
    n = int(n)
    if n == 0:
        return "no episode to judge, none in the reference either"
    return "its one episode passes" if n == 1 else f"all {n} episodes pass"


def _ratios_sentence(c: dict) -> str:
    """Each check's worst error over its tolerance, and the checks with nothing to measure named as such."""
    ratios = {short: c.get(f"{name}_ratio", math.nan) for name, (*_, short) in CHECKS.items()}
    measured = [f"{short} {fmt(r)}" for short, r in ratios.items() if not (isinstance(r, float) and math.isnan(r))]
    unmeasured = [short for short, r in ratios.items() if isinstance(r, float) and math.isnan(r)]
    text = f"Each check's worst error over its tolerance (1 = at the tolerance): {', '.join(measured) or 'none measured'}"
    if unmeasured:
        text += (f"; nothing to measure for {', '.join(unmeasured)} (no such event in the run's episodes, or none the "
                 "step measures to its tolerance: e.g. no exit when nothing slides off, the restitution section below)")
    return text + "."


def _sentence(result) -> str:
    """The frontier's sentence with a capital, for the guide."""
    line = frontier_line(result)
    return line[:1].upper() + line[1:]


TRANSFER_NOTE = ("Each setting rerun, at its own tolerances, on the scene's family: the initial energy x 0.25, x 0.5 "
                 "and x 2 (drop height, forcing amplitude or initial speed) and the masses x 0.2 and x 5, each for at "
                 "least 10 s where the scene has no forcing period; it holds where every episode agrees (persistence "
                 "included).")


def frontier_note(result) -> str:
    """What the frontier is, and the tightest levels reached (one paragraph)."""
    reach = result.extra.get("tightest", {})
    pct = lambda v: "none" if v is None else f"{100 * v:.3g}%"  # noqa: E731
    rule = (result.extra["searched"].get("band") or {}).get("rule", "dt x 0.8 and x 1.25 and the knobs' neighbours")
    return ("Each row is the cheapest band-robust setting at its tolerances (it and every run of its band "
            f"pass there: {rule}; `band passed` counts them), judged at those tolerances, with its contact after each "
            "stick (`open after stick`: the share of the rest it is open, `onsets/s`: contact onsets per second), so "
            "`compare` with "
            "them and the row's settings says `match`; a level another row reaches as tightly and as cheaply is left "
            f"out. Tightest reached robustly: stick {pct(reach.get('stick'))}, restitution {pct(reach.get('restitution'))} "
            "(each at any level of the other; exit and first impact move with stick in the asked proportions).")


def _restitution_claim(result, ev=None) -> list[str]:
    """Where the chosen settings give R under the scene's own forces at every place in a step, with the numbers where
    they miss, and the run's own impacts as the judge measures them (Markdown; ``ev``: the evidence, whose strikes
    cover every resolved impact, else the chosen row's, the check's)."""
    c = result.chosen
    tol = result.tolerance
    r = strike_summary(misses_of(ev.strikes, tol)) if ev is not None and ev.strikes is not None else c
    runs = _run_impacts(result, ev)
    if not isinstance(r.get("r_struck"), str) or not r["r_struck"]:
        return runs
    holds, held = r["r_holds_from"], r["r_held_from"]
    where = (f"Struck under the scene's own forces from the reference's state before each impact the judge resolves "
             f"({r['r_struck']}), these settings give")
    if holds == 0.0:
        return [f"**Restitution under the scene's forces:** {where} e within {100 * tol.restitution:g}% of R = "
                f"{result.scene.restitution:g} at every one, wherever in a step it falls."] + runs
    span = (f"at {holds:.3g} m/s and faster, wherever in a step the impact falls; slower, they miss at some place in "
            f"the step (e over its places): {r['r_misses']}" if math.isfinite(holds)
            else f"at none of them wherever in a step the impact falls (e over the step's places): {r['r_misses']}")
    held_text = (f"The judge holds a time-stepper at dt = {c['dt']:g} s to R at {held:.3g} m/s and faster (there its "
                 "sampling uncertainty is within the tolerance)")
    if not math.isfinite(held):
        counted = (f"At dt = {c['dt']:g} s the judge's sampling uncertainty exceeds the tolerance at every one of these "
                   "impacts, so none counts against a candidate.")
    elif c.get("scene_restitution_ratio", math.nan) > 1.0:
        n_ok = table_meets_r(result.table)
        counted = (f"{held_text}, and there these settings miss: that counts against a candidate, and "
                   + (f"{n_ok} passing candidates tried meet R there." if n_ok else
                      "none of the passing candidates tried meets R there."))
    else:
        counted = f"{held_text}, and there these settings meet R; the misses are at slower impacts."
    return [f"**Restitution under the scene's forces:** {where} e within {100 * tol.restitution:g}% of R = "
            f"{result.scene.restitution:g} {span}. {counted}"] + runs


RUN_IMPACTS_LISTED = 12  # the run's first resolved impacts the guide lists (and its worst, when later)


def _run_impacts(result, ev) -> list[str]:
    """The run's resolved impacts as the judge measures them, which the exported scripts print too (Markdown)."""
    if ev is None or not len(ev.impacts):
        return []
    rows = ev.impacts[(ev.impacts["impact"] <= RUN_IMPACTS_LISTED) | ev.impacts["worst"]]
    listed = "; ".join(f"#{int(row.impact)} at t = {row.t:.4f} s, {row.speed:.3g} m/s: e = {row.restitution_effective:.4f}"
                       + (" (the report's restitution error)" if row.worst else "") for row in rows.itertuples())
    files = export_files_names(result.engine)
    printed = f" (`{result.engine}/{files[-1]}` prints each of them, the same e)" if files else ""
    more = len(ev.impacts) - len(rows)
    return [f"**The run's impacts:** its resolved impacts as the judge measures them{printed}: {listed}"
            + (f"; and {more} more." if more > 0 else ".")]


def table_meets_r(table: pd.DataFrame) -> int:
    """How many passing candidates of a tune table also meet R under the scene's forces where the judge holds them."""
    return int((passing(table["verdict"]) & ~(table["scene_restitution_ratio"] > 1.0)).sum())
