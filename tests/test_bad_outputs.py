"""The bad-output table: every output option given a place it cannot write, and the message it gets.

Each case is (id, what is wrong, argv, file content or None, words the message must contain),
the shape of ``tests/test_bad_inputs.py``'s table. The test runs ``chatterbench`` in-process in
a scratch directory (``scratch``: ``afile`` a file, ``adir/`` a directory, ``apipe`` a named
pipe, ``alink`` a link to nothing, ``rodir/`` mode 555, ``rofile`` mode 444, and the case's
``bad.toml`` or ``bad.csv``) and asserts exit code 2, one stderr line naming the option, no
traceback, nothing on stdout and nothing created or changed: every destination is checked
before any work (``report`` runs no simulation first).

Below the table, writes that fail for real after the checks, on a 64 KiB tmpfs filled to the
last byte (ENOSPC): one line ``--OPTION PATH: cannot write FILE: No space left on device``,
no temp file, no partial file. A read-only mount (EROFS) is refused up front. Both need root
and mount rights and are skipped without them; the chmod cases are skipped as root (root
writes through a mode 555 directory).
"""

from __future__ import annotations

import os
import stat
import subprocess
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.pipeline.atomic import write_text

from helpers import cli

FILE, CSV = "bad.toml", "bad.csv"  # argv placeholders for a case's file (gate file, sweep spec; dataset)
AFILE, ADIR, APIPE, ALINK, RODIR, ROFILE = "afile", "adir", "apipe", "alink", "rodir", "rofile"
GATE = '[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nscene_overrides = { duration = 0.2 }\nlimits = ["status == ok"]\n'
SPEC = 'scene = "bouncing-ball"\n[grid]\ndt = [1e-3]\n'
ROWS = ("engine,dt,verdict,cost_per_sim_s,restitution,exit_error_max,stick_error_max\n"
        "mujoco,0.0001,match,0.02,0.5,1e-3,2e-3\npybullet,0.0001,late,0.2,0.5,1e-2,3e-3\n")
RUN = ["run", "bouncing-ball", "--set", "duration=0.2"]
LONG = "x" * 300  # past every filesystem's 255-byte name limit

# (id, what is wrong, argv, file content or None, words the message must contain)
CASES: list[tuple[str, str, list[str], str | None, tuple[str, ...]]] = [
    # a directory option (--out) that cannot be a directory
    ("run --out afile", "--out names a file", [*RUN, "--out", AFILE], None, ("--out afile: exists and is not a directory",)),
    ("compare --out afile", "--out names a file", ["compare", "bouncing-ball", "--engines", "pybullet", "--out", AFILE],
     None, ("--out afile: exists and is not a directory",)),
    ("platemap --out afile", "--out names a file", ["platemap", "feigin-pair", "--out", AFILE], None,
     ("--out afile: exists and is not a directory",)),
    ("report --out afile", "--out names a file: refused before any simulation", ["report", "--out", AFILE], None,
     ("--out afile: exists and is not a directory",)),
    ("tune --out afile", "--out names a file", ["tune", "bouncing-ball", "--engine", "pybullet", "--out", AFILE], None,
     ("--out afile: exists and is not a directory",)),
    ("chart --out afile", "--out names a file", ["chart", CSV, "--kind", "work-precision", "--out", AFILE], ROWS,
     ("--out afile: exists and is not a directory",)),
    ("sweep --out afile", "--out names a file", ["sweep", FILE, "--out", AFILE], SPEC, ("--out afile: exists and is not a directory",)),
    ("--out afile/sub", "--out under a file", [*RUN, "--out", AFILE + "/sub"], None,
     ("--out afile/sub: afile is not a directory",)),
    ("--out apipe", "--out names a named pipe", [*RUN, "--out", APIPE], None, ("--out apipe: exists and is not a directory",)),
    ("--out alink", "--out names a link to nothing", ["compare", "bouncing-ball", "--out", ALINK], None,
     ("--out alink: alink is a broken link (-> nowhere)",)),
    ("--out alink/sub", "--out under a link to nothing", ["platemap", "feigin-pair", "--out", ALINK + "/sub"], None,
     ("--out alink/sub: alink is a broken link",)),
    ("--out LONG", "--out longer than a file name may be", [*RUN, "--out", LONG], None, ("--out xxx", "File name too long")),
    ("--out rodir/sub", "--out in a directory this user may not write", [*RUN, "--out", RODIR + "/sub"], None,
     ("--out rodir/sub: cannot write in rodir (permission denied)",)),
    # a file option that names a directory, a pipe, or a place no file can be written
    ("--events adir", "--events names a directory", [*RUN, "--events", ADIR], None,
     ("--events adir: is a directory; give a file path",)),
    ("--export-model adir", "--export-model names a directory", [*RUN, "--engines", "mujoco", "--export-model", ADIR],
     None, ("--export-model adir: is a directory",)),
    ("--junit adir", "--junit names a directory", ["gate", FILE, "--junit", ADIR], GATE, ("--junit adir: is a directory",)),
    ("--summary adir", "--summary names a directory", ["gate", FILE, "--summary", ADIR], GATE, ("--summary adir: is a directory",)),
    ("--json adir", "--json names a directory", ["gate", FILE, "--json", ADIR], GATE, ("--json adir: is a directory",)),
    ("--save-baseline adir", "--save-baseline names a directory", ["gate", FILE, "--save-baseline", ADIR], GATE,
     ("--save-baseline adir: is a directory",)),
    ("--events afile/log.csv", "--events under a file", [*RUN, "--events", AFILE + "/log.csv"], None,
     ("--events afile/log.csv: afile is not a directory",)),
    ("--events apipe", "--events names a named pipe (an atomic write would replace it)", [*RUN, "--events", APIPE], None,
     ("--events apipe: is not a regular file",)),
    ("--junit alink/g.xml", "--junit under a link to nothing", ["gate", FILE, "--junit", ALINK + "/g.xml"], GATE,
     ("--junit alink/g.xml: alink is a broken link",)),
    ("--events LONG", "--events name too long for its temporary file", [*RUN, "--events", "y" * 250], None,
     ("--events yyy", "file name too long", "temporary")),
    ("--events rofile", "--events names a read-only file", [*RUN, "--events", ROFILE], None,
     ("--events rofile: cannot be overwritten (permission denied)",)),
    ("--junit rodir/g.xml", "--junit in a directory this user may not write", ["gate", FILE, "--junit", RODIR + "/g.xml"],
     GATE, ("--junit rodir/g.xml: cannot write in rodir (permission denied)",)),
    # issue 25: nothing written or removed outside --out through a link under it
    ("sweep rows->elsewhere", "a sweep --out whose rows/ links to another directory (before: parts written there, "
     "its .precious.abcdefgh.tmp deleted)", ["sweep", FILE, "--out", "linkedrows"], SPEC,
     ("--out linkedrows: linkedrows/rows is a symbolic link (-> ../elsewhere)",)),
    ("sweep .lock->victim", "a sweep --out whose .lock links to a file (before: the file overwritten with the lock's JSON)",
     ["sweep", FILE, "--out", "linkedlock"], SPEC, ("linkedlock/.lock is a symbolic link (-> ../victim)",)),
]
PERMISSION = {"--out rodir/sub", "--events rofile", "--junit rodir/g.xml"}  # refused by permissions, which root passes


class Outcome(NamedTuple):
    """One in-process run: exit code, stdout, stderr, and the scratch entries it created, removed or changed."""
    code: int
    stdout: str
    stderr: str
    changed: set[tuple[str, int, int]]


@contextmanager
def scratch(content: str | None = None, name: str = FILE):
    """A scratch working directory holding the table's destinations and file ``name`` (when there is content)."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / AFILE).write_text("a file\n")
        (root / ADIR).mkdir()
        os.mkfifo(root / APIPE)
        (root / ALINK).symlink_to("nowhere")
        (root / RODIR).mkdir(mode=0o555)
        (root / ROFILE).write_text("read-only\n")
        (root / ROFILE).chmod(0o444)
        (root / "elsewhere").mkdir()  # a directory outside any --out, and a file, linked from two sweep --outs
        (root / "elsewhere" / ".precious.abcdefgh.tmp").write_text("the user's\n")
        (root / "victim").write_text("the user's\n")
        (root / "linkedrows").mkdir()
        (root / "linkedrows" / "rows").symlink_to("../elsewhere")
        (root / "linkedlock").mkdir()
        (root / "linkedlock" / ".lock").symlink_to("../victim")
        if content is not None:
            (root / name).write_text(content)
        os.chdir(root)
        try:
            yield root
        finally:
            os.chdir(old)
            (root / RODIR).chmod(0o755)  # so the scratch directory can be removed whatever a case left there


def _tree(root: Path) -> set[tuple[str, int]]:
    """Every entry under ``root`` (links not followed): (path, file type, size), so a pipe replaced by a file, or a
    file overwritten through a link, counts as a change."""
    return {(str(p.relative_to(root)), stat.S_IFMT(p.lstat().st_mode), p.lstat().st_size) for p in root.rglob("*")}


def run_cli(argv: list[str], content: str | None) -> Outcome:
    """Run the CLI in-process in a ``scratch`` directory."""
    with scratch(content, CSV if CSV in argv else FILE) as root:
        before = _tree(root)
        done = cli(argv)
        changed = _tree(root) ^ before
    return Outcome(done.code, done.out, done.err, changed)


def _root_writes_through_permissions() -> bool:
    with scratch() as root:
        return os.access(root / RODIR, os.W_OK)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_output_is_refused_before_any_work(case):
    case_id, _, argv, content, words = case
    if case_id in PERMISSION and _root_writes_through_permissions():
        pytest.skip("running as root: a mode 555 directory or 444 file does not stop root's writes")
    got = run_cli(argv, content)
    assert got.code == 2, got
    assert "Traceback" not in got.stderr, got.stderr
    assert got.stderr.count("\n") == 1 and got.stderr.startswith("chatterbench: error: "), got.stderr
    for word in words:
        assert word in got.stderr, (word, got.stderr)
    assert got.stdout == "", "refused after some work: it printed " + got.stdout  # report: no simulation ran
    assert not got.changed, f"refused, but created or changed {sorted(got.changed)}"


def test_case_ids_are_unique_and_permission_cases_exist():
    ids = [c[0] for c in CASES]
    assert len(ids) == len(set(ids))
    assert PERMISSION <= set(ids)


def test_a_nul_in_a_path_is_one_line(capsys):
    # not reachable from a shell (argv is C strings), but from main() in a notebook it is
    assert main([*RUN, "--out", "a\0b"]) == 2
    err = capsys.readouterr().err
    assert err == "chatterbench: error: --out 'a\\x00b': contains a NUL character\n"


# -- writes that fail for real after the checks ---------------------------------------------------
def _mount_tmpfs(where: Path, options: str) -> None:
    where.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here (needs root and mount rights): {proc.stderr.strip()}")


@pytest.fixture(scope="module")
def full_disk(tmp_path_factory):
    """A scratch directory whose ``full/`` is a 64 KiB tmpfs filled to the last byte; ``full/old.md`` holds "old"."""
    root = tmp_path_factory.mktemp("full-disk")
    (root / CSV).write_text(ROWS)
    (root / FILE).write_text(GATE)
    full = root / "full"
    _mount_tmpfs(full, "size=64k")
    try:
        (full / "old.md").write_text("old")
        fd = os.open(full / "filler", os.O_WRONLY | os.O_CREAT)
        try:
            while True:  # unbuffered: every byte the disk takes stays taken
                os.write(fd, b"\0" * 4096)
        except OSError as exc:
            assert exc.errno == 28, exc  # ENOSPC
        finally:
            os.close(fd)
        yield root
    finally:
        subprocess.run(["umount", str(full)], check=False)


def _full(case_id: str, argv: list[str], line: str):
    return pytest.param(argv, line, id=case_id)


# (id, argv, the start of the error line after "chatterbench: error: "): the disk is full before the first byte
FULL_CASES = [
    _full("run --out", [*RUN, "--out", "full/run"], "--out full/run: cannot write events.csv: No space left on device"),
    _full("run --events", [*RUN, "--events", "full/log.csv"], "--events full/log.csv: cannot write: No space left on device"),
    _full("run --export-model", [*RUN, "--engines", "mujoco", "--export-model", "full/ball.xml"],
          "--export-model full/ball.xml: cannot write: No space left on device"),
    _full("compare --out", ["compare", "bouncing-ball", "--engines", "pybullet", "--set", "duration=0.2", "--no-figures",
                            "--out", "full/cmp"], "--out full/cmp: cannot write "),
    _full("platemap --out", ["platemap", "feigin-pair", "--phases", "4", "--speeds", "4", "--out", "full/pm"],
          "--out full/pm: cannot write plate_map.csv: No space left on device"),
    _full("report --out", ["report", "bouncing-ball", "--engines", "pybullet", "--set", "duration=0.2", "--out", "full/rep"],
          "--out full/rep: cannot write "),
    _full("gate --junit", ["gate", FILE, "--junit", "full/g.xml"], "--junit full/g.xml: cannot write: No space left on device"),
    _full("gate --save-baseline", ["gate", FILE, "--save-baseline", "full/b.json"],
          "--save-baseline full/b.json: cannot write: No space left on device"),
    _full("chart --out", ["chart", CSV, "--kind", "work-precision", "--out", "full/ch"],
          "--out full/ch: cannot write work_precision.png: No space left on device"),
    _full("tune --out", ["tune", "bouncing-ball", "--engine", "pybullet", "--set", "duration=0.2", "--max-runs", "5",
                         "--repeats", "1", "--workers", "1", "--out", "full/tune"],  # a small search: the write is tested
          "--out full/tune: cannot write recommended.json: No space left on device"),
]


@pytest.mark.parametrize("argv,line", FULL_CASES)
def test_a_full_disk_is_one_line_naming_the_option(full_disk, monkeypatch, capsys, argv, line):
    monkeypatch.chdir(full_disk)
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert "Traceback" not in err, err
    errors = [ln for ln in err.splitlines() if ln.startswith("chatterbench: error: ")]
    assert errors == [err.splitlines()[-1]] and errors[0].startswith("chatterbench: error: " + line), err
    assert "No space left on device" in errors[0]
    files = sorted(str(p.relative_to(full_disk)) for p in (full_disk / "full").rglob("*") if not p.is_dir())
    assert files == ["full/filler", "full/old.md"], "a temp or partial file was left: " + ", ".join(files)


def test_a_failed_write_keeps_the_old_file(full_disk):
    target = full_disk / "full" / "old.md"
    with pytest.raises(OSError) as info:
        write_text(target, "new")
    assert info.value.errno == 28 and info.value.filename == str(target)
    assert target.read_text() == "old"
    assert sorted(p.name for p in target.parent.iterdir() if p.name.endswith(".tmp")) == []


def test_a_read_only_filesystem_is_refused_up_front(tmp_path, monkeypatch, capsys):
    _mount_tmpfs(tmp_path / "ro", "ro,size=64k")
    monkeypatch.chdir(tmp_path)
    try:
        for option, target in (("--out", "ro/run"), ("--events", "ro/log.csv")):
            assert main([*RUN, option, target]) == 2
            out, err = capsys.readouterr()
            assert out == "" and err == f"chatterbench: error: {option} {target}: cannot write in ro (a read-only filesystem)\n"
    finally:
        subprocess.run(["umount", str(tmp_path / "ro")], check=False)


# -- the temp file of an atomic write goes on every failure ---------------------------------------
def test_an_interrupted_write_leaves_no_temp_file(tmp_path):
    target = tmp_path / "report.md"
    write_text(target, "old")

    def interrupted(tmp: Path) -> None:
        tmp.write_text("half a rep")
        raise KeyboardInterrupt  # Ctrl-C mid-write: a BaseException, not an Exception

    from chatterbench.comparisons.pipeline.atomic import write_with

    with pytest.raises(KeyboardInterrupt):
        write_with(target, interrupted)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"] and target.read_text() == "old"


@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_a_written_file_has_the_usual_permissions(tmp_path, umask):
    old = os.umask(umask)
    try:
        mode = stat.S_IMODE(write_text(tmp_path / "r.md", "x").stat().st_mode)
    finally:
        os.umask(old)
    assert mode == 0o666 & ~umask  # as open() makes a new file
