"""The house rules a newcomer relies on: imports go one way, no cycles, small files, no copy-paste."""

from __future__ import annotations

import ast
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FLOORS = {"reference": "chatterbench.reference", "engines": "chatterbench.engines", "comparisons": "chatterbench.comparisons"}
MAX_LINES = 500
# a numba kernel file may be longer, with its reason in its docstring; none is today
LONG_FILES: dict[str, str] = {}


def _modules() -> dict[str, Path]:
    """Every module of the three packages: dotted name -> file."""
    out = {}
    for folder, package in FLOORS.items():
        for path in (ROOT / folder).rglob("*.py"):
            rel = path.relative_to(ROOT / folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            out[".".join([package, *parts])] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package modules ``name`` imports anywhere in its file (inside functions too)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_package = path.name == "__init__.py"
    here = name.split(".") if is_package else name.split(".")[:-1]
    found = set()
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(here[: len(here) - node.level + 1] + ([base] if base else []))
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
        for t in targets:
            if t in modules:
                found.add(t)
    found.discard(name)
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def test_imports_go_one_way_reference_engines_comparisons():
    rank = {"chatterbench.reference": 0, "chatterbench.engines": 1, "chatterbench.comparisons": 2}
    floor = lambda m: next(v for k, v in rank.items() if m == k or m.startswith(k + "."))  # noqa: E731
    wrong = [(a, b) for a, targets in _graph().items() for b in targets if floor(b) > floor(a)]
    assert not wrong, wrong


def test_no_import_cycle_counting_imports_inside_functions():
    graph = _graph()
    # a package importing its own submodules is how a package works; a submodule importing
    # its package's __init__ back would be a cycle, and is counted
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    assert not cycles, cycles


def test_no_source_file_over_500_lines():
    long = {str(p.relative_to(ROOT)): sum(1 for _ in p.open()) for p in _modules().values()}
    over = {k: n for k, n in long.items() if n > MAX_LINES and k not in LONG_FILES}
    assert not over, over


def test_every_package_folder_is_installed():
    text = (ROOT / "pyproject.toml").read_text()
    packages = {name for name, path in _modules().items() if path.name == "__init__.py"}
    missing = [p for p in packages if f'"{p}"' not in text]
    assert not missing, f"add to [tool.setuptools] packages in pyproject.toml: {missing}"


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("pylint") is None, reason="pylint is in the test extra: pip install '.[test]'")
def test_no_duplicate_code():
    proc = subprocess.run([sys.executable, "-m", "pylint", "--disable=all", "--enable=duplicate-code",
                           "--min-similarity-lines=6", "reference", "engines", "comparisons"],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-4000:]
