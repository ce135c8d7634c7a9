"""Every module example (``>>>``) runs, as a doctest, with the names a reader would have at hand."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import chatterbench.comparisons
import chatterbench.engines
import chatterbench.reference

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = (chatterbench.reference, chatterbench.engines, chatterbench.comparisons)
# modules run as programs (``python -m ...``), not imported
SKIP = {"chatterbench.comparisons.cli.__main__"}


def _modules() -> list[str]:
    names = []
    for pkg in PACKAGES:
        names.append(pkg.__name__)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=pkg.__name__ + "."):
            if info.name not in SKIP:
                names.append(info.name)
    return sorted(names)


def _namespace(tmp: Path) -> dict:
    from chatterbench.engines.mujoco_engine import MujocoSettings
    from chatterbench.engines.pybullet_engine import PybulletSettings
    from chatterbench.reference import load_scene

    return {"np": np, "pd": pd, "Path": Path, "tmp": tmp, "load_scene": load_scene,
            "MujocoSettings": MujocoSettings, "PybulletSettings": PybulletSettings}


@pytest.mark.parametrize("name", _modules())
def test_module_examples_run(name, monkeypatch):
    monkeypatch.chdir(ROOT)  # examples name repository files: gates/default.toml, examples/sweeps/...
    module = importlib.import_module(name)
    with tempfile.TemporaryDirectory() as tmp:
        result = doctest.testmod(module, extraglobs=_namespace(Path(tmp)), report=True,
                                 optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of {name} failed (printed above)"
    if module.__doc__ and ">>>" in module.__doc__:
        assert result.attempted > 0
