"""Writing that fails after the up-front checks: one line, exit 2, no temp file (a real full disk)."""

from __future__ import annotations

import os
import subprocess

import pytest

from chatterbench.comparisons.cli.main import main


@pytest.fixture
def full_disk(tmp_path):
    """A 64 KiB tmpfs: the comparison's first files fit, its figures do not."""
    mount = tmp_path / "tiny"
    mount.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)], capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here (needs root and mount rights): {proc.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def test_a_full_disk_is_one_line_and_leaves_no_temp_file(full_disk, capsys):
    out = full_disk / "cmp"
    code = main(["compare", "bouncing-ball", "--engines", "pybullet", "--set", "duration=0.5", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    errors = [line for line in err.splitlines() if line.startswith("chatterbench: error: ")]  # progress lines aside
    assert len(errors) == 1 and errors[0].startswith(f"chatterbench: error: --out {out}: cannot write "), err
    assert err.strip().splitlines()[-1] == errors[0]
    assert "No space left on device" in err and str(out) in err
    assert not [p for p in full_disk.rglob("*") if p.name.endswith(".tmp")]  # the torn write is gone
    # the comparison's files come together or not at all (issue 34: outputs complete or removed): the ones written
    # before the disk filled went with their hidden staging folder, so no set of half old, half new files is left
    assert sorted(p.name for p in out.iterdir()) == []


def test_a_full_disk_keeps_the_files_of_the_run_before(full_disk, capsys):
    out = full_disk / "cmp"
    out.mkdir()
    (out / "episodes.csv").write_text("the run before\n")
    code = main(["compare", "bouncing-ball", "--engines", "pybullet", "--set", "duration=0.5", "--out", str(out)])
    assert code == 2, capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["episodes.csv"]
    assert (out / "episodes.csv").read_text() == "the run before\n"
    assert os.path.getsize(out / "episodes.csv") > 0
