"""Hostile runs: gate outputs and baselines, interruptions, links planted in an output folder, a guide section to embed.

Each case is a command in a scratch directory prepared by its ``setup`` (a gate file
``gate.toml`` of one 0.2 s check, a named pipe ``apipe``, a folder ``elsewhere/`` outside
every output), the exit code it must end with, the words its output must hold, and what must
be on disk after (``after``: also the sentence ``docs/bad-inputs.md`` shows). Interrupted
cases run in a child process that gets a real SIGINT or SIGTERM while it writes its files
(the signal is sent by the command's own process, from the function named, so the moment is
the same on every machine). Issue 34: "gate outputs and baselines", "interruption", and the
security rows about tune's planted link and ``report --tune`` embedding its guide section
verbatim; each case says what happened before.

``docs/bad-inputs.md`` shows these rows too (``tests/test_bad_inputs.py`` generates it), all
but those that need root to mount a full disk.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, NamedTuple

import pytest

from helpers import cli
from shared_runs import made_once, session_folder

GATE = '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nscene_overrides = { duration = 0.2 }\nlimits = ["status == ok"]\n'
OTHER_GATE = GATE.replace("duration = 0.2", "duration = 0.3")  # the same check's name, another run
TUNE = ["tune", "bouncing-ball", "--engine", "pybullet", "--set", "duration=1.6", "--max-runs", "4", "--repeats", "1"]
REPORT = ["report", "bouncing-ball", "--engines", "pybullet", "--set", "duration=1.6", "--out", "r"]
HOSTILE_GUIDE = ('<h2 id="tuning-pybullet-bouncing-ball">Tuning pybullet for bouncing-ball</h2>\n'
                 "<p>the answer</p><script>document.title = 'ran'</script>\n"
                 '<img src="http://127.0.0.1:9/beacon.png" alt="beacon">\n<p>then <!-- a comment never closed')


class Outcome(NamedTuple):
    code: int  # the exit code; -N: killed by signal N
    output: str  # stdout and stderr
    root: Path  # the scratch directory, still there for ``after``


class Case(NamedTuple):
    id: str
    what: str  # what is wrong, and what happened before
    argv: list[str]
    code: int
    words: tuple[str, ...]  # in the output
    setup: Callable[[Path], dict[str, str]] | None = None  # prepares the scratch directory; returns the environment to add
    interrupt: tuple[str, int] | None = None  # ("module:function", signal): the signal is sent after that call
    after: Callable[[Outcome], str] | None = None  # checks the disk; returns what the doc says of it
    root_only: bool = False  # needs root (a full tmpfs): not in the doc


# -- setups ------------------------------------------------------------------------------------------------------
def _env(**env: str) -> Callable[[Path], dict[str, str]]:
    return lambda root: env


def _saved_baseline(gate_text: str, name: str = "base.json") -> Callable[[Path], dict[str, str]]:
    def setup(root: Path) -> dict[str, str]:
        (root / "saved.toml").write_text(gate_text)
        assert cli(["gate", "saved.toml", "--save-baseline", name]).code == 0
        return {}
    return setup


def _huge_baseline(root: Path) -> dict[str, str]:
    _saved_baseline(GATE)(root)
    data = json.loads((root / "base.json").read_text())
    data["checks"]["bouncing-ball/pybullet"]["stick_error_max"] = int("1" * 401)
    (root / "base.json").write_text(json.dumps(data))
    return {}


def _previous_tune(root: Path) -> dict[str, str]:
    """``d`` as a tune left it: its guide and the recommendation that goes with it."""
    (root / "d").mkdir()
    for name in ("guide.md", "guide.html", "guide_section.html", "candidates.csv"):
        (root / "d" / name).write_text(f"the previous tune's {name}\n")
    (root / "d" / "recommended.json").write_text('{"previous": true}\n')
    return {}


def _planted_link(root: Path) -> dict[str, str]:
    (root / "d").mkdir()
    (root / "d" / "pybullet").symlink_to("../elsewhere")
    return {}


def _guide(kind: str) -> Callable[[Path], dict[str, str]]:
    def setup(root: Path) -> dict[str, str]:
        folder = root / "t"
        folder.mkdir()
        target = folder / "guide_section.html"
        if kind == "hostile":
            target.write_text(HOSTILE_GUIDE)
        elif kind == "huge":
            with open(target, "wb") as f:
                f.truncate(1536 * 2**20)  # 1.5 GiB, sparse: costs no disk
        elif kind == "fifo":
            os.mkfifo(target)
        elif kind == "zero":
            target.symlink_to("/dev/zero")
        elif kind == "dir":
            target.mkdir()
        return {}
    return setup


def _dataset(kind: str) -> Callable[[Path], dict[str, str]]:
    def setup(root: Path) -> dict[str, str]:
        if kind == "fifo":
            os.mkfifo(root / "rows.csv")
        elif kind == "huge":
            with open(root / "rows.csv", "wb") as f:
                f.truncate(2 * 2**30)  # 2 GiB, sparse
        elif kind == "rows":  # a few hundred kB of Parquet standing for gigabytes of rows
            import pyarrow as pa
            import pyarrow.parquet as pq

            n = 3_000_000  # each column one value repeated, made by Arrow (pandas' list of 3e6 strings: 0.5 s more)
            pq.write_table(pa.table({"engine": pa.repeat("mujoco", n), "dt": pa.repeat(1e-4, n),
                                     "verdict": pa.repeat("match", n), "cost_per_sim_s": pa.repeat(0.1, n)}),
                           root / "rows.parquet")
        return {}
    return setup


def _trajectory_file(root: Path) -> dict[str, str]:
    """``t.csv``: the exact bouncing ball sampled at 1 ms, as another simulator would write it."""
    from chatterbench.comparisons import reference_trajectory, trajectory_table
    from chatterbench.reference.scene import load_scene

    trajectory_table(reference_trajectory(load_scene("bouncing-ball"), dt=1e-3)).to_csv(root / "t.csv", index=False)
    return {}


def _full_step_summary(root: Path) -> dict[str, str]:
    full = root / "full"
    full.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(full)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here (needs root and mount rights): {done.stderr.strip()}")
    (full / "step.md").write_text("an earlier step\n".ljust(4096, "."))  # a whole page: the next byte needs another
    fd = os.open(full / "filler", os.O_WRONLY | os.O_CREAT)
    try:
        while True:  # unbuffered: every byte the disk takes stays taken
            os.write(fd, b"\0" * 4096)
    except OSError:
        pass
    finally:
        os.close(fd)
    return {"GITHUB_STEP_SUMMARY": str(full / "step.md")}


# -- what must be on disk after -------------------------------------------------------------------------------------
def _nothing_new(folder: str) -> Callable[[Outcome], str]:
    def after(got: Outcome) -> str:
        path = got.root / folder
        left = sorted(p.name for p in path.iterdir()) if path.exists() else []
        assert left == [], left  # no file of the interrupted set, no staging folder
        return f"{folder}/: empty (nothing of the interrupted set, no staging folder)"
    return after


def _previous_kept(got: Outcome) -> str:
    names = sorted(p.name for p in (got.root / "d").iterdir())
    assert names == ["candidates.csv", "guide.html", "guide.md", "guide_section.html", "recommended.json"], names
    assert all((got.root / "d" / n).read_text().startswith(("the previous tune's", '{"previous"')) for n in names)
    return "d/: the previous tune's guide and recommended.json, unchanged (before: the new recommended.json beside them)"


def _elsewhere_untouched(got: Outcome) -> str:
    assert sorted(p.name for p in (got.root / "elsewhere").iterdir()) == ["victim.txt"]
    return "elsewhere/: untouched (before: scene.py written there through d/pybullet)"


def _label_refused(got: Outcome) -> str:
    assert sorted(p.name for p in (got.root / "elsewhere").iterdir()) == ["victim.txt"]
    assert not (got.root / "o").exists()
    return "elsewhere/: untouched; o/: not made"


def _gate_file_kept(got: Outcome) -> str:
    assert (got.root / "gate.toml").read_text() == GATE
    return "gate.toml: unchanged"


def _inert_report(got: Outcome) -> str:
    page = (got.root / "r" / "index.html").read_text()
    assert "<script" not in page.split("</head>", 1)[1] and "127.0.0.1" not in page and "<!--" not in page
    guide = page.index("Tuning pybullet for bouncing-ball")
    assert page.index("What produced this report") > guide  # the rest of the page is there, after the section
    return "r/index.html: the section's text kept; no script, no remote image, no comment; the page ends as it should"


def _summary_kept(got: Outcome) -> str:
    assert (got.root / "full" / "step.md").read_text().startswith("an earlier step\n")
    return "the earlier steps' summary kept"


HOOK = """
import os, signal, sys, importlib, functools
sys.argv[0] = "chatterbench"  # as the console script: Ctrl-C is the command's, exit 130
module, name = sys.argv[1].split(":")
target, sig = importlib.import_module(module), int(sys.argv[2])
real = getattr(target, name)

@functools.wraps(real)
def then_signal(*args, **kwargs):
    value = real(*args, **kwargs)
    os.kill(os.getpid(), sig)  # delivered at once, as a user's Ctrl-C or a CI job's kill would be
    return value

setattr(target, name, then_signal)
from chatterbench.comparisons.cli.main import main
sys.exit(main(sys.argv[3:]))
"""

# (id, what, argv, exit code, words, setup, interrupt, after)
CASES = [
    # gate outputs and baselines
    Case("gate --junit = --summary", "JUnit and the job summary named one file (before: accepted, one replaced the other)",
         ["gate", "gate.toml", "--junit", "out.xml", "--summary", "out.xml"], 2,
         ("--junit out.xml and --summary out.xml name one file",)),
    Case("gate --junit = GATES.toml", "JUnit named the gate file itself (before: the gate file replaced by XML)",
         ["gate", "gate.toml", "--junit", "gate.toml"], 2, ("--junit gate.toml is the GATES.toml file",),
         after=_gate_file_kept),
    Case("gate --json = --baseline", "the benchmark JSON named the baseline it reads (before: the baseline replaced)",
         ["gate", "gate.toml", "--json", "base.json", "--baseline", "base.json"], 2,
         ("--json base.json is the --baseline file",), setup=_saved_baseline(GATE)),
    Case("gate --summary = $GITHUB_STEP_SUMMARY", "--summary named GitHub's step summary file, which the gate appends to",
         ["gate", "gate.toml", "--summary", "step.md"], 2, ("--summary step.md is the $GITHUB_STEP_SUMMARY file",),
         setup=_env(GITHUB_STEP_SUMMARY="step.md")),
    Case("$GITHUB_STEP_SUMMARY fifo", "GitHub's step summary is a named pipe no one reads (before: the gate hung)",
         ["gate", "gate.toml"], 0, ("warning: $GITHUB_STEP_SUMMARY apipe: cannot be opened", "PASS: 1 of 1"),
         setup=_env(GITHUB_STEP_SUMMARY="apipe")),
    Case("$GITHUB_STEP_SUMMARY /dev/full", "GitHub's step summary is a device that is always full (before: exit 2, the "
         "verdict never printed)", ["gate", "gate.toml"], 0,
         ("warning: $GITHUB_STEP_SUMMARY /dev/full: not a regular file", "PASS: 1 of 1"),
         setup=_env(GITHUB_STEP_SUMMARY="/dev/full")),
    Case("$GITHUB_STEP_SUMMARY full disk", "GitHub's step summary on a full disk (before: exit 2 naming the file, no "
         "verdict)", ["gate", "gate.toml"], 0, ("No space left on device", "the verdict is in this log", "PASS: 1 of 1"),
         setup=_full_step_summary, after=_summary_kept, root_only=True),
    Case("gate --baseline of another gate", "a baseline saved from another gate file whose check of the same name ran "
         "another scene (before: compared without a word)", ["gate", "gate.toml", "--baseline", "base.json"], 1,
         ("was saved from gate file 'saved.toml', not 'gate.toml'", "measured another scene", "--save-baseline"),
         setup=_saved_baseline(OTHER_GATE)),
    Case("gate --baseline 401 digits", "a baseline metric that is a 401-digit integer (before: OverflowError traceback)",
         ["gate", "gate.toml", "--baseline", "base.json"], 2, ("(401 characters): too large for a metric",),
         setup=_huge_baseline),
    Case("gate --baseline fifo", "a baseline that is a named pipe", ["gate", "gate.toml", "--baseline", "apipe"], 2,
         ("--baseline apipe: not a regular file",)),
    # the other files a command reads: sweep datasets (chart, report --sweep)
    Case("chart fifo", "a dataset that is a named pipe (before: waited for a writer)",
         ["chart", "rows.csv", "--kind", "work-precision"], 2, ("rows.csv: not a regular file",), setup=_dataset("fifo")),
    Case("chart 2 GiB", "a 2 GiB dataset (before: read whole, 14.9 GiB peak)", ["chart", "rows.csv", "--kind",
         "work-precision"], 2, ("rows.csv: 2048 MiB of rows, more than the 256 MiB",), setup=_dataset("huge")),
    Case("report --sweep 3e6 rows", "a Parquet dataset of 150 kB and 3 million rows (before: read whole, 0.85 GB peak)",
         ["report", "bouncing-ball", "--sweep", "rows.parquet"], 2,
         ("rows.parquet: 3,000,000 rows, more than the 1,000,000",), setup=_dataset("rows")),
    # interruption (tune's: right after its guide.md is made, recommended.json already written and the page's figures
    # not yet rendered, which took 0.9 s more of each run after guide_html)
    Case("tune Ctrl-C while writing", "Ctrl-C while tune writes its guide (before: the files written so far stayed)",
         [*TUNE, "--out", "d"], 130, ("chatterbench: interrupted",),
         interrupt=("chatterbench.comparisons.outputs.guide:guide_markdown", signal.SIGINT), after=_nothing_new("d")),
    Case("second tune killed", "a second tune into the same --out killed by SIGTERM while it writes (before: its new "
         "recommended.json, written first, beside the previous tune's guide)", [*TUNE, "--out", "d"], 143,
         ("chatterbench: terminated",),
         setup=_previous_tune, interrupt=("chatterbench.comparisons.outputs.guide:guide_markdown", signal.SIGTERM),
         after=_previous_kept),
    Case("report Ctrl-C while writing", "Ctrl-C while report writes its pages (before: index.html without its report.md)",
         REPORT, 130, ("chatterbench: interrupted",),
         interrupt=("chatterbench.comparisons.outputs.report_page:report_markdown", signal.SIGINT),
         after=_nothing_new("r")),
    # security: a link planted in an output folder, a guide section to embed
    Case("judge --engine a path", "an engine label that is a path (before: elsewhere/x.csv written, outside --out)", ["judge", "bouncing-ball", "t.csv", "--engine", "/../../elsewhere/x", "--out", "o",
                            "--no-figures"], 2, ("--engine '/../../elsewhere/x'", "no '/'"), setup=_trajectory_file, after=_label_refused),
    Case("tune planted link", "tune --out d where d/pybullet is a link out of d (before: scene.py written through it)",
         [*TUNE, "--out", "d"], 2, ("--out d: d/pybullet is a symbolic link (-> ../elsewhere)",), setup=_planted_link,
         after=_elsewhere_untouched),
    Case("report --tune hostile", "a guide section with a <script>, a remote <img> and an unclosed <!-- (before: embedded "
         "verbatim: the script ran, the image loaded, the comment hid the rest of the page)",
         [*REPORT, "--tune", "t"], 0, ("left out of the report: 1 script, 1 image not embedded in the file, 1 comment",),
         setup=_guide("hostile"), after=_inert_report),
    Case("report --tune 1.5 GiB", "a 1.5 GiB guide section (before: read whole, 3.19 GiB peak)", [*REPORT, "--tune", "t"], 2,
         ("--tune t: guide_section.html: larger than 16 MiB",), setup=_guide("huge")),
    Case("report --tune fifo", "a guide section that is a named pipe (before: 'no guide_section.html there')",
         [*REPORT, "--tune", "t"], 2, ("guide_section.html: not a regular file",), setup=_guide("fifo")),
    Case("report --tune /dev/zero", "a guide section linked to /dev/zero (before: 'no guide_section.html there'; "
         "issue 45: a link in the folder is refused as a link)",
         [*REPORT, "--tune", "t"], 2, ("guide_section.html: a symbolic link (-> /dev/zero)",), setup=_guide("zero")),
    Case("report --tune dir", "a guide section that is a directory (before: 'no guide_section.html there')",
         [*REPORT, "--tune", "t"], 2,
         ("guide_section.html: cannot be read (is a directory)",), setup=_guide("dir")),
]


@contextmanager
def _scratch():
    old = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "gate.toml").write_text(GATE)
        os.mkfifo(root / "apipe")
        (root / "elsewhere").mkdir()
        (root / "elsewhere" / "victim.txt").write_text("the user's\n")
        os.chdir(root)
        try:
            yield root
        finally:
            os.chdir(old)
            subprocess.run(["umount", str(root / "full")], capture_output=True, check=False)


_DONE: dict[str, tuple[Outcome, str]] = {}  # case id -> its run, made once per process (the test and the doc read it)


def run_case(case: Case, shared: Path | None = None) -> tuple[Outcome, str]:
    """Run one case, once per test session (``test_hostile_case`` and ``docs/bad-inputs.md`` read the same run: in
    this process, or left in ``shared`` by another pytest-xdist worker, ``shared_runs.made_once``); returns its
    outcome and what ``after`` says of the disk ("" without one)."""
    if case.id not in _DONE:
        code, output, root, said = made_once(shared, f"hostile-{CASES.index(case)}", lambda: _run_case(case))
        _DONE[case.id] = Outcome(code, output, Path(root)), said
    return _DONE[case.id]


def _run_case(case: Case) -> tuple[int, str, str, str]:
    """``case`` run in a scratch directory: its exit code, output, the scratch directory (gone after) and what
    ``after`` said of the disk while it was there."""
    with _scratch() as root:
        env = case.setup(root) if case.setup else {}
        saved = {k: os.environ.get(k) for k in (*env, "GITHUB_ACTIONS", "GITHUB_STEP_SUMMARY")}
        os.environ.pop("GITHUB_ACTIONS", None)
        os.environ.pop("GITHUB_STEP_SUMMARY", None)
        os.environ.update(env)
        try:
            if case.interrupt:
                proc = subprocess.run([sys.executable, "-c", HOOK, case.interrupt[0], str(int(case.interrupt[1])),
                                       *case.argv], capture_output=True, text=True, timeout=600)
                got = Outcome(proc.returncode, proc.stdout + proc.stderr, root)
            else:
                done = cli(case.argv)
                got = Outcome(done.code, done.out + done.err, root)
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
        said = case.after(got) if case.after else ""
    return got.code, got.output, str(got.root), said


SLOW = {"report --tune hostile"}  # besides the interrupted ones: a run of several seconds before the check


@pytest.mark.parametrize("case", [pytest.param(c, marks=[pytest.mark.slow] if c.interrupt or c.id in SLOW else [])
                                  for c in CASES], ids=[c.id for c in CASES])
def test_hostile_case(case, tmp_path_factory):
    got, _ = run_case(case, session_folder(tmp_path_factory))
    assert_outcome(got, case)


def assert_outcome(got: Outcome, case) -> None:
    """A case's run says what it should: its exit code, no traceback, each of its words (round five's cases too)."""
    assert got.code == case.code, (got.code, got.output[-3000:])
    assert "Traceback" not in got.output, got.output
    for word in case.words:
        assert word in got.output, (word, got.output[-3000:])


def test_case_ids_are_unique():
    assert len({c.id for c in CASES}) == len(CASES)


def message(case: Case, got: Outcome, said: str) -> str:
    """The doc's cell: the command's own lines about it (error, warning, note, interrupted, the verdict), the exit, and
    what ``after`` found on disk."""
    lines = [ln for ln in got.output.splitlines()
             if ln.startswith(("chatterbench: error", "chatterbench: warning", "chatterbench: note", "chatterbench: interr",
                               "chatterbench: termin", "PASS:", "FAIL:"))]
    if not lines and got.code < 0:
        lines = [f"killed by {signal.Signals(-got.code).name}"]
    return "<br>".join([*lines, *([said] if said else [])])


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown_rows(shared: Path | None = None) -> list[str]:
    """The rows ``docs/bad-inputs.md`` shows (``tests/test_bad_inputs.py``), every case but the root-only ones (the
    runs of this test session: ``run_case``)."""
    rows = []
    for case in CASES:
        if case.root_only:
            continue
        got, said = run_case(case, shared)
        shown = "chatterbench " + " ".join(a if a and " " not in a else repr(a) for a in case.argv)
        if case.interrupt:
            shown += f" (a {signal.Signals(case.interrupt[1]).name} after {case.interrupt[0].split(':')[1]})"
        cell = textwrap.shorten(message(case, got, said), 600, placeholder=" ...")
        what = case.what
        rows.append(f"| `{case.id}` | {_cell(what)} | `{_cell(shown)}` | {_cell(cell)} ({got.code}) |")
    return rows
