"""The files ``tune --out DIR`` writes beside the guide: the scene at the chosen settings, runnable in the engine alone.

    >>> import tempfile
    >>> from pathlib import Path
    >>> tmp = Path(tempfile.mkdtemp())
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.engine_files import write_engine_files
    >>> from chatterbench.comparisons.studies.tune import tune
    >>> result = tune(load_scene("bouncing-ball"), "pybullet", 0.05, space={"dt": (1e-3,)}, workers=1, refine_steps=0)
    >>> write_engine_files(result, tmp)
    ['pybullet/scene.py']

``DIR/mujoco/model.xml`` (the full MJCF) and ``DIR/mujoco/run.py`` (a runner with plain
MuJoCo), or ``DIR/pybullet/scene.py`` (a complete PyBullet script): written by the exporter
of ``chatterbench run --export-model`` (``engines.export``) at ``TuneResult.chosen``'s
settings. Run as written, each prints one line per impact, ``impact t=... v_in=... v_out=... e=...``.
An engine that does not export, or a tune where no candidate ran, writes nothing.
"""

from __future__ import annotations

from pathlib import Path

from chatterbench.comparisons.pipeline.atomic import write_text
from chatterbench.engines.export import export_files, export_files_names


def write_engine_files(result, out: Path) -> list[str]:
    """Write the chosen settings' files under ``out / engine``; returns their paths relative to ``out``.

    The settings are ``recommended.json``'s (``tune_evidence.chosen_settings``)."""
    from chatterbench.comparisons.studies.tune_evidence import chosen_settings

    settings = chosen_settings(result)
    if settings is None or not export_files_names(result.engine):
        return []
    written = []
    for name, text in export_files(result.engine, result.scene, settings).items():
        write_text(Path(out) / result.engine / name, text)
        written.append(f"{result.engine}/{name}")
    return written
