"""The evidence behind a tuning answer: the chosen settings rerun on the scene, and their restitution against impact speed.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune.evidence import evidence
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...               ladder=None, phases=(), transfer=False)   # the asked tolerances alone (no frontier ladder)
    >>> ev = evidence(result, speeds=[0.5, 4.0])
    >>> ev.comparison.table["verdict"].tolist(), ev.curve["restitution_effective"].round(3).unique().tolist()
    (['match'], [0.5])
    >>> len(ev.curve)                                       # 2 speeds x 10 places in a step (8 through it, 2 ends)
    20
    >>> ev.strikes["forces"].iloc[0], len(ev.strikes) > 3      # under gravity, at the ball's own impacts
    ('scene', True)

For the chosen candidate (``TuneResult.chosen``: the recommendation, or the best reachable
one when nothing passes): ``comparison``, the scene through ``compare`` with those settings
(its episodes, impacts and the chatter ladder's data), ``curve``, the effective restitution
of strikes at ``STRIKES`` places in a step at each speed with those settings
(``studies.restitution_curve``, the contact law alone: no other force) over
``default_speeds(scene)``, ``strikes``, the same under the scene's own forces at the speeds
the scene reaches (``studies.scene_restitution``: from the reference's state before each
impact the judge resolves, every one), and ``impacts``, the restitution
of each resolved impact of the scene in that same run (no curve and no strikes for a scene
without an impact: there is no speed to take). Nothing here changes the choice.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import pandas as pd

from chatterbench.engines.registry import make_settings
from chatterbench.reference.errors import InputError

from ...pipeline.compare import Comparison, compare
from ..restitution_curve import default_speeds, impact_restitutions, pinned_settings, restitution_curve
from .checks import scene_strikes
from .answer import recommended


@dataclass(frozen=True)
class Evidence:
    """The chosen settings' comparison on the scene and their R(v) curve (module docstring)."""

    comparison: Comparison
    curve: pd.DataFrame | None  # studies.restitution_curve.CURVE_COLUMNS; None when the scene has no impact
    strikes: pd.DataFrame | None  # the same columns, forces "scene": under the scene's forces at its own impacts
    impacts: pd.DataFrame  # studies.restitution_curve.IMPACT_COLUMNS


def chosen_settings(result):
    """The engine's settings dataclass for ``result.chosen``, made from ``recommended.json``'s content (``tune.answer.recommended``:
    what the guide's snippet and files show is what the JSON says); None when no candidate ran."""
    rec = recommended(result)
    return None if rec is None else settings_of(rec)


def settings_of(rec: dict):
    """The settings dataclass a ``recommended.json`` names: ``make_settings(engine, dt, settings)``, as ``compare
    --engines E --dt DT --set K=V ...`` makes them."""
    return make_settings(rec["engine"], float(rec["dt"]), dict(rec["settings"]))


def evidence(result, speeds: Sequence[float] | None = None) -> Evidence | None:
    """Rerun the chosen candidate on the scene and strike once per speed [m/s] (default ``default_speeds``)."""
    settings = chosen_settings(result)  # the one settings object of the rerun, the strikes and the curve
    if settings is None:
        return None
    comparison = compare(result.scene, engines=(result.engine,), settings={result.engine: settings},
                         tol=result.tolerance, solution=result.extra.get("solution"))
    run = comparison.runs[result.engine]
    impacts = impact_restitutions(result.engine, settings, result.scene, comparison.solution, result.tolerance,
                                  trajectory=run.trajectory)
    if speeds is None:
        try:
            speeds = default_speeds(result.scene)
        except InputError:  # a run with no impact has no speed to take them from: no curve
            return Evidence(comparison=comparison, curve=None, strikes=None, impacts=impacts)
    pinned = pinned_settings(settings, run.trajectory.settings)  # the contact the scene's run had (Drake)
    curve = restitution_curve(result.engine, pinned, result.scene.restitution, speeds, scene=result.scene)
    strikes = scene_strikes(result.engine, pinned, comparison.solution, result.tolerance, held_only=False)
    return Evidence(comparison=comparison, curve=curve, strikes=strikes if len(strikes) else None, impacts=impacts)
