"""Atomic output: a writer killed at any moment leaves the old file or the new one, never a torn one."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from chatterbench.comparisons.pipeline.atomic import write_frame, write_text

# a child that rewrites one Parquet file forever, alternating two contents of ~1.6 MB each
WRITER = """
import sys
import numpy as np, pandas as pd
from chatterbench.comparisons.pipeline.atomic import write_frame
path = sys.argv[1]
frames = [pd.DataFrame({"k": np.full(200_000, float(i)), "x": np.arange(200_000, dtype=float)}) for i in (1, 2)]
write_frame(path, frames[0])
print("ready", flush=True)
i = 1
while True:
    write_frame(path, frames[i % 2])
    i += 1
"""


@pytest.mark.parametrize("delay", np.linspace(0.0, 0.3, 6))
def test_killed_writer_leaves_an_old_or_a_new_file(tmp_path, delay):
    path = tmp_path / "rows.parquet"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(delay)
    os.kill(proc.pid, signal.SIGKILL)  # mid-write, mid-rename or between writes: wherever it lands
    proc.wait()
    frame = pd.read_parquet(path)  # a torn file would not parse
    assert len(frame) == 200_000
    assert frame["k"].nunique() == 1 and frame["k"].iloc[0] in (1.0, 2.0)
    assert (frame["x"].to_numpy() == np.arange(200_000)).all()


def test_failed_writer_keeps_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "report.md"
    write_text(path, "old")

    class Boom(Exception):
        pass

    def explode(_):
        raise Boom

    from chatterbench.comparisons.pipeline.atomic import write_with

    with pytest.raises(Boom):
        write_with(path, explode)
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]
    write_frame(tmp_path / "t.csv", pd.DataFrame({"a": [0.1]}))
    assert (tmp_path / "t.csv").read_text() == "a\n0.10000000000000001\n"


# -- inside an output folder: no link followed, no path out of it; a set of files moved in together -------------------
def test_a_link_planted_in_the_folder_is_never_written_through(tmp_path):
    from chatterbench.comparisons.pipeline.atomic import confined

    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir(), elsewhere.mkdir()
    (out / "pybullet").symlink_to(elsewhere)  # planted while the command ran (after its up-front check)
    (out / "report.md").symlink_to(elsewhere / "victim.md")
    with confined(out):
        # an OSError naming the link (write_with names the file asked for): the CLI's one line for --out
        with pytest.raises(OSError, match=r"out/pybullet is a symbolic link"):
            write_text(out / "pybullet" / "scene.py", "x")
        with pytest.raises(OSError, match=r"out/report.md is a symbolic link"):
            write_text(out / "report.md", "x")
        with pytest.raises(OSError, match="outside the output folder"):  # a label that became a path
            write_text(out / "/../../escaped.csv", "x")
        assert write_text(out / "new" / "deeper" / "ok.txt", "fine").read_text() == "fine"  # made one folder at a time
    assert list(elsewhere.iterdir()) == []
    assert write_text(out / "pybullet" / "scene.py", "x")  # outside `confined` a link is the caller's business


def test_a_staged_set_appears_whole_or_not_at_all(tmp_path):
    from chatterbench.comparisons.pipeline.atomic import staged

    out = tmp_path / "out"
    write_text(out / "guide.md", "old guide")
    write_text(out / "recommended.json", "old answer")
    with pytest.raises(KeyboardInterrupt):  # interrupted halfway: the folder keeps the old set, nothing staged is left
        with staged(out, last=["recommended.json"]) as stage:
            write_text(stage / "recommended.json", "new answer")
            write_text(stage / "guide.md", "new guide")
            raise KeyboardInterrupt
    assert sorted(p.name for p in out.iterdir()) == ["guide.md", "recommended.json"]
    assert (out / "recommended.json").read_text() == "old answer" and (out / "guide.md").read_text() == "old guide"
    with staged(out, last=["recommended.json"]) as stage:
        write_text(stage / "recommended.json", "new answer")
        write_text(stage / "guide.md", "new guide")
        write_text(stage / "pybullet" / "scene.py", "new scene")
    assert (out / "recommended.json").read_text() == "new answer" and (out / "pybullet" / "scene.py").read_text() == "new scene"
    assert sorted(p.name for p in out.iterdir()) == ["guide.md", "pybullet", "recommended.json"]  # no staging folder


def test_a_killed_tunes_staged_folder_is_removed_by_the_next_set_and_only_it(tmp_path):
    # before: a SIGKILL mid-set left OUT/.staged.* for ever; now the next staged set in OUT removes a folder whose
    # process is gone, and keeps one whose process runs (a concurrent writer) and any other name
    from chatterbench.comparisons.pipeline.atomic import staged

    out = tmp_path / "out"
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    runs = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    try:
        killed = out / f".staged.{int(gone.stdout)}.abcdefgh12345678"
        running = out / f".staged.{runs.pid}.abcdefgh12345678"
        other = out / ".staged.mine"
        for folder in (killed, running, other):
            write_text(folder / "guide.md", "half a set")
        with staged(out) as stage:
            write_text(stage / "guide.md", "a whole set")
        assert not killed.exists() and running.exists() and other.exists()
        assert (out / "guide.md").read_text() == "a whole set"
    finally:
        runs.kill()
        runs.wait()


# -- issue 45: nothing is renamed over what is not a regular file (stand-ins in tmp_path, never the machine's /dev) --
def _char_device(path):
    if os.geteuid() != 0:
        pytest.skip("making a character device needs root")
    os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 3))  # the null device's numbers: writing to it is harmless


@pytest.mark.parametrize("kind", ["fifo", "link to a file", "link to a fifo", "dangling link", "char device"])
def test_a_target_that_is_not_a_regular_file_is_left_as_it_was(tmp_path, kind):
    from chatterbench.comparisons.pipeline.atomic import write_text

    target = tmp_path / "target"
    if kind in ("fifo", "link to a fifo"):
        os.mkfifo(tmp_path / "pipe")
    if kind == "fifo":
        target = tmp_path / "pipe"
    elif kind == "link to a fifo":
        target.symlink_to("pipe")
    elif kind == "link to a file":
        (tmp_path / "file.txt").write_text("the user's\n")
        target.symlink_to("file.txt")
    elif kind == "dangling link":
        target.symlink_to("nowhere")
    else:
        _char_device(target)
    before = os.lstat(target)
    with pytest.raises(OSError, match="not a regular file: nothing is written over it"):  # atomic.NotRenamedOver
        write_text(target, "summary")
    after = os.lstat(target)
    assert (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)  # the same inode: not renamed over
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")) == []  # no temp file left
    if kind == "link to a file":
        assert (tmp_path / "file.txt").read_text() == "the user's\n"
