"""pytest plugin: ``--chatterbench-engine NAME`` runs the shipped engine contract suite against an installed engine.

    pip install "chatterbench[test]" ./my-engine        # the plugin's package: its entry point declares NAME
    cd "$(mktemp -d)" && python -m pytest --chatterbench-engine NAME

Registered through the ``pytest11`` entry point ``chatterbench_engines``, so installing
chatterbench is enough (disable with ``-p no:chatterbench_engines``). The option takes an
engine's name, repeated or as a comma list (``--chatterbench-engine mujoco,pymunk``), any
engine of the table: built in, or a plugin found through its entry point. Given it, the
session also collects the tests of ``contract_tests.py`` (the module docstring says what they
check) with each named engine as the ``contract_engine`` fixture; with no path given (in an
empty folder, say) it runs only those. A name no engine has is a usage error before anything
runs, with the nearest names; an engine that cannot run here (a plugin that does not load, an
extra not installed) fails every test with its one-line reason.

A test module of one's own can run the same tests on its engines: import them and set
``CONTRACT_ENGINES``, the names they take when the option is not given (this package's
``tests/engines/test_contract.py``)::

    from chatterbench.engines.contract_tests import *  # noqa: F401,F403
    CONTRACT_ENGINES = ("myengine",)

Promises: nothing heavy is imported until the option is given or a test asks for
``contract_engine``; the tests are the package's own module, imported once (never a copy
from a path), so their classes are the registry's.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import pytest

OPTION = "--chatterbench-engine"
MODULE = "chatterbench.engines.contract_tests"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("chatterbench", "chatterbench engines")
    group.addoption(OPTION, action="append", default=[], metavar="NAME",
                    help="run chatterbench's engine contract suite against engine NAME (repeatable, or a comma list)")


def engine_names(config: pytest.Config) -> list[str]:
    """The names given with ``--chatterbench-engine``, in order, each once."""
    given = [n.strip() for value in config.getoption("chatterbench_engine") or () for n in value.split(",")]
    return list(dict.fromkeys(n for n in given if n))


def pytest_configure(config: pytest.Config) -> None:
    names = engine_names(config)
    if not names:
        return
    from .settings import SettingsError
    from .registry import check_engine

    for name in names:  # a misspelt name: said once, before anything is collected
        try:
            check_engine(name)
        except SettingsError as exc:  # the registry's one line: the engines there are, the nearest name
            raise pytest.UsageError(f"{OPTION} {name}: {exc}") from None


class _Suite(pytest.Module):
    """The shipped test module, collected from the imported package module (not imported again from its path)."""

    def _getobj(self) -> Any:
        return importlib.import_module(MODULE)


@pytest.hookimpl(tryfirst=True)  # before -k and -m deselect, so that they apply to the suite's tests too
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    if not engine_names(config):
        return
    module = importlib.import_module(MODULE)
    suite = _Suite.from_parent(session, path=Path(module.__file__), nodeid=MODULE)
    ours = list(session.genitems(suite))
    if config.args_source != pytest.Config.ArgsSource.ARGS:  # no path given: the suite alone
        if items:
            config.hook.pytest_deselected(items=list(items))
        items[:] = ours
    else:
        items.extend(ours)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "contract_engine" not in metafunc.fixturenames:
        return
    names = engine_names(metafunc.config) or list(getattr(metafunc.module, "CONTRACT_ENGINES", ()))
    metafunc.parametrize("contract_engine", names, ids=names)
