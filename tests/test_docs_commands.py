"""Every command block of the README and the docs pages runs, or says why it is not run here.

A command block (```` ```bash ````, ``sh``, ``shell``, ``console``) is one of three kinds:

- *run here*: its lines run one after another in a scratch folder holding copies of ``examples/`` and
  ``gates/``, a ``chatterbench ...`` line in this process (``main``), any other line in bash; each
  must exit 0, or the code a trailing ``# exit N`` names. Where a ```` ```text ```` block follows it,
  every line of that block (``...`` standing for anything) is in what the block's commands printed;
- *covered*: ``COVERED`` names the test that runs the same command (one that installs the package);
- *not run*: a ``<!-- not run: REASON -->`` line right above it; a test the reason names exists.

A block under ``<!-- file: PATH -->`` is that file of the repository as it is (a gate file a page shows).

Every fence names its language, so no command hides in an untagged block.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest
from docs_blocks import ROOT, all_blocks

from chatterbench.comparisons.cli.main import main

# (page, the block's first command) -> the tests that run its commands: the set-up block's two, the report as a new
# user runs it, and the test command, which .ci/run runs as written (after the install, which it runs too)
SET_UP = ("tests/comparisons/outputs/test_report.py::test_the_readmes_report_loads_every_figure_in_chromium",
          "tests/test_docs.py::test_ci_runs_the_readmes_test_command_with_every_optional_extra")
COVERED = {
    ("README.md", "python3 -m pip install . && chatterbench report"): SET_UP,
    ("docs/how-to/install.md", "python3 -m pip install . && chatterbench report"): SET_UP,
}
BLOCKS = all_blocks()
RUN = [b for b in BLOCKS if b.is_command and not b.not_run and (b.page, b.lines[0]) not in COVERED]
_TEST = re.compile(r"(tests/[\w/]+\.py)::(\w+)")
_SHELL = set("|&;<>$`()*?")


def _test_exists(node: str) -> bool:
    path, name = _TEST.fullmatch(node).groups()
    source = (ROOT / path).read_text(encoding="utf-8") if (ROOT / path).is_file() else ""
    return re.search(rf"^(async )?def {name}\(", source, re.M) is not None


def test_every_fence_names_its_language():
    bare = [f"{b.page}:{b.line}" for b in BLOCKS if not b.language]
    assert not bare, f"fences with no language (bash for commands, text for output): {bare}"


def test_a_block_not_run_says_why_and_the_tests_it_names_exist():
    marked = [b for b in BLOCKS if b.not_run]
    assert all(b.is_command for b in marked), [f"{b.page}:{b.line}" for b in marked if not b.is_command]
    short = [f"{b.page}:{b.line}" for b in marked if len(b.not_run.split()) < 5]
    assert not short, f"a reason of a few words at least: {short}"
    named = [(f"{b.page}:{b.line}", m[0]) for b in marked for m in _TEST.finditer(b.not_run)]
    assert [n for n in named if not _test_exists(n[1])] == []


def test_the_covered_commands_are_in_the_docs_and_their_tests_exist():
    firsts = {(b.page, b.lines[0]) for b in BLOCKS if b.is_command}
    assert [k for k in COVERED if k not in firsts] == []
    assert [t for tests in COVERED.values() for t in tests if not _test_exists(t)] == []


def test_a_block_that_shows_a_file_is_the_file():
    shown = [b for b in BLOCKS if b.file]
    assert shown, "the tutorial shows its gate file"
    assert [f"{b.page}:{b.line}" for b in shown if b.text != (ROOT / b.file).read_text(encoding="utf-8")] == []


def _run_line(line: str, env: dict[str, str]) -> tuple[int, str]:
    """One command line: its exit code and what it printed (stdout)."""
    words = shlex.split(line, comments=True)
    if words[0] == "chatterbench" and not _SHELL & set(line.split("#", 1)[0]):
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            code = main(words[1:])
        return code, out.getvalue()
    done = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", line], env=env, capture_output=True, text=True,
                          timeout=600)
    return done.returncode, done.stdout + done.stderr


def _expected_code(line: str) -> int:
    found = re.search(r"#.*\bexit (\d)\b", line)
    return int(found[1]) if found else 0


@pytest.mark.slow
@pytest.mark.parametrize("block", RUN, ids=[f"{b.page}:{b.line}" for b in RUN])
def test_a_command_block_runs_as_written(block, tmp_path, monkeypatch):
    for folder in ("examples", "gates"):
        shutil.copytree(ROOT / folder, tmp_path / folder)
    monkeypatch.chdir(tmp_path)
    env = {**os.environ, "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", "")}
    printed = []
    for line in block.lines:
        code, out = _run_line(line, env)
        assert code == _expected_code(line), f"{line}\n{out[-3000:]}"
        printed.append(out)
    text = " ".join(" ".join(printed).split())
    for shown in block.after.splitlines():
        if shown.strip() and shown.strip() != "...":
            pattern = ".*?".join(re.escape(" ".join(part.split())) for part in shown.split("..."))
            assert re.search(pattern, text), f"{block.page}:{block.line} prints no line like {shown!r}:\n{text[-3000:]}"
