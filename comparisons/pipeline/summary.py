"""One row per (run, engine): a comparison condensed to numbers and a verdict, with one set of column names.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.summary import summarize
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> result = compare(load_scene("bouncing-ball"), settings=settings_for(("pybullet",), 1e-3))
    >>> row = summarize(result, "pybullet", params={"dt": 1e-3})
    >>> row["point_id"], row["verdict"], row["n_episodes"]     # on time, then bouncing at g dt (threshold 0)
    ('bcf533bb0b267c67', 'buzz', 1)
    >>> round(row["open_fraction_max"], 2), round(row["onset_rate_max"])   # open a third of the rest, 333 onsets/s
    (0.33, 333)

The same row is ``compare``'s summary, a sweep's dataset row, the gate's metrics and the
report's summary table. Columns (a sweep dataset's schema; charts and reports read these names):

=========================  ===========================================================================
point_id                   stable id of the grid point (hash of scene + params), str
scene                      scene name
engine                     the engine's name in the engine table (``engines.registry.ENGINE_NAMES``)
<param>                    one column per swept parameter, named by its dotted key (sweeps only)
dt                         engine timestep [s]
mass_ratio                 mu = mass2 / mass1 (0 when mass1 is infinite: a fixed body)
status                     engine run status: ``ok``, ``diverged``, ``error``, ``timeout``, ``crashed``
verdict                    the episodes' verdicts combined (``vocabulary.combine``: the most severe);
                           ``none`` when neither the reference nor the engine has an episode
n_episodes, n_match        episodes judged, and how many matched
exit_error_max             max |exit error| [s]
stick_error_max            max |sticking start - Zeno point| [s]
stick_error_plate_max      max |sticking start - Feigin's plate entry| [s]
first_impact_error_max     max |first impact error| [s]
exit_error_rel_max         max |exit error| / sliding duration [-] (the exit tolerance's measure)
stick_error_rel_max        max |sticking start error| / chatter duration [-] (the stick tolerance's)
restitution_error_max      max |effective R / R - 1| over the resolved impacts [-]
penetration_max            deepest penetration of a wall [m]
open_fraction_max          max share of an episode's rest after its stick that the contact is open [-] (persistence's
                           measure: ``persistence.py``; NaN with no rest window)
onset_rate_max             max contact onsets per second in an episode's rest after its stick [1/s]
cost_per_sim_s             wall-clock seconds of engine stepping per simulated second
reference_cost_per_sim_s   wall-clock seconds of the reference (Feigin's model) per simulated second
wall_time_s                wall-clock seconds of engine stepping
engine_version             the engine package's version
precision                  the engine's floating-point type (its adapter's ``precision``: ``float32`` for MuJoCo Warp)
message                    failure message, "" when ok
refine_level               (refined sweeps only) the level the point was added at, 0 for the coarse grid
=========================  ===========================================================================
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any, Mapping

from .vocabulary import combine

METRIC_COLUMNS = [
    "exit_error_max", "stick_error_max", "stick_error_plate_max", "first_impact_error_max",
    "exit_error_rel_max", "stick_error_rel_max", "restitution_error_max", "penetration_max",
    "open_fraction_max", "onset_rate_max",
]
ROW_COLUMNS = [
    "point_id", "scene", "engine", "dt", "mass_ratio", "status", "verdict", "n_episodes", "n_match",
    *METRIC_COLUMNS, "cost_per_sim_s", "reference_cost_per_sim_s", "wall_time_s", "engine_version", "precision", "message",
]
SUMMARY_COLUMNS = [c for c in ROW_COLUMNS if c != "point_id"]
# columns a sweep does not set but charts may use as an axis, like a swept parameter
DERIVED_PARAMETERS = ("dt", "mass_ratio")
# a refined sweep's row: the level its point was added at (0: the coarse grid); says when a point ran, not where
REFINE_LEVEL = "refine_level"
# the table column each worst-case metric is taken from
_SOURCES = {
    "exit_error_max": "exit_error", "stick_error_max": "stick_error_zeno", "stick_error_plate_max": "stick_error_plate",
    "first_impact_error_max": "first_impact_error", "exit_error_rel_max": "exit_error_rel",
    "stick_error_rel_max": "stick_error_rel", "restitution_error_max": "restitution_error",
    "penetration_max": "penetration_max", "open_fraction_max": "open_fraction", "onset_rate_max": "onset_rate",
}


# the report's signed worst errors: the error of largest magnitude, with its sign (engine minus reference:
# negative = early, or an impact that keeps less than R of its speed). Not row columns: the ``_max`` columns
# above stay magnitudes (the gate's and the sweeps' smaller-is-better metrics) and a sweep's schema is unchanged;
# |<name>_worst| == <name>_max always.
SIGNED_COLUMNS = {
    "stick_error_worst": "stick_error_zeno", "stick_error_rel_worst": "stick_error_rel", "exit_error_worst": "exit_error",
    "exit_error_rel_worst": "exit_error_rel", "first_impact_error_worst": "first_impact_error",
    "restitution_error_worst": "restitution_error",
}


def point_id(scene: str, engine: str, params: Mapping[str, Any]) -> str:
    """Stable 16-hex-digit id of a grid point (same inputs, same id, on any machine)."""
    blob = json.dumps({"scene": scene, "engine": engine, "params": dict(sorted(params.items()))}, sort_keys=True, default=repr)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def mass_ratio(scene) -> float:
    """mu = m2 / m1 (Feigin's mass ratio); 0 when body 1 is infinitely heavy (fixed)."""
    return 0.0 if math.isinf(scene.mass1) else float(scene.mass2 / scene.mass1)


def _absmax(series) -> float:
    vals = series.abs().dropna()
    return float(vals.max()) if len(vals) else math.nan


def worst_signed(series) -> float:
    """The entry of largest magnitude, with its sign (the first of equal magnitudes); NaN when there is none."""
    vals = series.astype(float).dropna().to_numpy()
    return float(vals[abs(vals).argmax()]) if len(vals) else math.nan


def signed_worst(table) -> dict[str, float]:
    """The signed worst errors (``SIGNED_COLUMNS``) of one engine's judged episodes (``judge.TABLE_COLUMNS``)."""
    return {name: worst_signed(table[source]) for name, source in SIGNED_COLUMNS.items()}


def metrics(table) -> dict[str, Any]:
    """Verdict, counts and worst errors of one engine's judged episodes (``judge.TABLE_COLUMNS``)."""
    return {
        "verdict": combine(table["verdict"]),
        "n_episodes": int((table["wall"] != "").sum()),
        "n_match": int((table["verdict"] == "match").sum()),
        **{name: _absmax(table[source]) for name, source in _SOURCES.items()},
    }


def summarize(comparison, engine: str, params: Mapping[str, Any]) -> dict[str, Any]:
    """The row of ``engine`` in a ``compare.Comparison`` (columns in the module docstring)."""
    run = comparison.runs[engine]
    sub = comparison.table[comparison.table["engine"] == engine]
    return {
        "point_id": point_id(comparison.scene.name, engine, params),
        "scene": comparison.scene.name,
        "engine": engine,
        **dict(params),
        "dt": float(run.settings.get("dt", math.nan)),
        "mass_ratio": mass_ratio(comparison.scene),
        "status": run.status,
        **metrics(sub),
        "cost_per_sim_s": run.cost_per_sim_s,
        "reference_cost_per_sim_s": comparison.solution.cost_per_sim_s,
        "wall_time_s": run.wall_time,
        "engine_version": run.version,
        "precision": precision(run.settings),
        "message": run.trajectory.message,
    }


def precision(settings: Mapping[str, Any]) -> str:
    """The floating-point type a run computed in: its ``precision`` setting (MuJoCo Warp), else ``float64``
    (MuJoCo's mjtNum, Drake's double, PyBullet's double-precision Bullet build)."""
    return str(settings.get("precision", "float64"))


def failure_row(scene: str, engine: str, params: Mapping[str, Any], status: str, message: str, version: str = "",
                mu: float = math.nan) -> dict[str, Any]:
    """The row of a point whose run crashed, hung or raised before any result (verdict = status).

    ``mu`` is the point's mass ratio (``mass_ratio``), NaN when unknown.
    """
    return {
        "point_id": point_id(scene, engine, params), "scene": scene, "engine": engine, **dict(params),
        "dt": float(params.get("dt", math.nan)), "mass_ratio": mu, "status": status, "verdict": status,
        "n_episodes": 0, "n_match": 0, **{m: math.nan for m in METRIC_COLUMNS},
        "cost_per_sim_s": math.nan, "reference_cost_per_sim_s": math.nan,
        "wall_time_s": math.nan, "engine_version": version, "precision": str(params.get(f"{engine}.precision", "")),
        "message": message,
    }
