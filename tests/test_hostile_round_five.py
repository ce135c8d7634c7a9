"""Hostile runs of issue 45 (round five): links out of an input folder, CI-log and job-summary injection, a guide
section that covers the page, raw HTML in the Markdown outputs, non-regular output targets, a frontier without a
number ``dt`` or of 12,000 points.

The cases run as ``tests/test_hostile_cases.py``'s do (its ``Case``, its scratch directory: a gate file
``gate.toml``, a named pipe ``apipe``, a folder ``elsewhere/`` outside every output), each with what happened before
this round; ``docs/bad-inputs.md`` shows them in its section "Round five" (``markdown_rows``). Every stand-in for a
device or ``/dev/stdout`` is made in the scratch directory: never the machine's own ``/dev``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Callable
from xml.etree import ElementTree as ET

import pytest

from chatterbench.comparisons.pipeline.inert_text import log_text
from helpers import cli
from shared_runs import made_once, session_folder
from test_hostile_cases import GATE, REPORT, Case, Outcome, _scratch, assert_outcome, message

SECRET = "root:x:0:0:SECRET-OUTSIDE-THE-FOLDER"  # what an outside file holds: it must reach no output
INJECTED = "x\n::warning title=INJ::injected\n## INJ fake PASS\n##[warning]INJ legacy\n| INJ | row |"
BEACON = "<img src=http://198.51.100.7/beacon.png>"
OVERLAY = ('<h2>Tuning</h2><div style="position:fixed;inset:0;z-index:2147483647;background:white" class="cover" id="cover">'
           "<h1>chatterbench report</h1><p>every engine: match</p></div><p>the answer</p>")
# the ball on a free floor (examples/scenes), 1.6 s: a scene file whose ``name`` a case sets
SCENE = (Path(__file__).resolve().parents[1] / "examples" / "scenes" / "ball-free-floor.toml").read_text().replace(
    'name = "ball-free-floor"', "name = {name}").replace("duration = 2.0", "duration = 1.6")


def _frontier_entry(**change) -> dict:
    entry = {"tolerances": {"stick": 0.05, "exit": 0.05, "first_impact": 0.05, "restitution": 0.05}, "dt": 1e-3,
             "settings": {"pybullet.restitution_velocity_threshold": 0.1}, "cost_steps_per_s": 1000.0, "margin": 0.5}
    return {k: v for k, v in {**entry, **change}.items() if v is not None}


def _recommended(**change) -> dict:
    rec = {"scene": "bouncing-ball", "engine": "pybullet", "tolerances": {"stick": 0.05, "restitution": 0.05},
           "frontier": [_frontier_entry()]}
    rec.update(change)
    return rec


# -- setups ----------------------------------------------------------------------------------------------------------
def _tune_folder(guide: str = "<h2>Tuning</h2><p>the answer</p>", rec: dict | None = None,
                 link: str | None = None) -> Callable[[Path], dict[str, str]]:
    """``t/`` as a tune wrote it (a guide section, maybe a recommended.json), with ``link`` planted: ``guide`` (its
    guide section links to an outside file), ``rec`` (recommended.json does), ``folder`` (an engine's folder does)."""
    def setup(root: Path) -> dict[str, str]:
        t, outside = root / "t", root / "elsewhere"
        t.mkdir()
        (outside / "secret.txt").write_text(SECRET + "\n")
        if link == "guide":
            (t / "guide_section.html").symlink_to("../elsewhere/secret.txt")
        else:
            (t / "guide_section.html").write_text(guide)
        if rec is not None:
            (t / "recommended.json").write_text(json.dumps(rec))
        if link == "rec":
            (outside / "recommended.json").write_text(json.dumps(_recommended(engine=SECRET)))
            (t / "recommended.json").symlink_to("../elsewhere/recommended.json")
        if link == "folder":
            (outside / "tuned").mkdir()
            (outside / "tuned" / "recommended.json").write_text(json.dumps(_recommended(engine=SECRET)))
            (t / "pybullet").symlink_to("../elsewhere/tuned")
        return {}
    return setup


def _linked_rows(root: Path) -> dict[str, str]:
    (root / "s").mkdir()
    (root / "elsewhere" / "rows.parquet").write_text(SECRET)
    (root / "s" / "rows.parquet").symlink_to("../elsewhere/rows.parquet")
    return {}


def _scene_named(name: str) -> Callable[[Path], dict[str, str]]:
    def setup(root: Path) -> dict[str, str]:
        (root / "s.toml").write_text(SCENE.replace("{name}", json.dumps(name)))
        return {}
    return setup


def _injected_gate(root: Path) -> dict[str, str]:
    """A gate whose every name field holds ``INJECTED``: the check's name, the description, the gate file's name, a
    scene file's name, the scene's ``name``, a ``scene_overrides`` key; a baseline (as a shared cache could hold it)
    whose versions and gate name hold it too; GitHub's step summary to append to."""
    scene = root / f"scene{INJECTED}.toml"
    scene.write_text(SCENE.replace("{name}", json.dumps("ball" + INJECTED)))
    gate = root / f"gate{INJECTED}.toml"
    gate.write_text(f'description = {json.dumps("promises" + INJECTED)}\n'
                    f'[[check]]\nname = {json.dumps("check" + INJECTED)}\nscene = {json.dumps(scene.name)}\n'
                    'engine = "pybullet"\ndt = 1e-3\nscene_overrides = { duration = 0.2 }\nlimits = ["status == ok"]\n'
                    # a check that fails: its account, the commands to run next (the scene file's name in them), the
                    # ::error annotation and the summary's failure rows are printed too
                    f'[[check]]\nname = {json.dumps("failing" + INJECTED)}\nscene = {json.dumps(scene.name)}\n'
                    'engine = "pybullet"\ndt = 1e-3\nscene_overrides = { duration = 0.2 }\nlimits = ["n_match >= 99"]\n')
    cli(["gate", gate.name, "--save-baseline", "base.json"])
    assert (root / "base.json").exists()
    data = json.loads((root / "base.json").read_text())
    data["versions"]["pybullet"] = "3.2.7" + INJECTED
    (root / "base.json").write_text(json.dumps(data))
    (root / "step.md").write_text("")
    return {"GITHUB_ACTIONS": "true", "GITHUB_STEP_SUMMARY": "step.md"}


def _injected_key(root: Path) -> dict[str, str]:
    (root / "k.toml").write_text(GATE.replace("duration = 0.2", json.dumps("duration" + INJECTED) + " = 0.2"))
    return {"GITHUB_ACTIONS": "true"}


def _link_to(kind: str) -> Callable[[Path], dict[str, str]]:
    """``alink``, a symbolic link standing for ``/dev/stdout``: to a named pipe, to a regular file, or to nothing."""
    def setup(root: Path) -> dict[str, str]:
        if kind == "fifo":
            os.mkfifo(root / "pipe")
            (root / "alink").symlink_to("pipe")
        if kind == "file":
            (root / "target.txt").write_text("the user's\n")
            (root / "alink").symlink_to("target.txt")
        if kind == "nothing":
            (root / "alink").symlink_to("missing/target.txt")
        return {}
    return setup


# -- what must be on disk after -------------------------------------------------------------------------------------
def _outside_not_shown(got: Outcome) -> str:
    assert SECRET not in got.output
    for page in ("index.html", "report.md"):
        path = got.root / "r" / page
        assert not path.exists() or SECRET not in path.read_text()
    return "r/: no page holds the outside file (before: its content in index.html / report.md)"


def _no_overlay(got: Outcome) -> str:
    page = (got.root / "r" / "index.html").read_text()
    section = page[page.index("<h2>Tuning</h2>"):page.index("the answer")]
    assert "position" not in section and "style=" not in section and "class=" not in section and 'id="cover"' not in page
    assert "the answer" in page and page.index("What produced this report") > page.index("the answer")
    return "r/index.html: the text kept, no style, class or id from the file (before: the div covered the page)"


def _markdown_inert(got: Outcome) -> str:
    lines = [ln for p in ("r/report.md", "d/guide.md") if (got.root / p).exists()
             for ln in (got.root / p).read_text().splitlines()]
    assert lines
    raw = [ln for ln in lines if re.search(r"(?<!\\)<(img|script)", ln) or ln.lstrip().startswith("## INJ")]
    assert raw == [], raw
    return "no raw <img>, <script> or injected heading in the Markdown (before: raw in report.md and guide.md)"


def _log_clean(got: Outcome) -> str:
    lines = got.output.splitlines()
    summary = got.root / "step.md"
    lines += summary.read_text().splitlines() if summary.exists() else []
    for line in lines:
        start = line.lstrip()
        assert not start.startswith(("::warning", "## INJ", "| INJ")), line
        assert "##[" not in line, line
        assert not start.startswith("::") or start.startswith(("::error ", "::notice ")), line
    for junit in got.root.glob("j*.xml"):  # read by a JUnit reader: still XML, the failing check there
        assert ET.parse(junit).getroot().find("testsuite/testcase/failure") is not None
    return ("no line of the log or the job summary starts with the injected ::warning, heading or table row "
            "(before: each its own line; a fake PASS heading)")


def _link_kept(target: str) -> Callable[[Outcome], str]:
    def after(got: Outcome) -> str:
        link = got.root / "alink"
        assert link.is_symlink() and os.readlink(link) == target, "the link was replaced"
        if target == "target.txt":
            assert (got.root / "target.txt").read_text() == "the user's\n"
        return f"alink -> {target}: still a link, its target untouched (before: replaced by a regular file)"
    return after


ROUND_FIVE = [
    # links out of an input folder
    Case("report --tune linked guide", "t/guide_section.html is a link to a file outside t (before: exit 0, the file "
         "in index.html)", [*REPORT, "--tune", "t"], 2,
         ("--tune t: guide_section.html: a symbolic link (-> ../elsewhere/secret.txt)",),
         setup=_tune_folder(link="guide"), after=_outside_not_shown),
    Case("report --tune linked recommended.json", "t/recommended.json is a link out of t (before: its content in "
         "report.md)", [*REPORT, "--tune", "t"], 2,
         ("--tune t: recommended.json: a symbolic link (-> ../elsewhere/recommended.json)",),
         setup=_tune_folder(link="rec"), after=_outside_not_shown),
    Case("report --tune linked folder", "t/pybullet is a link to a folder outside t (before: its recommended.json in "
         "report.md)", [*REPORT, "--tune", "t"], 2,
         ("--tune t: pybullet/recommended.json: pybullet is a symbolic link (-> ../elsewhere/tuned)",),
         setup=_tune_folder(link="folder"), after=_outside_not_shown),
    Case("report --sweep linked rows", "s/rows.parquet is a link out of s", ["report", "bouncing-ball", "--sweep", "s"],
         2, ("s: rows.parquet is a symbolic link (-> ../elsewhere/rows.parquet)",), setup=_linked_rows),
    # a recommended.json the report cannot show
    Case("report --tune no dt", "a frontier entry without dt (before: KeyError: 'dt')", [*REPORT, "--tune", "t"], 2,
         ("--tune t: recommended.json: frontier[0].dt: missing",),
         setup=_tune_folder(rec=_recommended(frontier=[_frontier_entry(dt=None)]))),
    Case("report --tune dt fast", "a frontier entry with dt = \"fast\" (before: ValueError: Unknown format code 'g')",
         [*REPORT, "--tune", "t"], 2, ("frontier[0].dt: 'fast' is not a number > 0",),
         setup=_tune_folder(rec=_recommended(frontier=[_frontier_entry(dt="fast")]))),
    Case("report --tune 12,000 points", "a recommended.json of 12,000 frontier points, 3.6 MB (before: still running "
         "at 180 s)", [*REPORT, "--tune", "t"], 2, ("a frontier of 12,000 points, more than the 100 the report draws",),
         setup=_tune_folder(rec=_recommended(frontier=[_frontier_entry(cost_steps_per_s=1000.0 + i)
                                                        for i in range(12000)]))),
    # pages and Markdown
    Case("report --tune overlay", "a guide section whose div covers the page (position:fixed, z-index, white; before: "
         "kept, the browser showed only 'every engine: match')", [*REPORT, "--tune", "t"], 0, (),
         setup=_tune_folder(guide=OVERLAY), after=_no_overlay),
    Case("report --tune raw HTML engine", f"engine and scene fields {BEACON}\\n## INJ in recommended.json (before: "
         "raw in report.md)", [*REPORT, "--tune", "t"], 0, (),
         setup=_tune_folder(rec=_recommended(engine=BEACON + "\n## INJ", scene=BEACON + "\n## INJ")),
         after=_markdown_inert),
    Case("tune scene named <script>", f"a scene named <script> with a remote {BEACON} (before: raw in guide.md)",
         ["tune", "s.toml", "--engine", "pybullet", "--max-runs", "2", "--repeats", "1", "--out", "d"], 1, (),
         setup=_scene_named("<script>alert(1)</script>" + BEACON + "\n## INJ"), after=_markdown_inert),
    Case("report scene named <script>", f"a scene named <script> with a remote {BEACON} (before: raw in report.md)",
         ["report", "s.toml", "--engines", "pybullet", "--out", "r"], 0, (),
         setup=_scene_named("<script>alert(1)</script>" + BEACON + "\n## INJ"), after=_markdown_inert),
    # CI log and job summary
    Case("gate injected names", "a newline, '::warning', '## ' and '##[' in the check's name, the description, the "
         "gate file's and scene file's names, the scene's name and a baseline's versions (before: a workflow command "
         "line and a fake heading of their own)",
         ["gate", f"gate{INJECTED}.toml", "--baseline", "base.json", "--junit", f"j{INJECTED}.xml"], 1,
         ("FAIL: 1 of 2 checks passed", "::error file="),
         setup=_injected_gate, after=_log_clean),
    Case("gate injected override key", "a newline and '::warning' in a scene_overrides key", ["gate", "k.toml"], 2,
         ("scene_overrides",), setup=_injected_key, after=_log_clean),
    # output targets that are not regular files (stand-ins for /dev/stdout, made in the scratch directory)
    Case("gate --summary link to a pipe", "--summary a link to a named pipe (before: the link replaced by a regular "
         "file when it was one)", ["gate", "gate.toml", "--summary", "alink"], 2,
         ("--summary alink: a symbolic link (-> pipe) to what is not a regular file",), setup=_link_to("fifo"),
         after=_link_kept("pipe")),
    Case("gate --summary link to a file", "--summary a link to a regular file, as /dev/stdout of a command whose "
         "output went to a file (before: the link replaced by a regular file)", ["gate", "gate.toml", "--summary",
         "alink"], 2, ("--summary alink: a symbolic link (-> target.txt), which the write would replace",),
         setup=_link_to("file"), after=_link_kept("target.txt")),
    Case("gate --junit dangling link", "--junit a link to nothing (before: the link replaced)",
         ["gate", "gate.toml", "--junit", "alink"], 2, ("--junit alink: a symbolic link to nothing",),
         setup=_link_to("nothing"), after=_link_kept("missing/target.txt")),
]


def run_case(case: Case, shared: Path | None = None) -> tuple[Outcome, str]:
    """One case, run once per test session (as ``test_hostile_cases.run_case``)."""
    import test_hostile_cases as hostile

    if case.id not in _DONE:
        code, output, root, said = made_once(shared, f"round-five-{ROUND_FIVE.index(case)}",
                                             lambda: hostile._run_case(case))
        _DONE[case.id] = Outcome(code, output, Path(root)), said
    return _DONE[case.id]


_DONE: dict[str, tuple[Outcome, str]] = {}

SLOW = {"report --tune overlay", "report --tune raw HTML engine", "tune scene named <script>",
        "report scene named <script>"}


@pytest.mark.parametrize("case", [pytest.param(c, marks=[pytest.mark.slow] if c.id in SLOW else [])
                                  for c in ROUND_FIVE], ids=[c.id for c in ROUND_FIVE])
def test_round_five_case(case, tmp_path_factory):
    got, _ = run_case(case, session_folder(tmp_path_factory))
    assert_outcome(got, case)


def test_case_ids_are_unique():
    assert len({c.id for c in ROUND_FIVE}) == len(ROUND_FIVE)


def test_summary_to_a_link_to_stdout_is_written_through_it(tmp_path):
    """``gate --summary /dev/stdout`` with stdout a file: a link to the file stdout goes to stands in for
    ``/dev/stdout``. The summary goes through stdout after the table, nothing is renamed over the link."""
    (tmp_path / "gate.toml").write_text(GATE)
    (tmp_path / "stdout").symlink_to("log.txt")
    with open(tmp_path / "log.txt", "w") as log:
        done = subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", "gate", "gate.toml", "--summary",
                               "stdout"], cwd=tmp_path, stdout=log, stderr=subprocess.PIPE, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "stdout").is_symlink()
    log = (tmp_path / "log.txt").read_text()
    assert log.index("bouncing-ball/pybullet") < log.index("## chatterbench gate `gate.toml`: PASS")  # appended, in order
    assert log.rstrip().endswith("PASS: 1 of 1 checks passed")


def markdown_rows(shared: Path | None = None) -> list[str]:
    """The rows of ``docs/bad-inputs.md``'s section "Round five" (as ``test_hostile_cases.markdown_rows``)."""
    rows = []
    for case in ROUND_FIVE:
        got, said = run_case(case, shared)
        shown = "chatterbench " + " ".join(a if a and " " not in a and "\n" not in a else repr(a) for a in case.argv)
        cell = textwrap.shorten(message(case, got, said), 600, placeholder=" ...")
        for form in (repr(INJECTED)[1:-1], log_text(INJECTED)):  # the doc names the injected text once, above
            shown, cell = shown.replace(form, "INJ"), cell.replace(form, "INJ")
        rows.append(f"| `{case.id}` | {_cell(case.what)} | `{shown.replace('|', chr(92) + '|')}` | {_cell(cell)} "
                    f"({got.code}) |")
    return rows


def _cell(text: str) -> str:
    """A table cell of text from a case: its bars and angle brackets shown, never read as Markdown or HTML (the line
    breaks ``message`` puts between its lines kept)."""
    return "<br>".join(t.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;") for t in text.split("<br>"))
