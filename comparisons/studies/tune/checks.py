"""How far a judged run is from each of the judge's checks: every error over its tolerance, and which checks failed.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune.checks import check_ratios, Tolerances, describe_failures
    >>> from chatterbench.comparisons.pipeline.compare import judge_run
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> from chatterbench.engines.registry import make_settings
    >>> ref, tol = solve(load_scene("feigin-pair", ["duration=12.6"])), Tolerances(stick=0.01, exit=0.01, first_impact=0.01)
    >>> run, table, impacts = judge_run(ref, "mujoco", make_settings("mujoco", 1e-3, ["mujoco.w0_dt=0.1"]), tol)
    >>> ratios = check_ratios(table, impacts, tol, tol.penetration * ref.length_scale)
    >>> round(ratios["stick_ratio"], 1), describe_failures(table, ratios, tol)    # 12% late against 1%
    (12.2, 'sticking error +0.122 of the chatter > 0.01; restitution error 0.146 > 0.05; contact open after the stick 0.0334 of the rest > 0.01')

A ratio is the check's measure over its tolerance (``Tolerances``), taken over the run's
episodes at their worst, so a ratio above 1 is a failed check and ``worst_ratio`` (the largest)
is the run's distance from passing in one number: the same rules as ``pipeline.verdict_rules.verdict``
(stick and first impact against the chatter duration, exit against the sliding duration,
restitution of the impacts the step can measure to the tolerance, the resolved-impact count, the penetration
against the scene's length scale, the contact's open share of the rest after each stick against ``persistence``),
and one the judge cannot make from a whole run:
**restitution under the scene's forces** (``scene_restitution``), the worst e / R - 1 of the
settings struck from the reference's state before each impact the judge resolves where its
sampling uncertainty is within the restitution tolerance (where it holds a time-stepper to R),
each at ``STRIKES`` places in a step (``scene_strikes``): a run's impacts fall anywhere in a step
and carry the drift of the run, and where in a step an impact falls moves e (MuJoCo's
spring-damper at w0 dt = 0.1, dt = 3e-4 gives e = 0.436 to 0.467, -12.8% to -6.7%, at the
ball's 0.277 m/s under gravity over the step; the whole run's 5th impact there measures 0.452,
-9.6%). A run with an episode that has no error to measure
(``missed``, ``endless``, ``spurious``, a failure, or ``unmeasured``: no resolved impact measurable to the
restitution tolerance) has ``worst_ratio`` = inf: no tolerance of the other checks makes it pass.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from ...pipeline.solution import ReferenceSolution
from ...pipeline.tolerances import Tolerances
from ...pipeline.vocabulary import UNDETERMINED, VERDICTS
from ..restitution_curve import pinned_settings
from ..scene_restitution import Misses, miss_summary, scene_restitution

# check -> (the Tolerances field, how the guide names the measure, the scale it is a fraction of, a short name)
CHECKS = {
    "stick": ("stick", "sticking error", " of the chatter", "sticking"),
    "first_impact": ("first_impact", "first impact error", " of the chatter", "first impact"),
    "exit": ("exit", "exit error", " of the sliding", "exit"),
    "restitution": ("restitution", "restitution error", "", "restitution"),
    "impact_count": ("impact_count", "resolved impacts differ by", "", "resolved impact count"),
    "penetration": ("penetration", "penetration", " of the length scale", "penetration"),
    "persistence": ("persistence", "contact open after the stick", " of the rest", "persistence"),
    "scene_restitution": ("restitution", "restitution under the scene's forces", "", "restitution under the scene's forces"),
}
RATIO_COLUMNS = [f"{name}_ratio" for name in CHECKS] + ["worst_ratio"]
# where the strikes under the scene's forces (scene_strikes: at every phase of a step) meet R: r_holds_from [m/s]
# (every faster strike within the tolerance at every phase; 0: all, inf: none), r_held_from [m/s] (the slowest strike
# the judge holds to R), r_struck ("N impacts, V1 to V2 m/s, each at 10 places in a step"), r_misses (the strikes beyond
# the tolerance at some place in a step, their bands in words); NaN / "" without strikes
STRIKE_COLUMNS = ["r_holds_from", "r_held_from", "r_struck", "r_misses"]
MEASURED = ("agree", "timing", "impacts")  # verdict groups whose episodes have every error measured
MEASURED_TOO = ("buzz",)  # and the verdicts of other groups that have theirs: a buzz's open share (persistence)


def _no_error(verdict: str) -> bool:
    """Whether an episode of this verdict has an error left unmeasured (no tolerance of the checks makes it pass): a
    verdict outside the measured groups, or an undetermined one (``unresolved``: a time the samples cannot pin to
    its tolerance; ``unmeasured``: no resolved impact the step can measure), in a measured group but not measured."""
    return verdict in VERDICTS and verdict not in MEASURED_TOO and (VERDICTS[verdict].group not in MEASURED
                                                                     or verdict in UNDETERMINED)


def _ratio(value: float, limit: float) -> float:
    if math.isnan(value):
        return math.nan
    if limit == 0:
        return math.inf if value > 0 else 0.0
    return abs(value) / limit


def check_values(table: pd.DataFrame, impacts: pd.DataFrame, allowance: float,
                 misses: Misses | None = None) -> dict[str, float]:
    """Each check's worst measure over the episodes (signed for the timing errors: + late, - early).

    ``table``: the judged episodes (``judge.TABLE_COLUMNS``); ``impacts``: the paired impacts
    (``judge.IMPACT_PAIR_COLUMNS``, column ``excess`` = |e / R - 1| of a measurable impact, NaN otherwise);
    ``allowance``: the penetration allowance [m] (tolerance x the scene's length scale);
    ``misses``: the run's settings struck under the scene's forces, summed up against the restitution tolerance
    (``misses_of``), whose worst signed e / R - 1 among the strikes the judge holds to R is ``scene_restitution``,
    at ``scene_restitution_speed`` [m/s].
    """
    columns = {c: table[c].to_numpy() for c in CHECK_COLUMNS if c in table}
    excess = impacts["excess"].to_numpy() if "excess" in impacts else np.empty(0)
    return values_of(columns, excess, allowance, misses)


def misses_of(strikes: pd.DataFrame | None, tol: Tolerances) -> Misses | None:
    """The strikes ``strikes`` (``scene_strikes``) against the restitution tolerance (``miss_summary``), made once for
    the checks (``check_ratios``) and the row's words (``strike_summary``); None without strikes."""
    return miss_summary(strikes, tol.restitution) if strikes is not None and len(strikes) else None


# the judged table's columns the checks read (``values_of``)
CHECK_COLUMNS = ("wall", "stick_error_rel", "first_impact_error_rel", "exit_error_rel", "resolved_impacts",
                 "ref_resolved_impacts", "penetration_max", "open_fraction")


def _finite(values) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    return values[~np.isnan(values)]


def _max(values) -> float:
    """The largest of ``values`` that is not NaN (NaN: none), as pandas' ``max`` gives."""
    values = _finite(values)
    return float(values.max()) if len(values) else math.nan


def _worst_signed(values) -> float:
    """``summary.worst_signed`` of an array: the entry of largest magnitude, with its sign (the first of equal ones)."""
    values = _finite(values)
    return float(values[np.abs(values).argmax()]) if len(values) else math.nan


def values_of(columns: dict[str, np.ndarray], excess: np.ndarray, allowance: float,
              misses: Misses | None = None) -> dict[str, float]:
    """``check_values`` from the judged table's ``CHECK_COLUMNS`` as arrays (shape (n_rows,), in the table's order;
    ``wall``, ``open_fraction`` may be absent) and the paired impacts' ``excess`` (shape (n_pairs,)): what a ladder
    judge (``pipeline.prepared``) gives without a table."""
    n_rows = len(columns["penetration_max"])
    keep = columns["wall"] != "" if "wall" in columns else np.ones(n_rows, dtype=bool)
    eps = {c: np.asarray(v)[keep] for c, v in columns.items()}
    counts = np.abs(np.asarray(eps["resolved_impacts"], dtype=float) - np.asarray(eps["ref_resolved_impacts"], dtype=float))
    return {
        "stick": _worst_signed(eps["stick_error_rel"]), "first_impact": _worst_signed(eps["first_impact_error_rel"]),
        "exit": _worst_signed(eps["exit_error_rel"]), "restitution": _max(excess),
        "impact_count": _max(counts),
        "penetration": _max(columns["penetration_max"]) / allowance if allowance > 0 and n_rows else math.nan,
        "persistence": _max(eps["open_fraction"]) if "open_fraction" in eps else math.nan,
        "scene_restitution": misses.value if misses else math.nan,
        "scene_restitution_speed": misses.speed if misses else math.nan,
    }


def scene_strikes(engine: str, settings: Any, solution: ReferenceSolution, tol: Tolerances,
                  record: dict[str, Any] | None = None, held_only: bool = True) -> pd.DataFrame:
    """The settings struck under the scene's own forces at the impacts the judge resolves, at ``STRIKES`` places in a
    step each (``scene_restitution``): for the check, only where the judge holds a run to R (``held_only``: sampling
    uncertainty within the restitution tolerance; the others cannot count against a candidate), every one for a claim.

    ``record``: the whole run's ``Trajectory.settings``, to pin what an engine made from the scene
    (``pinned_settings``: Drake's contact), so that every strike meets the contact the run had.
    """
    settings = pinned_settings(settings, record) if record else settings
    return scene_restitution(engine, settings, solution, tol.resolved_steps,
                             most_uncertain=tol.restitution if held_only else math.inf)


def strike_summary(m: Misses | None) -> dict[str, Any]:
    """``STRIKE_COLUMNS`` of the strikes against the restitution tolerance (``misses_of``; None: no strikes)."""
    if m is None:
        return {"r_holds_from": math.nan, "r_held_from": math.nan, "r_struck": "", "r_misses": ""}
    v = m.strikes["speed"]
    impacts, phases = m.strikes.groupby(["impact", "speed"]).ngroups, m.strikes.groupby(["impact", "speed"]).size().max()
    return {"r_holds_from": m.holds_from, "r_held_from": m.held_from,
            "r_struck": f"{impacts} impacts, {v.max():.3g} to {v.min():.3g} m/s, each at {phases} places in a step"
            if len(v) else "", "r_misses": m.describe()}


def check_ratios(table: pd.DataFrame, impacts: pd.DataFrame, tol: Tolerances, allowance: float,
                 misses: Misses | None = None) -> dict[str, float]:
    """``<check>_ratio``: each check's worst measure over its tolerance (> 1: failed), and ``worst_ratio``;
    ``misses``: the strikes under the scene's forces against ``tol.restitution`` (``misses_of``)."""
    return ratios_of(check_values(table, impacts, allowance, misses), tol, table["verdict"])


def ratios_of(values: dict[str, float], tol: Tolerances, verdicts) -> dict[str, float]:
    """``check_ratios`` from the checks' measures (``check_values``, ``values_of``) and the table's verdicts."""
    out = {}
    for name, (field, _, _, _) in CHECKS.items():
        limit = 1.0 if name == "penetration" else float(getattr(tol, field))  # penetration is already a fraction of the allowance
        out[f"{name}_ratio"] = _ratio(values[name], limit)
    unmeasured = any(_no_error(v) for v in verdicts)
    finite = [r for r in out.values() if not math.isnan(r)]
    out["worst_ratio"] = math.inf if unmeasured or not len(verdicts) else (max(finite) if finite else 0.0)
    return {**out, **{f"{name}_value": v for name, v in values.items()}}


# checks a margin is measured on: the judge's, but the resolved-impact count (an integer: "one impact short" is a
# ratio of 1.0 whatever the run, no measure of room) and restitution under the scene's forces (the judge has none)
MARGIN_CHECKS = tuple(name for name in CHECKS if name not in ("impact_count", "scene_restitution"))


def judged_margin(ratios: dict[str, Any]) -> float:
    """The worst measured error over its tolerance among the judge's checks (``check_ratios``'s dict or a tune row)
    [-], ``MARGIN_CHECKS``: <= 1 passes, the smaller the more room; inf for an episode with no error to measure."""
    return margin_and_check(ratios)[0]


def margin_and_check(ratios: dict[str, Any]) -> tuple[float, str]:
    """``judged_margin`` and the check that sets it (``CHECKS``' short name: "sticking", "restitution", ...; "" for
    none measured, "unmeasured" for an episode with no error to measure)."""
    if not math.isfinite(ratios["worst_ratio"]):
        return math.inf, "unmeasured"
    judged = [(float(ratios.get(f"{name}_ratio", math.nan)), CHECKS[name][3]) for name in MARGIN_CHECKS]
    judged = [(r, name) for r, name in judged if not math.isnan(r)]
    return max(judged) if judged else (0.0, "")


def describe_failures(table: pd.DataFrame, ratios: dict[str, Any], tol: Tolerances) -> str:
    """The checks that failed, each with its measure and tolerance, and the episodes with no measure; "" if none.

    ``ratios`` is ``check_ratios``'s dict (it carries the measures as ``<check>_value``).
    """
    parts = []
    for name, (field, label, scale, _) in CHECKS.items():
        ratio = ratios.get(f"{name}_ratio", math.nan)
        if math.isnan(ratio) or ratio <= 1.0:
            continue
        value, limit = ratios[f"{name}_value"], getattr(tol, field)
        if name == "impact_count":
            parts.append(f"{label} {value:.0f} > {limit}")
        elif name == "penetration":
            parts.append(f"{label} {value * tol.penetration:.3g}{scale} > {tol.penetration:g}")
        elif name in ("restitution", "persistence"):
            parts.append(f"{label} {value:.3g}{scale} > {limit:g}")
        elif name == "scene_restitution":
            parts.append(f"{label} {value:+.3g} at {ratios['scene_restitution_speed_value']:.3g} m/s > {limit:g}")
        else:
            parts.append(f"{label} {value:+.3g}{scale} > {limit:g}")
    verdicts = table["verdict"].value_counts()
    for verdict, n in verdicts.items():
        if _no_error(verdict):
            parts.append(f"{n} {'episode' if n == 1 else 'episodes'} {verdict} ({VERDICTS[verdict].meaning})")
    return "; ".join(parts)
