"""The files ``tune --out DIR`` writes beside the guide: the scene at the chosen settings, runnable in the engine alone.

    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.engine_files import write_engine_files
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> space = {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.1,)}
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=space, workers=1, refine_steps=0,
    ...               ladder=None, check_robust=False)  # the asked tolerances alone (no frontier ladder, no neighbours)
    >>> write_engine_files(result, tmp)
    ['pybullet/scene.py']

``DIR/mujoco/model.xml`` (the full MJCF) and ``DIR/mujoco/run.py`` (a runner with plain
MuJoCo), or ``DIR/pybullet/scene.py`` (a complete PyBullet script): written by the exporter
of ``chatterbench run --export-model`` (``engines.export``) at ``TuneResult.chosen``'s
settings. Run as written, each prints the impacts of its run as the judge finds them at the tune's
tolerances (``flight_band``), one line each, ``impact t=... v_in=... v_out=... e=...``: the run's count,
each e the judge's.
An engine that does not export, or a tune where no candidate ran, writes nothing.
"""

from __future__ import annotations

from pathlib import Path

import math

from chatterbench.comparisons.pipeline.atomic import write_text
from chatterbench.comparisons.pipeline.extract_options import ExtractionOptions
from chatterbench.comparisons.pipeline.persistence import reference_rest_windows
from chatterbench.comparisons.pipeline.solution import ReferenceSolution, solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.export import export_files, export_files_names


def flight_band(solution: ReferenceSolution, tol: Tolerances) -> float:
    """The judge's band x sticking tolerance x (1 - R) [s] on this scene (``pipeline/extract.py``: the flights that
    no longer matter to the sticking tolerance); 0 for a scene without a visit. The exported scripts take it
    (``engines.export.export_files``) so that they count the impacts the judge counts."""
    stick = solution.stick_tolerance(tol.stick)
    return ExtractionOptions().band * stick * (1.0 - solution.scene.restitution) if math.isfinite(stick) else 0.0


def write_frontier_files(result, out: Path) -> list[str]:
    """Each frontier point's files under ``out``: its model and runnable script (``export_files``, judged at the
    point's own tolerances) and its snippet, in ``tune.answer.point_folder``; the names ``recommended.json`` lists
    (``tune.answer.point_record``), relative to ``out``."""
    from chatterbench.comparisons.studies.tune.answer import point_record
    from chatterbench.engines.registry import make_settings

    if not export_files_names(result.engine):
        return []
    solution = result.extra.get("solution") or solve(result.scene)
    written = []
    for entry in result.frontier:
        record = point_record(result, entry)
        tol = Tolerances(**entry["tolerances"])
        settings = make_settings(result.engine, float(entry["dt"]), dict(entry["settings"]))
        texts = list(export_files(result.engine, result.scene, settings, flight_band(solution, tol),
                                  reference_rest_windows(solution, tol)).values())
        if record["snippet"]:
            texts.append(record["snippet"] if record["snippet"].endswith("\n") else record["snippet"] + "\n")
        for name, text in zip(record["files"], texts):
            write_text(Path(out) / name, text)
            written.append(name)
    return written


def write_engine_files(result, out: Path) -> list[str]:
    """Write the chosen settings' files under ``out / engine``; returns their paths relative to ``out``.

    The settings are ``recommended.json``'s (``tune.evidence.chosen_settings``); the scripts count impacts as the
    judge does at the tune's tolerances (``flight_band``)."""
    from chatterbench.comparisons.studies.tune.evidence import chosen_settings

    settings = chosen_settings(result)
    if settings is None or not export_files_names(result.engine):
        return []
    solution = result.extra.get("solution") or solve(result.scene)
    written = []
    for name, text in export_files(result.engine, result.scene, settings, flight_band(solution, result.tolerance),
                                   reference_rest_windows(solution, result.tolerance)).items():
        write_text(Path(out) / result.engine / name, text)
        written.append(f"{result.engine}/{name}")
    return written
