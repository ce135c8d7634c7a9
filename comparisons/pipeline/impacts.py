"""The impacts themselves: pair the resolvable impacts of a visit and measure each engine impact's restitution.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.impacts import pair_impacts, reference_flights
    >>> from chatterbench.comparisons import reference_trajectory
    >>> from chatterbench.comparisons.pipeline.extract import extract
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> ref = solve(load_scene("bouncing-ball"))
    >>> found = extract(reference_trajectory(ref.scene, 1e-3, ref.exhaustive), ref.scene)   # the known answer
    >>> visit = ref.episodes.iloc[0]
    >>> ref_visit = ref.visit_impacts(visit)
    >>> pairs = pair_impacts(ref_visit, reference_flights(ref_visit, visit.t_stick), found.impacts, dt=1e-3,
    ...                      resolved_steps=10, restitution=0.5, tolerance=0.05)
    >>> pairs.resolved, pairs.ref_resolved, pairs.measured, abs(pairs.worst_error) < 1e-6
    (6, 6, 6, True)

A time-stepper at step dt cannot resolve an impact whose flight is a few steps long, so
only the *resolved* impacts are judged: those whose flight after the impact (to the next
impact on the same wall; for a soft contact, from the contact's release) lasts at least
``resolved_steps`` x dt as the samples see it on both sides: measured between the two
impacts, and as long as the rebound speed and the next impact's incoming speed each imply
(2 |v| / |y''|, ``extract.py``'s ``flight_seen``). A "flight" that spans bounces too short
for the samples to see (the tail of a ladder summed up between two samples) is not one.
The reference's flights come from its exact events. Feigin's ladder is geometric, so the
resolved impacts are the first ones of each visit, on both sides. The k-th resolved impact
of the engine's visit is paired with the k-th of the reference's, in time order.

Effective restitution of an engine impact: e = -v+ / v- (the rebound over the incoming
relative speed; for a contact, where the body crosses the wall's undeformed surface on its
way out over on its way in, ``surface.py``: what the flights before and after see). Its error is
relative to the scene's R: e / R - 1 (for R = 0, e itself). Each speed is known to within
``v_error`` (``extract.py``): for an impact between two free samples, located by the free
parabola, the change of y'' over the step times the step; for a contact, which takes an
unknown part of the steps it starts and ends in, |y''| dt. So e is known to within
u = (1 + e) v_error / (R |v-|)
relative (``restitution_uncertainty``). The allowance is the tolerance itself, never widened
by u: an impact with u <= tolerance is *measurable* and departs from R when |e / R - 1| >
tolerance; one with u > tolerance is *unmeasured*: the step cannot tell whether it follows
R, so it is counted (``unmeasured``) and neither passes nor fails. ``excess`` = |e / R - 1|
of a measurable pair (NaN for an unmeasured one); the visit's ``worst_error`` is the signed
error of the measurable pair with the largest (negative: the engine loses more than R says);
``measured`` and ``unmeasured`` count the pairs of each kind.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import pandas as pd

from .sample_grid import at_least_steps

PAIR_COLUMNS = ["k", "ref_t", "t", "ref_v_minus", "v_minus", "ref_restitution", "restitution", "restitution_error",
                "restitution_uncertainty", "measurable", "excess"]


@dataclass(frozen=True)
class ImpactPairs:
    """The resolved impacts of one visit, paired (``PAIR_COLUMNS``), and what they add up to."""

    columns: dict  # PAIR_COLUMNS -> array, one entry per pair: k, times [s], speeds [m/s] (> 0), restitutions [-], error [-]
    resolved: int  # resolved engine impacts of the visit
    ref_resolved: int  # resolved reference impacts of the visit
    worst_error: float  # signed relative restitution error of the measurable pair with the largest |error| (NaN: none)
    worst_excess: float  # |error| of that pair [-] (NaN: no measurable pair)
    unmeasured: int = 0  # paired engine impacts whose uncertainty exceeds the tolerance
    measured: int = 0  # paired engine impacts measurable to the tolerance

    @functools.cached_property
    def table(self) -> pd.DataFrame:
        """The pairs as a table (``PAIR_COLUMNS``), one row per pair; made when asked (a judge joins the columns of
        every visit into one table instead)."""
        return pd.DataFrame(self.columns, columns=PAIR_COLUMNS)

    def __len__(self) -> int:
        return len(self.columns["k"]) if self.columns else 0


def reference_flights(impacts: pd.DataFrame, t_end: float) -> np.ndarray:
    """Flight after each reference impact of a visit [s]: to the next one, the last to ``t_end`` (its Zeno point)."""
    t = impacts["t"].to_numpy(dtype=float)
    return np.diff(np.append(t, t_end)) if len(t) else np.empty(0)


def restitution_error(e: np.ndarray, restitution: float) -> np.ndarray:
    """e / R - 1, or e itself for R = 0 (module docstring)."""
    return e / restitution - 1.0 if restitution > 0 else np.asarray(e, dtype=float)


def pair_impacts(ref_impacts: pd.DataFrame | Mapping, ref_flights: np.ndarray, eng_impacts: pd.DataFrame | Mapping, dt: float,
                 resolved_steps: float, restitution: float, tolerance: float) -> ImpactPairs:
    """Pair the resolved impacts of one visit (module docstring).

    Parameters
    ----------
    ref_impacts : DataFrame, or mapping column -> array
        The reference's impacts of the visit (log rows: ``t``, ``v_minus``, ``v_plus``), by time.
    ref_flights : ndarray, shape (len(ref_impacts),)
        Flight after each of them [s] (``reference_flights``).
    eng_impacts : DataFrame, or mapping column -> array
        The engine's impacts of the visit (``extract.IMPACT_COLUMNS``: ``t``, ``v_minus``,
        ``v_plus``, ``flight_seen``, ``v_error``), by time.
    dt : float
        The engine's timestep [s].
    tolerance : float
        The restitution tolerance [-]: the allowance, and the largest uncertainty an impact may have to be measured.
    """
    ref_kept = at_least_steps(ref_flights, resolved_steps, dt)  # exactly resolved_steps steps, rounded: resolved
    flights = np.asarray(eng_impacts["flight_seen"], dtype=float)
    eng_kept = at_least_steps(np.nan_to_num(flights, nan=-1.0), resolved_steps, dt)
    n_ref, n_eng = int(ref_kept.sum()), int(eng_kept.sum())
    n = min(n_ref, n_eng)
    rows = []
    if n:  # the first n resolved of each, as arrays (a visit's pandas rows cost more than the pairing)
        r = {c: np.asarray(ref_impacts[c], dtype=float)[ref_kept][:n] for c in ("t", "v_minus", "v_plus")}
        e = {c: np.asarray(eng_impacts[c], dtype=float)[eng_kept][:n] for c in ("t", "v_minus", "v_plus", "v_error")}
        with np.errstate(divide="ignore", invalid="ignore"):
            e_ref = -r["v_plus"] / r["v_minus"]
            e_eng = -e["v_plus"] / e["v_minus"]
        err = restitution_error(e_eng, restitution)
        v_in = np.abs(e["v_minus"])
        with np.errstate(divide="ignore", invalid="ignore"):
            # e / R - 1 moves by de / R (by de itself for R = 0, where the error is e)
            unc = (1.0 + np.abs(e_eng)) * e["v_error"] / ((restitution if restitution > 0 else 1.0) * v_in)
        unc = np.where(np.isfinite(unc), unc, np.inf)
        rows = {"k": np.arange(n), "ref_t": r["t"], "t": e["t"],
                "ref_v_minus": np.abs(r["v_minus"]), "v_minus": v_in,
                "ref_restitution": e_ref, "restitution": e_eng, "restitution_error": err,
                "restitution_uncertainty": unc}
    return measured_at(ImpactPairs(columns=rows if n else {}, resolved=n_eng, ref_resolved=n_ref, worst_error=math.nan,
                                   worst_excess=math.nan), tolerance)


def measured_at(pairs: ImpactPairs, tolerance: float) -> ImpactPairs:
    """``pairs`` measured against the restitution tolerance ``tolerance`` [-] (module docstring): which pairs are
    measurable (``measurable``, ``excess``), the worst, and the counts; the pairing itself does not depend on it, so
    a judge at many tolerances pairs once (``pipeline.prepared``). ``pair_impacts`` ends here."""
    n = len(pairs)
    rows = dict(pairs.columns)
    if n:
        err, unc = rows["restitution_error"], rows["restitution_uncertainty"]
        measurable = unc <= tolerance
        rows.update(measurable=measurable, excess=np.where(measurable, np.abs(err), np.nan))
    excess = rows["excess"] if n else np.empty(0)  # what follows from the arrays, not from the table's columns
    ok = np.isfinite(excess)
    if ok.any():
        k = int(np.flatnonzero(ok)[np.argmax(excess[ok])])
        worst, worst_excess = float(rows["restitution_error"][k]), float(excess[k])
    else:
        worst, worst_excess = math.nan, math.nan
    measured = int(rows["measurable"].sum()) if n else 0
    return ImpactPairs(columns=rows if n else {}, resolved=pairs.resolved, ref_resolved=pairs.ref_resolved,
                       worst_error=worst, worst_excess=worst_excess, unmeasured=n - measured, measured=measured)
