"""The verdict of one judged episode row and why, from the rules ``judge.py``'s docstring lists (1 to 10).

    >>> from chatterbench.comparisons.pipeline.verdict_rules import timing
    >>> timing(error=0.004, bound=0.001, limit=0.002), timing(0.003, 0.004, 0.002), timing(0.001, 0.0, 0.002)
    ('late', 'unresolved', '')

``verdict_reason(row, tol, run)`` takes a judged row (a named tuple of ``judge.TABLE_COLUMNS`` with
``stick_scale``, ``restitution_excess`` and ``measured_impacts``), the tolerances and what is known of the
run (``RunFacts``); ``run_failure`` is the run's own failure, ``run_failure_words`` says it. Times in seconds,
errors engine minus reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from .tolerances import Tolerances
from .vocabulary import FAILURES


@dataclass(frozen=True)
class RunFacts:
    """What the verdict rules need to know of the run besides its episodes."""

    status: str = "ok"  # the trajectory's status: "ok" or a failure class
    t_end: float = math.inf  # [s] the last sample's time
    t_diverged: float = math.nan  # [s] first non-finite state or energy past its bound; NaN if never
    t_penetrated: float = math.nan  # [s] first time past the penetration allowance; NaN if never
    penetration_allowance: float = math.inf  # [m]
    inside_impacts: Callable[[str, float, float], int] = lambda wall, t0, t1: 0  # engine impacts on wall in [t0, t1]
    sliding_min: float = 0.0  # [s] the shortest sliding the samples can show (``sliding_min``)
    dt: float = math.nan  # [s] the sampling step (the median spacing)


def run_failure_words(run: RunFacts) -> str:
    """What ``run_failure`` found, in words: "diverged at 2.5 s", "ended (timeout) at 1.2 s", ..."""
    failure = run_failure(run)
    if failure in FAILURES and failure != "diverged":
        return f"ended ({failure}) at {run.t_end:.6g} s"
    if failure == "diverged":
        return f"diverged at {run.t_diverged:.6g} s"
    return f"went past the penetration allowance {run.penetration_allowance:.3g} m at {run.t_penetrated:.6g} s"


def run_failure(run: RunFacts) -> str:
    """The run's own failure verdict ("" when it did not fail): its status, else diverged, else penetrated."""
    if run.status in FAILURES:
        return run.status
    if not math.isnan(run.t_diverged):
        return "diverged"
    return "penetrated" if not math.isnan(run.t_penetrated) else ""


def timing(error: float, bound: float, limit: float) -> str:
    """One timing criterion: ``""`` (within), ``early``/``late`` or ``unresolved`` (all in seconds).

    ``bound``: how far the samples let the engine's time be off (NaN: not known, 0). Beyond the
    tolerance even with the bound taken off: early or late, whatever the bound. Otherwise, a
    bound over the tolerance leaves the criterion ``unresolved`` unless the error is within the
    tolerance even with the bound added; a bound within it: the error alone decides.
    """
    if math.isnan(error) or math.isnan(limit):
        return ""
    b = 0.0 if math.isnan(bound) else bound
    side = "early" if error < 0 else "late"
    if abs(error) - b > limit:
        return side
    if b <= limit:
        return side if abs(error) > limit else ""
    return "" if abs(error) + b <= limit else "unresolved"


# timing criteria in the order the verdict checks them: (name, error column, bound column, tolerance, scale column, scale)
_TIMING = (("sticking start", "stick_error_zeno", "stick_bound", "stick", "stick_scale", "the chatter"),
           ("first impact", "first_impact_error", "first_impact_bound", "first_impact", "stick_scale", "the chatter"),
           ("exit", "exit_error", "exit_bound", "exit", "sliding_duration", "the sliding"))


def _seconds(value: float) -> str:
    return f"{value * 1e3:.3g} ms" if abs(value) < 1.0 else f"{value:.4g} s"


def advised_step(dt: float, bound: float, limit: float) -> float:
    """The sampling step [s] that places a time to its tolerance ``limit`` [s], where this sampling's step ``dt``
    places it to ``bound`` [s]. A bound of a step or more scales with the step (an extrapolated ladder, a step an
    exit lies in): dt limit / bound. One under a step is a window between two samples (a sticking start between
    the last landing and the first sample at rest, ``sticking.last_landing``; half a step for an exit), never wider
    than the step: a step of ``limit`` resolves it. Rounded down to two digits, so that the step a reason names is
    never coarser than the one that resolves it."""
    step = dt * limit / max(bound, dt)
    scale = 10.0 ** (math.floor(math.log10(step)) - 1)
    return math.floor(step / scale * (1.0 + 1e-12)) * scale


def _timing_reason(name: str, error: float, bound: float, limit: float, fraction: float, scale: str,
                   found: str, dt: float) -> str:
    """Why one timing criterion got ``found`` (early, late, unresolved), in words a user can act on."""
    pct = f"{100 * fraction:g}% of {scale}, {_seconds(limit)}"
    sign = "+" if error >= 0 else "-"
    if found != "unresolved":
        known = f" (known to +-{_seconds(bound)})" if bound > 0 else ""
        return f"{name} {sign}{_seconds(abs(error))}{known}, beyond the tolerance {pct}"
    finer = f"; samples every {advised_step(dt, bound, limit):.2g} s or closer would resolve it" if dt > 0 else ""
    return (f"{name} {sign}{_seconds(abs(error))}, but this sampling places it only to +-{_seconds(bound)}, more than "
            f"the tolerance {pct}{finer}")


def _metres(value: float) -> str:
    return f"{value * 1e6:.3g} um" if abs(value) < 1e-3 else f"{value * 1e3:.3g} mm" if abs(value) < 1.0 else f"{value:.4g} m"


def _buzz_reason(r, tol: Tolerances) -> str:
    """Why a stuck episode is ``buzz``: its contact's onsets per second, open share, largest gap and force swing."""
    swing = getattr(r, "force_swing", math.nan)
    force = "" if math.isnan(swing) else f", the contact force swinging by {swing:.0%} of the load it carries"
    return (f"the contact keeps opening after the stick: {int(r.contact_onsets)} contact onsets in "
            f"{_seconds(r.rest_window)} ({r.onset_rate:.3g} per second), open {r.open_fraction:.1%} of that time (the "
            f"persistence tolerance: {tol.persistence:.3g}), gaps up to {_metres(r.gap_max)}{force}")


def verdict(r, tol: Tolerances, run: RunFacts) -> str:
    """The verdict of one judged row (a ``TABLE_COLUMNS`` namedtuple with ``restitution_excess``): module docstring."""
    return verdict_reason(r, tol, run)[0]


def verdict_reason(r, tol: Tolerances, run: RunFacts) -> tuple[str, str]:
    """The verdict of one judged row and why, in one line ("" for ``match`` and ``none``): module docstring.

    The rules in order, the first that finds a failure decides: the run's own failure, the pairing of the episodes,
    timing, restitution, persistence (``buzz``: a stuck contact that does not stay closed); then what the sampling
    cannot resolve; then ``match``."""
    unresolved: list[str] = []
    for rule in (_run_rule, _pairing_rule, _timing_rule, _restitution_rule, _persistence_rule):
        found = rule(r, tol, run, unresolved)
        if found is not None:
            return found
    if unresolved:
        return "unresolved", "; ".join(unresolved)
    if getattr(r, "unmeasured_impacts", 0) > 0 and getattr(r, "measured_impacts", 0) == 0:
        return "unmeasured", (f"none of the {r.unmeasured_impacts} resolved impacts is measurable to the restitution "
                              f"tolerance {tol.restitution:.0%} at this step")
    return "match", ""


def _stop(r) -> float:
    """Where an episode ends for the run's failures [s]: its exit (the reference's when it has one), else never."""
    stop = r.ref_t_exit if not math.isnan(r.ref_t_stick) else r.t_exit
    return math.inf if math.isnan(stop) else stop


def _run_rule(r, tol: Tolerances, run: RunFacts, unresolved: list[str]) -> tuple[str, str] | None:
    """The run diverged, failed or penetrated before the episode ended."""
    stop = _stop(r)
    if not math.isnan(run.t_diverged) and run.t_diverged <= stop:
        return "diverged", f"the run diverged at {run.t_diverged:.6g} s"
    if run.status in FAILURES and stop > run.t_end:
        return run.status, f"the run ended ({run.status}) at {run.t_end:.6g} s, before this episode did"
    if not math.isnan(r.penetration_max) and r.penetration_max > run.penetration_allowance:
        return "penetrated", f"penetration {r.penetration_max:.3g} m > the allowance {run.penetration_allowance:.3g} m"
    return None


def _pairing_rule(r, tol: Tolerances, run: RunFacts, unresolved: list[str]) -> tuple[str, str] | None:
    """A reference episode the engine never sticks in (endless, unresolved or missed), or the engine's alone."""
    has_ref, has_eng = not math.isnan(r.ref_t_stick), not math.isnan(r.t_stick)
    if has_ref and not has_eng:
        inside = run.inside_impacts(r.wall, r.ref_t_stick, r.ref_t_exit)
        if inside >= tol.endless_impacts:
            return "endless", f"{inside} impacts inside the reference's sliding, and no stick"
        if r.sliding_duration < run.sliding_min:
            return "unresolved", (f"no stick, but the reference slides only {_seconds(r.sliding_duration)}: this sampling "
                                  f"shows no sliding shorter than {_seconds(run.sliding_min)}")
        return "missed", f"no stick where the reference slides {_seconds(r.sliding_duration)}"
    if has_eng and not has_ref:
        return "spurious", "sticks where the reference does not"
    return None


def _timing_rule(r, tol: Tolerances, run: RunFacts, unresolved: list[str]) -> tuple[str, str] | None:
    """Sticking, exit and first impact against their tolerances (``_TIMING``); what the step cannot tell, noted."""
    for name, err, bound, key, scale, words in _TIMING:
        if key == "exit" and math.isnan(r.ref_t_exit) != math.isnan(r.t_exit):
            found = "late" if math.isnan(r.t_exit) else "early"  # one of them is still stuck at the end of the run
            return found, f"{'the engine' if found == 'late' else 'the reference'} is still stuck at the end of the run"
        value, size = getattr(r, err), getattr(r, scale)
        limit = getattr(tol, key) * size if size > 0 else math.nan
        b = getattr(r, bound, math.nan)
        found = timing(value, b, limit)
        if found in ("early", "late"):
            return found, _timing_reason(name, value, b, limit, getattr(tol, key), words, found, run.dt)
        if found:
            unresolved.append(_timing_reason(name, value, b, limit, getattr(tol, key), words, found, run.dt))
    return None


def _restitution_rule(r, tol: Tolerances, run: RunFacts, unresolved: list[str]) -> tuple[str, str] | None:
    """A resolved impact's e beyond the tolerance, or too many or too few resolved impacts."""
    if not math.isnan(r.restitution_excess) and r.restitution_excess > tol.restitution:
        return "rebound", (f"restitution: a resolved impact's e / R - 1 = {r.restitution_error:+.1%}, beyond the "
                           f"tolerance {tol.restitution:.0%}")
    if abs(r.resolved_impacts - r.ref_resolved_impacts) > tol.impact_count:
        return "rebound", (f"impact count: {r.resolved_impacts} resolved impacts against the reference's "
                           f"{r.ref_resolved_impacts}, more than {tol.impact_count} apart")
    return None


def _persistence_rule(r, tol: Tolerances, run: RunFacts, unresolved: list[str]) -> tuple[str, str] | None:
    """After a stick on time, the contact open more of the rest than ``tol.persistence`` allows (``buzz``); where
    the samples cannot show a one-step flicker, noted as unresolved."""
    open_share = getattr(r, "open_fraction", math.nan)
    if open_share > tol.persistence:
        return "buzz", _buzz_reason(r, tol)
    if not math.isnan(open_share) and not getattr(r, "rest_resolved", True):
        unresolved.append(f"persistence: the contact is read from the positions, whose velocities tell motion from "
                          f"rest only above {r.contact_resolution:.3g} m/s, more than a one-step bounce's speed: a "
                          "flicker could pass for rest there")
    return None
