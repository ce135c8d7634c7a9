"""No test asserts a wall time: on a loaded machine a correct program takes longer, and a timed assertion fails.

Speed is a benchmark's business (``chatterbench bench ...``). A test asserts behaviour: "refused before any
engine ran" (no run's files, no rows), not "refused within 2 s". This scan reads every test file and refuses a
comparison that involves a clock reading (``time.time``, ``monotonic``, ``perf_counter``, ``process_time``, their
``_ns`` forms) or a value computed from one (a name assigned from it, a local function that reads a clock), in an
``assert``, an ``if`` or an expression. A clock read in a ``while`` condition is allowed: that is a polling loop
with a hang guard (``tests/helpers.wait_until``), after which the test asserts the behaviour it waited for.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
CLOCKS = {"time", "monotonic", "perf_counter", "process_time", "time_ns", "monotonic_ns", "perf_counter_ns",
          "process_time_ns"}
ORDER = (ast.Lt, ast.LtE, ast.Gt, ast.GtE)


def _is_clock_call(node: ast.AST) -> bool:
    """``time.monotonic()`` and the like (an attribute of a name ``time``) or ``monotonic()`` imported bare."""
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    if isinstance(f, ast.Attribute):
        return f.attr in CLOCKS and isinstance(f.value, ast.Name) and f.value.id == "time"
    return isinstance(f, ast.Name) and f.id in CLOCKS - {"time"}


class _Timed:
    """Which names and local functions of one file carry a clock reading (to a fixed point)."""

    def __init__(self, tree: ast.Module) -> None:
        self.functions: set[str] = set()
        self.names: set[str] = set()
        changed = True
        while changed:
            changed = False
            for node in ast.walk(tree):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name not in self.functions:
                    if any(self.reads_clock(n) for stmt in node.body for n in ast.walk(stmt)
                           if isinstance(n, ast.Return) and n.value is not None) or self._returns_timed(node):
                        self.functions.add(node.name)
                        changed = True
                if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)) and node.value is not None:
                    if self.reads_clock(node.value):
                        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                        for t in targets:
                            for name in ast.walk(t):
                                if isinstance(name, ast.Name) and name.id not in self.names:
                                    self.names.add(name.id)
                                    changed = True

    def _returns_timed(self, func: ast.AST) -> bool:
        """A function whose returned value comes from a list it appends clock-derived values to (``min(times)``)."""
        appended = {n.func.value.id for n in ast.walk(func) if isinstance(n, ast.Call)
                    and isinstance(n.func, ast.Attribute) and n.func.attr == "append"
                    and isinstance(n.func.value, ast.Name) and any(self.reads_clock(a) for a in n.args)}
        return any(isinstance(n, ast.Return) and n.value is not None
                   and any(isinstance(m, ast.Name) and m.id in appended for m in ast.walk(n.value))
                   for n in ast.walk(func))

    def reads_clock(self, node: ast.AST) -> bool:
        for n in ast.walk(node):
            if _is_clock_call(n) or (isinstance(n, ast.Name) and n.id in self.names):
                return True
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in self.functions:
                return True
        return False


def timed_comparisons(source: str) -> list[int]:
    """Line numbers of the ordering comparisons that involve a clock reading, outside ``while`` conditions.

    >>> timed_comparisons("import time\\nt0 = time.monotonic()\\nrun()\\nassert time.monotonic() - t0 < 2\\n")
    [4]
    >>> timed_comparisons("import time\\nend = time.monotonic() + 60\\nwhile not done() and time.monotonic() < end:\\n"
    ...                   "    pass\\nassert done()\\n")
    []
    """
    tree = ast.parse(source)
    timed = _Timed(tree)
    polling = {id(n) for w in ast.walk(tree) if isinstance(w, ast.While) for n in ast.walk(w.test)}
    return sorted({node.lineno for node in ast.walk(tree)
                   if isinstance(node, ast.Compare) and id(node) not in polling
                   and any(isinstance(op, ORDER) for op in node.ops) and timed.reads_clock(node)})


def test_no_test_compares_a_wall_time():
    found = [f"{path.relative_to(TESTS.parent)}:{line}" for path in sorted(TESTS.rglob("*.py"))
             for line in timed_comparisons(path.read_text(encoding="utf-8"))]
    assert not found, "a test compares a wall time (assert behaviour; time it in a benchmark):\n" + "\n".join(found)


def test_the_scan_finds_each_kind_of_timed_assertion():
    # known answers both ways: each shape the suite had before this scan is found, a polling loop is not
    caught = {
        "took": "import time\nt0 = time.monotonic()\nx()\ntook = time.monotonic() - t0\nassert took < 2, took\n",
        "inline": "import time\nstart = time.perf_counter()\nx()\nassert time.perf_counter() - start < 5.0\n",
        "deadline": "import time\nend = time.monotonic() + 30\nfor _ in x():\n    assert time.monotonic() < end\n",
        "ratio": ("import time\ndef best(n):\n    times = []\n    for _ in range(3):\n        s = time.perf_counter()\n"
                  "        run(n)\n        times.append(time.perf_counter() - s)\n    return min(times)\n"
                  "speed = 10 / (best(2) - best(1))\nassert 1 / 3 < bench() / speed < 3\n"),
        "returned": "import time\ndef f():\n    s = time.time()\n    x()\n    return time.time() - s\nif f() > 4:\n    y()\n",
    }
    for name, source in caught.items():
        assert timed_comparisons(source), name
    assert timed_comparisons("import time\nwhile time.monotonic() < 3:\n    pass\nassert x() < 2\n") == []


def test_the_engine_run_spy_sees_runs_in_this_process_and_in_isolated_children(engine_runs):
    # the spy replaces "refused within 2 s" with "refused before any engine ran": it must see every kind of run
    from chatterbench.engines.registry import make_settings, run_engine, run_engine_isolated
    from chatterbench.engines.settings import SettingsError
    from chatterbench.reference.scene import load_scene

    scene = load_scene("bouncing-ball", ["duration=0.01"])
    assert engine_runs() == []
    run_engine("pybullet", scene, make_settings("pybullet", 1e-3))
    assert engine_runs() == ["pybullet.run"]
    assert run_engine_isolated("mujoco", scene, make_settings("mujoco", 1e-3), timeout=120).status == "ok"
    assert engine_runs() == ["pybullet.run", "mujoco.run"]  # logged by the forked child
    with pytest.raises(SettingsError):  # refused before the engine steps: no run
        run_engine("mujoco", load_scene("feigin-pair"), make_settings("mujoco", 1e-3, ["mujoco.w0_dt=1.9"]))
    assert engine_runs() == ["pybullet.run", "mujoco.run"]
