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


# the stages inside comparisons/, lowest first: a stage imports only from itself and the stages before it
STAGES = ("pipeline", "studies", "outputs", "ci", "cli")


def test_stages_inside_comparisons_import_one_way():
    rank = {f"chatterbench.comparisons.{s}": i for i, s in enumerate(STAGES)}

    def stage(module):  # a module directly in comparisons/ (its __init__) is below every stage
        return next((v for k, v in rank.items() if module == k or module.startswith(k + ".")), -1)

    names = {m for m in _modules() if m.startswith("chatterbench.comparisons.")}
    assert {m.split(".")[2] for m in names} <= set(STAGES), "a new stage: add it to STAGES, in its place"
    wrong = sorted(f"{a} -> {b}" for a, targets in _graph().items() if a.startswith("chatterbench.comparisons")
                   for b in targets if b.startswith("chatterbench.comparisons") and stage(b) > stage(a))
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


MAX_FUNCTION_LINES = 80  # a function of the studies, docstring and signature included (issue 43: tune's was 101)


def test_no_function_of_the_studies_over_80_lines():
    # the studies grew by accretion (a tune of 101 lines, 19 parameters): a longer one is split by idea, its
    # parameters grouped (tune.runner.Limits); methods and nested functions are measured too
    long = []
    for path in sorted((ROOT / "comparisons" / "studies").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert not long, f"split these by idea: {long}"


def test_every_package_folder_is_installed():
    text = (ROOT / "pyproject.toml").read_text()
    packages = {name for name, path in _modules().items() if path.name == "__init__.py"}
    missing = [p for p in packages if f'"{p}"' not in text]
    assert not missing, f"add to [tool.setuptools] packages in pyproject.toml: {missing}"


# where a built-in engine's name may be written in code (docstrings aside): its own adapter package, the engine
# table, and the one-engine facts below, each with its reason; every other list of engines reads the table
ENGINE_NAME_ALLOWED = {
    "engines/registry.py": "the engine table itself (BUILT_IN)",
    "comparisons/studies/bench.py": "the benchmark cases: MuJoCo Warp's world-steps against MuJoCo C",
    "comparisons/studies/bench_tune.py": "the tune, ladder and atlas benchmarks' cases",
    "comparisons/cli/bench.py": "`bench sweep --only warp`: MuJoCo Warp's world-steps per second",
    "comparisons/pipeline/cross_check.py": "Siconos is the reference's cross-check (a second nonsmooth reference)",
}


def _code_strings(path: Path) -> list[tuple[int, str]]:
    """(line, text) of every string constant of a module, its docstrings left out."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = {id(node.body[0].value) for node in ast.walk(tree)
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body
            and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def test_no_engine_name_in_code_but_its_adapter_and_the_engine_table():
    from chatterbench.engines.registry import BUILT_IN

    names = {e.name for e in BUILT_IN}
    found = []
    for path in _modules().values():
        rel = path.relative_to(ROOT)
        if rel.parts[0] == "engines" and rel.parts[1].endswith("_engine") or str(rel) in ENGINE_NAME_ALLOWED:
            continue
        found += [f"{rel}:{line} {text!r}" for line, text in _code_strings(path)
                  if text in names or text.split(".", 1)[0] in names and "." in text]
    assert not found, f"engine names written in code: read them from engines.registry, or make them an adapter fact: {found}"


@pytest.mark.skipif(importlib.util.find_spec("radon") is None, reason="radon is in the test extra: pip install '.[test]'")
def test_no_function_of_complexity_grade_e_or_f():
    # what `radon cc -n E reference engines comparisons` lists: a block of cyclomatic complexity > 30
    from radon.complexity import cc_rank, cc_visit

    blocks = [(str(p.relative_to(ROOT)), b) for p in _modules().values() for b in cc_visit(p.read_text(encoding="utf-8"))]
    blocks += [(f, m) for f, b in blocks for m in getattr(b, "methods", [])]  # a class's methods, graded one by one
    worst = sorted(f"{f}:{b.lineno} {b.name} {cc_rank(b.complexity)} ({b.complexity})" for f, b in blocks
                   if cc_rank(b.complexity) in "EF")
    assert not worst, f"split these (a table of checks, or one helper per part): {worst}"


NEEDS_PYLINT = pytest.mark.skipif(importlib.util.find_spec("pylint") is None,
                                  reason="pylint is in the test extra: pip install '.[test]'")


@NEEDS_PYLINT
def test_no_duplicate_code():
    # what `pylint --disable=all --enable=duplicate-code --min-similarity-lines=6 reference engines comparisons`
    # reports, by pylint's own code on trees built without inference (tests/duplicates.py)
    from duplicates import copies

    paths = sorted(_modules().values())
    pragmas = [str(p.relative_to(ROOT)) for p in paths if "duplicate-code" in p.read_text(encoding="utf-8")]
    assert not pragmas, f"a pylint pragma on duplicate-code, which copies() does not read: {pragmas}"
    report = copies(paths)
    assert not report, report[-4000:]


@NEEDS_PYLINT
def test_the_duplicate_finder_reports_what_pylints_own_trees_give(tmp_path):
    from duplicates import copies

    # a real module twice (imports, decorators, signatures, docstrings, self.x = ...), and a block of 7 lines
    # (reported) beside one of 6 (not): the fast trees give pylint's report, word for word
    source = (ROOT / "engines" / "base.py").read_text(encoding="utf-8")
    (tmp_path / "one.py").write_text(source)
    (tmp_path / "two.py").write_text(source)

    def block(sign: str, n: int) -> str:
        return "".join(f"    total = total {sign} {i} * x\n" for i in range(n))

    head = "import math\n\n\ndef {}(\n    x,\n):\n    \"\"\"Doc.\"\"\"\n    total = {}\n"
    (tmp_path / "seven_a.py").write_text(head.format("seven_a", "math.pi") + block("+", 7))
    (tmp_path / "seven_b.py").write_text(head.format("seven_b", "math.e") + block("+", 7) + "    return total\n")
    (tmp_path / "six_a.py").write_text(head.format("six_a", "math.pi") + block("-", 6))
    (tmp_path / "six_b.py").write_text("def six_b(x):\n    total = 1\n" + block("-", 6) + "    return -total\n")
    paths = sorted(tmp_path.glob("*.py"))
    fast, pylints = copies(paths), copies(paths, fast=False)
    assert fast == pylints
    assert "one.py" in fast and "two.py" in fast  # the module's copy
    assert "7 similar lines in 2 files" in fast and "seven_a.py" in fast  # 7 shared lines: a copy
    assert "six_a.py" not in fast and "six_b.py" not in fast  # 6: not


def test_no_test_module_imports_from_a_conftest():
    # `from conftest import run` in tests/reference got tests/comparisons/studies/conftest.py when both folders were
    # collected (`pytest tests/reference tests/comparisons/studies/test_tune_warp.py ...`: 2 collection errors); shared
    # test code lives in modules of its own name (tests/helpers.py and the like)
    found = [str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("*.py")
             if any(isinstance(n, ast.ImportFrom) and n.module == "conftest"
                    or isinstance(n, ast.Import) and any(a.name == "conftest" for a in n.names)
                    for n in ast.walk(ast.parse(p.read_text(encoding="utf-8"))))]
    assert not found, f"import shared test code from a module of its own name, not from conftest: {found}"
