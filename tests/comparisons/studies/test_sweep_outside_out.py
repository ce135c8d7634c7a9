"""Issue 25, part 1: a sweep writes, locks and deletes only inside ``--out``, and resumes past a damaged spec.

Each test failed before the fix: a symlinked ``OUT/rows`` received the part files (and the
stale-temp cleanup deleted a user's ``.precious.abcdefgh.tmp`` there), a symlinked ``OUT/.lock``
had its target truncated and overwritten, and a garbled ``OUT/sweep.toml`` stranded every
finished row ("choose another --out"). Real engines, one PyBullet run of 0.2 s.
"""

from __future__ import annotations

import hashlib
import os
import stat
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from helpers import cli, wait_until

from chatterbench.comparisons.studies.sweep.directory import LOCK_NAME

SPEC = 'scene = "bouncing-ball"\nengines = ["pybullet"]\n[set]\nduration = 0.2\n[grid]\ndt = [1e-3, 2e-3]\n'


def _listing(*folders: Path) -> dict[str, tuple[int, str]]:
    """Every entry under ``folders`` (links not followed): path -> (file type, sha256 of a regular file's bytes)."""
    out = {}
    for folder in folders:
        for p in [folder, *folder.rglob("*")]:
            mode = p.lstat().st_mode
            digest = hashlib.sha256(p.read_bytes()).hexdigest() if stat.S_ISREG(mode) else ""
            out[str(p)] = (stat.S_IFMT(mode), digest)
    return out


def _sweep(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    """``chatterbench sweep ARGS`` run in ``cwd``, in this process (what these tests check is what the command writes,
    refuses and prints, not how a process starts: the Ctrl-C and terminal tests below start their own), as a finished
    process: its exit code, stdout and stderr."""
    old = os.getcwd()
    os.chdir(cwd)
    try:
        done = cli(["sweep", *args])
    finally:
        os.chdir(old)
    return subprocess.CompletedProcess(["chatterbench", "sweep", *args], done.code, done.out, done.err)


def _refused(proc: subprocess.CompletedProcess, *words: str) -> str:
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("chatterbench: error: "), proc.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    return lines[0]


@pytest.fixture
def place(tmp_path) -> Path:
    (tmp_path / "s.toml").write_text(SPEC)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / ".precious.abcdefgh.tmp").write_text("the user's\n")
    (tmp_path / "victim").write_text("the user's file\n")
    (tmp_path / "o").mkdir()
    return tmp_path


@pytest.mark.parametrize("link", ["rows", "rows/set-aside", LOCK_NAME])
def test_a_symlink_under_out_is_refused_and_its_target_untouched(place, link):
    target = place / ("victim" if link == LOCK_NAME else "other")
    (place / "o" / link).parent.mkdir(parents=True, exist_ok=True)
    (place / "o" / link).symlink_to(target)
    before = _listing(place / "other", place / "victim")
    proc = _sweep(place, "s.toml", "--out", "o", "--workers", "1")
    # before: exit 0, the parts written in other/ (rows), the victim overwritten with the lock's JSON (.lock)
    _refused(proc, f"o/{link}", "symbolic link")
    assert _listing(place / "other", place / "victim") == before
    assert not (place / "o" / "sweep.toml").exists(), "refused before anything is written"


def test_a_lock_that_is_a_named_pipe_is_refused(place):
    os.mkfifo(place / "o" / LOCK_NAME)
    _refused(_sweep(place, "s.toml", "--out", "o", "--workers", "1"), f"o/{LOCK_NAME}", "not a regular file")


def test_cleanup_removes_only_the_temp_files_of_a_sweep_of_this_directory(place):
    assert _sweep(place, "s.toml", "--out", "o", "--workers", "1").returncode == 0
    out = place / "o"
    # a kill leaves temps named with the killed holder's tag, which its .lock names
    tag = __import__("json").loads((out / LOCK_NAME).read_text())["temps"]
    torn = [out / f".rows.parquet.{tag}k3j4h5g6.tmp", out / "rows" / f".part-x.parquet.{tag}a1b2c3d4.tmp"]
    kept = [out / ".precious.abcdefgh.tmp", out / "rows" / ".mine.qwertyuiqwertyui.tmp", out / "notes.tmp"]
    for p in torn + kept:
        p.write_text("torn")
    proc = _sweep(place, "s.toml", "--out", "o", "--workers", "1", "--resume")
    assert proc.returncode == 0, proc.stderr
    assert not any(p.exists() for p in torn)
    assert all(p.exists() for p in kept), "before: .precious.abcdefgh.tmp was deleted"


LONG = 'scene = "bouncing-ball"\nengines = ["pybullet"]\n[set]\nduration = 30\n[grid]\ndt = [1e-4, 2e-4, 3e-4, 4e-4]\n'


class _Stderr(threading.Thread):
    """A process's stderr read as it comes (``-X importtime`` writes more than a pipe holds): its lines, and an event
    set once the process is inside the command's own imports (its package imported, a module after it finished, the
    command's modules still to come)."""

    def __init__(self, proc: subprocess.Popen) -> None:
        super().__init__(daemon=True)
        self.proc, self.lines, self.importing = proc, [], threading.Event()

    def run(self) -> None:
        seen_package = False
        for line in self.proc.stderr:
            self.lines.append(line)
            if seen_package and line.startswith("import time:"):
                self.importing.set()
            seen_package |= line.rstrip().endswith("| chatterbench.comparisons.cli")

    def text(self) -> str:
        """What the process wrote, the import times left out."""
        return "".join(line for line in self.lines if not line.startswith("import time:"))


def _phase_reached(out: Path, phase: str) -> bool:
    """Whether the sweep writing into ``out`` is in ``phase``: starting (its lock taken, no row yet: the pool and its
    first runs starting) or running (a row written, the other runs going on)."""
    if phase == "starting":
        return (out / LOCK_NAME).exists()
    return any((out / "rows").glob("*.parquet")) if (out / "rows").is_dir() else False


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["importing", "starting", "running"])
def test_ctrl_c_of_a_sweep_is_one_line_exit_130_promptly(tmp_path, phase):
    (tmp_path / "long.toml").write_text(LONG)
    # a terminal's Ctrl-C reaches the whole process group: the sweep, its pool and their isolated runs; Python's
    # -X importtime says on stderr where the import is (its lines are left out of the stderr checked below)
    proc = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "chatterbench.comparisons.cli", "sweep",
                             "long.toml", "--out", "o", "--workers", "2"], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    stderr = _Stderr(proc)
    stderr.start()
    if phase == "importing":
        assert stderr.importing.wait(300), "the command finished its imports unseen"
    else:
        wait_until(lambda: _phase_reached(tmp_path / "o", phase), f"the sweep never reached {phase}", limit=300)
    rows = tmp_path / "o" / "rows"
    finished = sorted(rows.glob("*.parquet")) if rows.is_dir() else []  # each run of 30 s of the ball takes seconds
    os.killpg(proc.pid, __import__("signal").SIGINT)
    proc.wait(timeout=300)
    stderr.join(timeout=60)
    err = stderr.text()
    # before: -2 and a traceback when interrupted while importing; the pool's runs finished first (1-4 s to stop)
    assert proc.returncode == 130, err
    assert err == "chatterbench: interrupted\n", err
    # stopped at once: no run in progress at the interrupt was carried on to its row, and no process is left
    assert (sorted(rows.glob("*.parquet")) if rows.is_dir() else []) == finished
    wait_until(lambda: not _group_alive(proc.pid), "a process of the interrupted sweep is still alive")
    # and no half-written file is left (a temp is renamed into place whole, or removed)
    assert not list((tmp_path / "o").rglob("*.tmp")) if (tmp_path / "o").exists() else True


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def test_an_emoji_scene_name_prints_on_an_ascii_terminal(tmp_path):
    (tmp_path / "s.toml").write_text('name = "ball \N{TENNIS RACQUET AND BALL}"\nmass1 = "inf"\nmass2 = 1.0\n'
                                     'restitution = 0.5\nduration = 0.3\n[gap]\nlower = 0.0\n[initial]\ny = 0.1\n',
                                     encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", "run", "s.toml"], cwd=tmp_path,
                          capture_output=True, timeout=120, env={**os.environ, "PYTHONIOENCODING": "ascii"})
    # before: UnicodeEncodeError: 'ascii' codec can't encode character '\U0001f3be'
    assert proc.returncode == 0, proc.stderr.decode()
    assert b"ball \\U0001f3be: reference" in proc.stdout, proc.stdout


@pytest.mark.parametrize("damage, spelling", [("garbled", "--spec"), ("removed rows table", "positional")])
def test_a_damaged_sweep_toml_resumes_from_the_rows_of_its_spec(place, damage, spelling):
    assert _sweep(place, "s.toml", "--out", "o", "--workers", "1").returncode == 0
    parts = sorted((place / "o" / "rows").glob("part-*.parquet"))
    spec = place / "o" / "sweep.toml"
    spec.write_bytes(b"\x00garbled{[" if damage == "garbled" else spec.read_bytes().replace(b"[grid]", b"[gird]"))
    # before: "the sweep written there cannot be read back (...); choose another --out", every row stranded
    spec_args = ["--spec", "s.toml"] if spelling == "--spec" else ["s.toml"]
    proc = _sweep(place, *spec_args, "--out", "o", "--workers", "1", "--resume")
    assert proc.returncode == 0, proc.stderr
    assert "ran " not in proc.stdout, "no finished run is run again"
    assert "wrote o/rows.parquet (2 rows)" in proc.stdout, proc.stdout
    assert sorted((place / "o" / "rows").glob("part-*.parquet")) == parts
    assert "cannot be read back" in proc.stderr and "rows of s.toml" in proc.stderr, proc.stderr
    assert "[grid]" in spec.read_text(), "rewritten from the spec given"


def test_a_damaged_sweep_toml_and_another_spec_is_refused(place):
    assert _sweep(place, "s.toml", "--out", "o", "--workers", "1").returncode == 0
    (place / "o" / "sweep.toml").write_text("garbled = [")
    (place / "t.toml").write_text(SPEC.replace("2e-3", "3e-3"))
    before = _listing(place / "o")
    line = _refused(_sweep(place, "t.toml", "--out", "o", "--workers", "1", "--resume"), "o/sweep.toml", "cannot be read back",
                    "no rows under o/rows were written by t.toml")
    lock = str(place / "o" / LOCK_NAME)  # names its last holder: the refused sweep held it while checking
    assert {k: v for k, v in _listing(place / "o").items() if k != lock} == {k: v for k, v in before.items() if k != lock}, line


def test_two_different_specs_are_refused_naming_both(place):
    (place / "t.toml").write_text(SPEC)
    _refused(_sweep(place, "s.toml", "--spec", "t.toml", "--out", "o"), "s.toml", "--spec", "t.toml")
    assert not any((place / "o").iterdir()), "nothing written"
