"""Atomic output: a writer killed at any moment leaves the old file or the new one, never a torn one."""

from __future__ import annotations

import os
import signal
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
