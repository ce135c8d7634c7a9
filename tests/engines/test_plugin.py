"""A third party's engine, in its own package (``examples/engine_plugin``), installed with pip: found and judged.

The package is installed into a fresh virtual environment that sees this one's packages
(``--system-site-packages``), so the repository's environment is never changed; the commands
run in that environment's interpreter, as a user's shell would run them.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

PLUGIN = Path(__file__).resolve().parents[2] / "examples" / "engine_plugin"


def _run(*args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=300, **kw)


@pytest.mark.slow
def test_an_engine_installed_with_pip_is_listed_and_judged_match(tmp_path):
    venv = tmp_path / "venv"
    assert _run(sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", venv).returncode == 0
    python = venv / "bin" / "python"
    before = _run(python, "-m", "chatterbench.comparisons.cli", "compare", "bouncing-ball", "--engines", "exact")
    assert before.returncode == 2 and "engine 'exact'" in before.stderr  # not there before it is installed
    pip = _run(sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-deps", PLUGIN, cwd=tmp_path)
    assert pip.returncode == 0, pip.stdout + pip.stderr
    shown = _run(python, "-m", "chatterbench.comparisons.cli", "compare", "--help", cwd=tmp_path)
    assert re.search(r"--engines .*\bexact\b", " ".join(shown.stdout.split())), shown.stdout  # listed with the others
    judged = _run(python, "-m", "chatterbench.comparisons.cli", "compare", "bouncing-ball", "--engines", "exact",
                  cwd=tmp_path)
    assert judged.returncode == 0, judged.stderr
    summary = judged.stdout.split("summary:")[1].splitlines()
    header, row = summary[1].split(), summary[2].split()
    assert row[header.index("engine")] == "exact" and row[header.index("verdict")] == "match"
    # and it keeps the engine contract, checked by the suite every engine goes through
    contract = _run(python, "-m", "pytest", "-q", "-p", "no:cacheprovider", Path(__file__).parent / "test_contract.py",
                    "-k", "exact", cwd=tmp_path)
    assert contract.returncode == 0 and re.search(r"\b[1-9]\d* passed", contract.stdout), contract.stdout[-2000:]
    # the facts of other adapters are not said of it: --export-model names the engines whose adapters export
    refused = _run(python, "-m", "chatterbench.comparisons.cli", "run", "bouncing-ball", "--engines", "exact",
                   "--export-model", tmp_path / "m.xml", cwd=tmp_path)
    assert refused.returncode == 2 and "engine 'exact': cannot export a model; engines that can: mujoco, pybullet" \
        in refused.stderr, refused.stderr
    # and it is drawn in a colour of its own, as every engine of the table is
    colours = _run(python, "-c", "from chatterbench.comparisons.outputs.style import engine_colour as c; "
                   "from chatterbench.engines.registry import ENGINE_NAMES as n; print(c('exact'), *map(c, n[:-1]))")
    mine, *others = colours.stdout.split()
    assert mine.startswith("#") and mine not in others, colours.stdout + colours.stderr
