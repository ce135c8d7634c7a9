"""The engines that write a scene as files a user runs in the engine alone, and the files they write.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.export import export_files, exporting_engines
    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> sorted(export_files("mujoco", load_scene("bouncing-ball"), MujocoSettings()))
    ['model.xml', 'run.py']
    >>> exporting_engines()[:2]
    ('mujoco', 'pybullet')

Which engines export, and what, is a fact each adapter declares (``EngineAdapter.exports``,
``export_kind``, ``export``): MuJoCo writes its full MJCF (``model.xml``) and a runner that
loads it with plain MuJoCo (``run.py``), PyBullet a complete script (``scene.py``).
``chatterbench run --export-model PATH`` writes the model file (``model_file``);
``chatterbench tune --out DIR`` writes ``export_files`` into ``DIR/<engine>/``. Every runnable
file prints the impacts of its run as the judge finds them, one line each, ``impact t=... v_in=...
v_out=... e=...`` (``impact_lines``), with the judge's sticking resolution when the caller gives it
(``flight_band``). Names go into the files escaped (``printable``). Adapters are imported on first use.
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Any

from chatterbench.reference.scene import Scene

from .base import EngineAdapter
from .impact_lines import judged_by
from .registry import adapter, available_engines, check_engine, plugin_said
from .settings import SettingsError


class ExportError(SettingsError):
    """An engine's adapter that does not write the files it declares (``EngineAdapter.exports``)."""


def printable(text: str) -> str:
    """``text`` with every character that is not printable (a newline, a tab, NUL, BEL, ESC, U+FFFE, a lone
    surrogate: what XML cannot hold or reads back changed) written as its Python escape (``\\n``, ``\\x07``)."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def exporting_engines() -> tuple[str, ...]:
    """The engines installed here whose adapter writes a scene as files (``EngineAdapter.exports``), in table order."""
    return tuple(name for name in available_engines() if adapter(name).exports)


def export_files_names(engine: str) -> list[str]:
    """The names ``export_files`` gives, the model file first (none for an engine that does not export)."""
    return list(adapter(check_engine(engine)).exports)


def check_exportable(engine: str) -> None:
    """SettingsError naming the engines that export, for any other."""
    if not export_files_names(engine):
        raise SettingsError(f"engine {engine!r}: cannot export a model; engines that can: {', '.join(exporting_engines())}")


def making_command() -> str | None:
    """The ``chatterbench ...`` command this process runs, quoted for a shell; None outside the command line."""
    main = getattr(sys.modules.get("__main__"), "__spec__", None)
    if Path(sys.argv[0]).name == "chatterbench" or (main is not None and main.name.startswith("chatterbench.")):
        return shlex.join(["chatterbench", *sys.argv[1:]])
    return None


def export_files(engine: str, scene: Scene, settings: Any, flight_band: float | None = None,
                 rest: tuple = ()) -> dict[str, str]:
    """File name -> text, what ``tune --out DIR`` writes into ``DIR/<engine>/`` (module docstring); the files keep
    ``making_command``. ``flight_band`` [s]: the judge's band x sticking tolerance x (1 - R) of the comparison the
    files are to agree with (``impact_lines.judged_by``; None: the sampling floor alone); ``rest``: the windows
    (t0 [s], t1 [s], wall) over which the scripts report whether the contact stays closed after a stick."""
    check_exportable(engine)
    return adapter_files(adapter(engine), scene, settings, flight_band, rest)


def adapter_files(engine: EngineAdapter, scene: Scene, settings: Any, flight_band: float | None = None,
                  rest: tuple = ()) -> dict[str, str]:
    """``engine.export``'s files, in the order it declares them (``exports``); an ``ExportError`` naming what is
    missing when it does not write each of them as text (a third party's adapter that returns nothing)."""
    with judged_by(flight_band, rest):
        files = engine.export(scene, settings, command=making_command())
    names = list(engine.exports)
    missing = [name for name in names if not isinstance(files, dict) or not isinstance(files.get(name), str)]
    if missing:
        got = (", ".join(map(repr, files)) or "an empty dict") if isinstance(files, dict) else repr(type(files).__name__)
        raise ExportError(f"engine {engine.name!r}: its adapter's export() wrote no {', '.join(map(repr, missing))} "
                          f"(it declares {', '.join(map(repr, names))}; it returned {got})")
    return {name: files[name] for name in names}


def model_file(engine: str, scene: Scene, settings: Any, flight_band: float | None = None, rest: tuple = ()) -> str:
    """The engine's model file for ``scene`` at ``settings`` (the first of its ``exports``): MuJoCo's MJCF (holding
    ``making_command``), PyBullet's script."""
    return export_files(engine, scene, settings, flight_band, rest)[export_files_names(engine)[0]]


def measurement(engine: str) -> str:
    """Python that measures one impact's e in the user's own model, with the snippet's placeholders ("" for an
    engine without one)."""
    return plugin_said(check_engine(engine), "measurement", instead=lambda fault: "", kept="the guide has no measurement")
