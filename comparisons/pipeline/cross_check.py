"""The reference cross-check: Feigin's exact model against Siconos, a second nonsmooth reference, at one dt.

    >>> from chatterbench.comparisons.pipeline.cross_check import cross_check
    >>> from chatterbench.reference.scene import load_scene
    >>> check = cross_check(load_scene("bouncing-ball"), dt=1e-4)
    >>> check.verdict == "match" if check.ran else "siconos" in check.reason
    True

The engines are judged against the event-driven reference; Siconos (Moreau-Jean time stepping
with Newton's impact law, ``engines/siconos_engine``) solves the same nonsmooth model by
another method, so unlike the engines it is expected to agree, to the order of its step.
``cross_check`` runs it (or takes its trajectory, already run) and judges it the way
``compare`` judges an engine (``compare.judge_run``); the check is the signed worst
differences Siconos minus Feigin [s]: first impact, sticking (the Zeno point) and exit, over
the scene's episodes. A disagreement points at the reference, or at the scene, before any
engine is blamed. Where Siconos is not installed the check says why (the install line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from chatterbench.engines.registry import make_settings, unavailable_reason
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene

from .compare import Comparison, EngineRun, judge_run
from .solution import ReferenceSolution, solve
from .summary import metrics, signed_worst
from .tolerances import Tolerances

ENGINE = "siconos"
RESOLUTION = 1e-9  # [s] differences below this are shown as 0


@dataclass(frozen=True)
class CrossCheck:
    """Siconos against Feigin's model on one scene: signed worst differences [s] (Siconos minus Feigin)."""

    scene: str
    dt: float  # [s] Siconos's step
    reason: str = ""  # why it did not run ("": it ran)
    verdict: str = ""  # the judge's verdict of the Siconos run (``vocabulary``), "" when not run
    n_match: int = 0  # episodes matched
    n_episodes: int = 0
    first_impact: float = math.nan  # [s] the worst first-impact difference, with its sign
    stick: float = math.nan  # [s] the worst sticking (Zeno point) difference, with its sign
    exit: float = math.nan  # [s] the worst exit difference, with its sign; nan: no episode exits
    message: str = ""  # the run's failure message, if any

    @property
    def ran(self) -> bool:
        return not self.reason

    def line(self) -> str:
        """One sentence for the report: the differences in ms, or why there are none."""
        if not self.ran:
            return f"Reference cross-check not run: {self.reason}"
        # a difference below RESOLUTION is rounding (the event times resolve to 1e-9 of a run: scene.TIME_RESOLUTION)
        ms = lambda v: "none" if math.isnan(v) else "0 ms" if abs(v) < RESOLUTION else f"{v * 1e3:+.3g} ms"  # noqa: E731
        episodes = f"{self.n_episodes} episode{'' if self.n_episodes == 1 else 's'}"
        text = (f"Reference cross-check, Siconos (Moreau-Jean, dt = {self.dt:g} s) minus Feigin's model: first impact "
                f"{ms(self.first_impact)}, sticking {ms(self.stick)}, exit {ms(self.exit)} (the worst of "
                f"{episodes}, {self.n_match} matched): {self.verdict}")
        return text + (f" ({self.message})" if self.message else "")


def cross_check(scene: Scene, dt: float | None = None, solution: ReferenceSolution | None = None,
                tol: Tolerances | None = None, trajectory: Trajectory | None = None) -> CrossCheck:
    """Siconos at ``dt`` [s] (None: its default) against the reference of ``scene`` (``solution``: already solved);
    ``trajectory``: a Siconos run already made, judged instead of running one."""
    reason = unavailable_reason(ENGINE)
    if reason and trajectory is None:
        return CrossCheck(scene.name, math.nan if dt is None else dt, reason=reason)
    settings = make_settings(ENGINE, dt) if not reason else None
    ref = solution if solution is not None else solve(scene)
    run, table, _ = judge_run(ref, ENGINE, settings, tol or Tolerances(), trajectory)
    return _judged(scene.name, run, table)


def _judged(scene: str, run: EngineRun, table) -> CrossCheck:
    """The check of a judged Siconos ``run`` and its episodes' ``table`` (``judge.TABLE_COLUMNS``)."""
    worst, counts = signed_worst(table), metrics(table)
    return CrossCheck(
        scene=scene, dt=float(run.settings.get("dt", math.nan)), verdict=counts["verdict"],
        n_match=counts["n_match"], n_episodes=counts["n_episodes"], first_impact=worst["first_impact_error_worst"],
        stick=worst["stick_error_worst"], exit=worst["exit_error_worst"], message=run.trajectory.message,
    )


def comparison_cross_check(comparison: Comparison, dt: float | None = None, tol: Tolerances | None = None) -> CrossCheck:
    """``cross_check`` of a comparison's scene against its solved reference, reusing its Siconos run when it has one
    (then at that run's dt, else at ``dt`` [s]; None: Siconos's own): judged at the comparison's tolerances, its
    own episodes are the check, nothing is judged again."""
    if ENGINE not in comparison.runs:
        return cross_check(comparison.scene, dt, comparison.solution, tol)
    if (tol or Tolerances()) == comparison.tolerances:
        return _judged(comparison.scene.name, comparison.runs[ENGINE], comparison.table[comparison.table["engine"] == ENGINE])
    return cross_check(comparison.scene, dt, comparison.solution, tol, comparison.runs[ENGINE].trajectory)
