"""Every module example (``>>>``) runs, as a doctest, with no names given to it: each imports what it uses."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import types
from pathlib import Path

import pytest
from helpers import needs_engine

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


def _run_examples(module: types.ModuleType) -> doctest.TestResults:
    # globs={}: no names are handed to the examples, not even the module's own (doctest's default
    # hands them the module's globals); an example sees only what it imports, as a reader who pastes it
    return doctest.testmod(module, globs={}, report=True, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)


def test_an_example_gets_no_names_it_does_not_import():
    from chatterbench.reference.scene import load_scene

    module = types.ModuleType("pasted", '>>> load_scene("bouncing-ball").name\n\'bouncing-ball\'\n')
    module.load_scene = load_scene  # a name of the module itself: still not the example's
    assert _run_examples(module).failed == 1
    module.__doc__ = ">>> from chatterbench.reference.scene import load_scene\n" + module.__doc__
    assert _run_examples(module) == (0, 2)


# the tests' own shared modules with examples (helpers, synthetic trajectories): the same rule
TEST_MODULES = sorted(p for p in (ROOT / "tests").rglob("*.py")
                      if not p.name.startswith(("test_", "conftest")) and ">>>" in p.read_text(encoding="utf-8"))


@pytest.mark.parametrize("path", TEST_MODULES, ids=[p.stem for p in TEST_MODULES])
def test_test_module_examples_run(path, monkeypatch):
    monkeypatch.syspath_prepend(str(path.parent))  # as pytest imports them: from their own folder
    result = _run_examples(importlib.import_module(path.stem))
    assert result.failed == 0 and result.attempted > 0, f"{result} in {path} (printed above)"


# modules outside an adapter package whose examples run an optional engine
EXAMPLE_ENGINES = {"chatterbench.comparisons.studies.tune.conformance": "mujoco_warp"}  # MuJoCo Warp's tune against MuJoCo C


def _engine_of(module: str) -> str:
    """The built-in engine whose adapter package holds ``module``, or that its examples run (``EXAMPLE_ENGINES``;
    "": none)."""
    from chatterbench.engines.registry import BUILT_IN

    if module in EXAMPLE_ENGINES:
        return EXAMPLE_ENGINES[module]
    for row in BUILT_IN:
        package = row.adapter.partition(":")[0]
        if module == package or module.startswith(package + "."):
            return row.name
    return ""


@pytest.mark.parametrize("name", _modules())
def test_module_examples_run(name, monkeypatch):
    if _engine_of(name):
        needs_engine(_engine_of(name))  # an optional engine's examples skip, with its install line, when it is absent
    monkeypatch.chdir(ROOT)  # examples name repository files: gates/default.toml, examples/sweeps/...
    module = importlib.import_module(name)
    result = _run_examples(module)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of {name} failed (printed above)"
    if module.__doc__ and ">>>" in module.__doc__:
        assert result.attempted > 0
