"""Engine tuning: for a scene and tolerances, the cheapest robust settings that pass, how far the search looked, and every candidate.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (5e-3, 4e-3, 3.1e-3), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> three = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...              phases=(), transfer=False)     # robust at dt x 0.8 and x 1.25 alone: the old three-point rule
    >>> three.best["settings"]
    'dt=0.0031, pybullet.restitution_velocity_threshold=0.1'
    >>> band = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...             transfer=False)                 # the default: every dt of [0.8, 1.25] x dt, 4 impact phases
    >>> band.best is None, band.table.set_index("settings").loc[three.best["settings"], "neighbourhood"]
    (True, 'dt x1.06: late; dt x1.15 at phase 0.25: late; dt x1.25 at phase 0.25: late')
    >>> [(p["tolerances"]["stick"], p["tolerances"]["restitution"], p["dt"]) for p in band.frontier]  # what is robust
    [(0.1, 0.05, 0.00410763)]

``outputs/guide.py`` turns the result into the tuning guide; ``tune.answer.recommended`` into ``recommended.json``.

Modules, in the order a tune goes through them: ``space`` (the searched space: dt from the
scene's scales, the engine's knobs), ``grid`` (the lattice, the dt range, a candidate's band
of dts, phases and knob neighbours), ``search`` (the order candidates are tried in, refined
where verdicts change, each pass's neighbourhood run), ``runs`` (a candidate's runs, alone or
a pass as one batch, its cost), ``rows`` (a candidate judged to its row, or refused),
``checks`` (how far a run is from each of the judge's checks), ``ladder`` (the tolerance
levels and each run judged at them), ``choice`` (the recommendation, the fragile pass, the
best reachable), ``frontier`` (the cheapest robust setting per level), ``result`` (what a tune
answers), ``runner`` (``tune`` itself: the search run and its answer); after it, ``answer``
(``recommended.json`` and the answer's words), ``evidence`` (the answer rerun) and
``conformance`` (an answer rerun in the engine whose model it steps: MuJoCo Warp's in MuJoCo C).
"""

from ..limits import MAX_RUNS
from ...pipeline.tolerances import Tolerances
from .choice import TIE_BAND, choose, passing, reachable
from .grid import dt_range
from .ladder import Ladder
from .result import TuneResult
from .rows import TUNE_COLUMNS
from .runner import Limits, tune
from .runs import short_label
from .space import TuneError, engine_space, search_space

__all__ = ["MAX_RUNS", "TIE_BAND", "TUNE_COLUMNS", "Ladder", "Limits", "Tolerances", "TuneError", "TuneResult", "choose",
           "dt_range", "engine_space", "passing", "reachable", "search_space", "short_label", "tune"]
