"""The space a tune searches: dt from the scene's own scales and the contact knobs the engine declares, checked.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune.space import engine_space
    >>> space = {"dt": [1e-3], "pybullet.restitution_velocity_threshold": [0.1]}
    >>> engine_space("pybullet", load_scene("bouncing-ball"), space)     # checked, every list a tuple
    {'dt': (0.001,), 'pybullet.restitution_velocity_threshold': (0.1,)}

The space (``search_space``): dt from the scene's own scales (``tune.grid.dt_range``: the coarsest dt
worth trying is the tightest timing tolerance in seconds, a step that places an event no
better than the tolerance, or a quarter of the flight time across the gap at the fastest
strike, whichever is less; the finest needed is ``FINEST`` (1/1000) of that tolerance, but
never finer than the finest dt the engine declares),
and each engine's contact knobs as its adapter declares them (``EngineAdapter.tuning_space``).
Every value is checked before anything runs (``engine_space``): a space tune cannot use raises ``TuneError``.
"""

from __future__ import annotations

import math
from typing import Sequence

from chatterbench.engines.registry import adapter
from chatterbench.reference.scene import Scene, SceneError

from ...pipeline.solution import ReferenceSolution, solve
from ...pipeline.tolerances import Tolerances
from .grid import DEPTH, DT_RATIO, dt_range, round_dt
from .runs import candidate_settings


class TuneError(SceneError):
    """A search space tune cannot use (no dt ladder, an empty list, an engine that declares none)."""


def search_space(engine: str, scene: Scene, tol: Tolerances, solution: ReferenceSolution | None = None,
                 depth: int = DEPTH) -> dict[str, tuple]:
    """The space ``tune`` searches: coarse dt from ``dt_range`` (DT_RATIO ** 2**depth apart, coarse to fine; never
    finer than the finest dt the engine declares), the engine's declared knobs (``engine_space``), checked."""
    fine, coarse = dt_range(solution or solve(scene), tol)
    declared = engine_space(engine, scene)
    fine = min(max(fine, min(declared["dt"])), coarse)  # never finer than the engine's own finest declared dt
    ratio = DT_RATIO ** (2 ** depth)
    n = math.floor(math.log(coarse / fine) / math.log(ratio) + 1e-9) + 1  # the finest row at or above ``fine``
    return {"dt": tuple(round_dt(coarse / ratio ** k) for k in range(n)), **{k: v for k, v in declared.items() if k != "dt"}}


def engine_space(engine: str, scene: Scene, space: dict[str, Sequence] | None = None) -> dict[str, tuple]:
    """The search space: ``space`` or what the engine declares (``EngineAdapter.tuning_space``), checked."""
    space = space if space is not None else adapter(engine).tuning_space(scene)
    if space is None:
        raise TuneError(f"engine {engine!r}: declares no tuning space (its adapter's tuning_space), so tune cannot search it; "
                        "tune(..., space={...}) names one")
    space = {k: tuple(v) for k, v in space.items()}
    if "dt" not in space or not all(len(v) for v in space.values()):
        raise TuneError("tune search space: needs a non-empty 'dt' list and non-empty lists for every setting")
    for key in space:
        if key != "dt" and not key.startswith(f"{engine}."):
            raise TuneError(f"tune search space: {key!r} is not a setting of {engine} (expected {engine}.FIELD)")
    for key, values in space.items():  # validate every value before running anything
        for v in values:
            candidate_settings(engine, {"dt": space["dt"][0], key: v})
    return space
