"""One sweep row per (point, engine): the comparison of a run condensed to numbers and a verdict.

    >>> result = compare(scene, engines=("mujoco",), dt=1e-4)
    >>> row = summarize(result, "mujoco", params={"dt": 1e-4, "restitution": 0.5})

Row columns (the sweep dataset's schema; charts and reports read these names):

======================  ===========================================================================
point_id                stable id of the grid point (hash of scene + params), str
scene                   scene name
engine                  ``mujoco`` or ``pybullet``
<param>                 one column per swept parameter, named by its dotted key
                        (``dt``, ``restitution``, ``mujoco.w0_dt``, ``initial.t`` ...)
dt                      engine timestep [s]
mass_ratio              mu = mass2 / mass1 of the point's scene (0 when mass1 is infinite: a fixed
                        body); the relative motion between impacts and the impact law (1.3) do
                        not depend on it, an engine's contact solver may
status                  engine run status: ``ok``, ``diverged``, ``error``, ``timeout``, ``crashed``
verdict                 the point's verdict: ``match`` when every episode matches, else the worst
                        one present in the order of ``VERDICT_SEVERITY``; ``none`` when the
                        reference has no episode and the engine none either
n_episodes, n_match     episodes judged, and how many matched
exit_error_max          max |exit error| over the point's episodes [s] (NaN if none)
stick_error_max         max |sticking start error| against the Zeno point [s]
stick_error_plate_max   max |sticking start error| against Feigin's plate entry [s]
first_impact_error_max  max |first impact error| [s]
cost_per_sim_s          wall-clock seconds of engine stepping per simulated second
reference_cost_per_sim_s  wall-clock seconds of the reference (Feigin's model, event-driven) per
                        simulated second, on the same machine in the same process
wall_time_s             wall-clock seconds of engine stepping
engine_version          the engine package's version
message                 failure message, "" when ok
======================  ===========================================================================
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any, Mapping

ROW_COLUMNS = [
    "point_id", "scene", "engine", "dt", "mass_ratio", "status", "verdict", "n_episodes", "n_match",
    "exit_error_max", "stick_error_max", "stick_error_plate_max", "first_impact_error_max",
    "cost_per_sim_s", "reference_cost_per_sim_s", "wall_time_s", "engine_version", "message",
]
# columns a sweep does not set but charts may use as an axis, like a swept parameter
DERIVED_PARAMETERS = ("dt", "mass_ratio")
# worst first: the verdict that names a point when its episodes disagree
VERDICT_SEVERITY = ("crashed", "timeout", "error", "diverged", "penetrated", "endless", "missed", "spurious", "late", "early", "match")


def point_id(scene: str, engine: str, params: Mapping[str, Any]) -> str:
    """Stable 16-hex-digit id of a grid point (same inputs, same id, on any machine)."""
    blob = json.dumps({"scene": scene, "engine": engine, "params": dict(sorted(params.items()))}, sort_keys=True, default=repr)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def point_verdict(verdicts) -> str:
    """The point's verdict from its episodes' verdicts (see ``VERDICT_SEVERITY``)."""
    present = set(verdicts)
    if not present:
        return "none"
    for v in VERDICT_SEVERITY:
        if v in present:
            return v
    return sorted(present)[0]


def mass_ratio(scene) -> float:
    """mu = m2 / m1 (Feigin's mass ratio); 0 when body 1 is infinitely heavy (fixed)."""
    return 0.0 if math.isinf(scene.mass1) else float(scene.mass2 / scene.mass1)


def _absmax(series) -> float:
    vals = series.abs().dropna()
    return float(vals.max()) if len(vals) else math.nan


def summarize(comparison, engine: str, params: Mapping[str, Any]) -> dict[str, Any]:
    """The sweep row of ``engine`` in a ``compare.Comparison`` (columns in the module docstring)."""
    run = comparison.runs[engine]
    sub = comparison.table[comparison.table["engine"] == engine]
    row = {
        "point_id": point_id(comparison.scene.name, engine, params),
        "scene": comparison.scene.name,
        "engine": engine,
        **dict(params),
        "dt": float(run.settings.get("dt", math.nan)),
        "mass_ratio": mass_ratio(comparison.scene),
        "status": run.status,
        "verdict": point_verdict(sub["verdict"]),
        "n_episodes": int(len(sub)),
        "n_match": int((sub["verdict"] == "match").sum()),
        "exit_error_max": _absmax(sub["exit_error"]),
        "stick_error_max": _absmax(sub["stick_error_zeno"]),
        "stick_error_plate_max": _absmax(sub["stick_error_plate"]),
        "first_impact_error_max": _absmax(sub["first_impact_error"]),
        "cost_per_sim_s": run.cost_per_sim_s,
        "reference_cost_per_sim_s": float(comparison.provenance.get("reference", {}).get("cost_per_sim_s", math.nan)),
        "wall_time_s": run.wall_time,
        "engine_version": run.version,
        "message": run.trajectory.message,
    }
    return row


def failure_row(scene: str, engine: str, params: Mapping[str, Any], status: str, message: str, version: str = "",
                mu: float = math.nan) -> dict[str, Any]:
    """The row of a point whose run crashed, hung or raised before any result (verdict = status).

    ``mu`` is the point's mass ratio (``mass_ratio``), NaN when unknown.
    """
    return {
        "point_id": point_id(scene, engine, params), "scene": scene, "engine": engine, **dict(params),
        "dt": float(params.get("dt", math.nan)), "mass_ratio": mu, "status": status, "verdict": status,
        "n_episodes": 0, "n_match": 0,
        "exit_error_max": math.nan, "stick_error_max": math.nan, "stick_error_plate_max": math.nan,
        "first_impact_error_max": math.nan, "cost_per_sim_s": math.nan, "reference_cost_per_sim_s": math.nan,
        "wall_time_s": math.nan, "engine_version": version, "message": message,
    }
