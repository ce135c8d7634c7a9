"""The engines that write a scene as files a user runs in the engine alone, and the files they write.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.export import EXPORTS, export_files
    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> sorted(export_files("mujoco", load_scene("bouncing-ball"), MujocoSettings()))
    ['model.xml', 'run.py']
    >>> sorted(EXPORTS)
    ['mujoco', 'pybullet']

``chatterbench run --export-model PATH`` writes the engine's model file (``model_file``:
MuJoCo's full MJCF, PyBullet's complete script); ``chatterbench tune --out DIR`` writes
``export_files`` into ``DIR/<engine>/``: ``model.xml`` and ``run.py`` (a runner that loads it
with plain MuJoCo) or ``scene.py``. Every runnable file prints one line per impact,
``impact t=... v_in=... v_out=... e=...`` (``impact_lines``). Adapters are imported on first use.
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Any

from chatterbench.reference.scene import Scene

from .settings import SettingsError

# engine -> (the model file's name in DIR/<engine>/, its suffix for --export-model)
EXPORTS = {"mujoco": ("model.xml", ".xml"), "pybullet": ("scene.py", ".py")}


def check_exportable(engine: str) -> None:
    """SettingsError naming the engines that export, for any other."""
    if engine not in EXPORTS:
        raise SettingsError(f"engine {engine!r}: cannot export a model; engines that can: {', '.join(EXPORTS)}")


def making_command() -> str | None:
    """The ``chatterbench ...`` command this process runs, quoted for a shell; None outside the command line."""
    main = getattr(sys.modules.get("__main__"), "__spec__", None)
    if Path(sys.argv[0]).name == "chatterbench" or (main is not None and main.name.startswith("chatterbench.")):
        return shlex.join(["chatterbench", *sys.argv[1:]])
    return None


def model_file(engine: str, scene: Scene, settings: Any) -> str:
    """The engine's model file for ``scene`` at ``settings``: MuJoCo's MJCF (holding ``making_command``) or
    PyBullet's script."""
    check_exportable(engine)
    if engine == "mujoco":
        from .mujoco_engine.export import model_xml

        return model_xml(scene, settings, command=making_command())
    from .pybullet_engine.export import scene_script

    return scene_script(scene, settings)


def measurement(engine: str) -> str:
    """Python that measures one impact's e in the user's own model, with the snippet's placeholders ("" for an
    engine without one)."""
    if engine == "mujoco":
        from .mujoco_engine.snippet import measurement as lines
    elif engine == "pybullet":
        from .pybullet_engine.settings import measurement as lines
    else:
        return ""
    return lines()


def export_files_names(engine: str) -> list[str]:
    """The names ``export_files`` gives (none for an engine that does not export)."""
    return {"mujoco": [EXPORTS["mujoco"][0], "run.py"], "pybullet": [EXPORTS["pybullet"][0]]}.get(engine, [])


def export_files(engine: str, scene: Scene, settings: Any) -> dict[str, str]:
    """File name -> text, what ``tune --out DIR`` writes into ``DIR/<engine>/`` (module docstring)."""
    check_exportable(engine)
    names = export_files_names(engine)
    files = {names[0]: model_file(engine, scene, settings)}
    if engine == "mujoco":
        from .mujoco_engine.export import runner_script

        files[names[1]] = runner_script(scene, settings, model_file=names[0], command=making_command())
    return files
