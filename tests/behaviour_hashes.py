"""The judge's, tune's and report's outputs hashed, the measured times left out: equal hashes, equal behaviour.

Run before and after a change that must not change what the suite answers (a refactoring)::

    python3 tests/behaviour_hashes.py [OUT_DIR]          # run the commands into OUT_DIR, print the hashes
    python3 tests/behaviour_hashes.py --hash-only OUT_DIR  # the hashes of an earlier run's outputs

It runs the commands a user runs (``compare`` on the four built-in scenes with MuJoCo and PyBullet, ``tune`` of
PyBullet on bouncing-ball with a small budget, ``report`` with MuJoCo, PyBullet and DART) and prints one line per
output: its name and the first 16 hex digits of the sha256 of its content with what a clock measured taken out
(the cost columns ``cost_per_sim_s`` and ``cost_repeats``, wall times, dates). Hashes are bit-for-bit: compare them
on one machine, before and after (another CPU or BLAS may move a last bit).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

SCENES = ("bouncing-ball", "feigin-pair", "impact-damper", "spring-pair")
CLOCKED_COLUMNS = {"cost_per_sim_s", "cost_repeats", "wall_time", "wall_time_s"}
CLOCKED_KEYS = {"wall_time_s", "wall_time", "date", "elapsed_s", "machine", "command", "started", "finished"}


def digest(text: str) -> str:
    """The first 16 hex digits of the sha256 of ``text``."""
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def csv_without_clocks(path: Path, any_order: bool = False) -> str:
    """A CSV file's rows without its clocked columns; ``any_order``: the rows sorted (rows written as runs finish)."""
    rows = list(csv.reader(io.StringIO(path.read_text())))
    keep = [i for i, name in enumerate(rows[0]) if name not in CLOCKED_COLUMNS]
    lines = [",".join(row[i] for i in keep) for row in rows]
    return "\n".join(lines[:1] + (sorted(lines[1:]) if any_order else lines[1:]))


def json_without_clocks(path: Path) -> str:
    """A JSON file without its clocked keys, at any depth."""
    def strip(o):
        if isinstance(o, dict):
            return {k: strip(v) for k, v in o.items() if k not in CLOCKED_KEYS}
        if isinstance(o, list):
            return [strip(v) for v in o]
        return o
    return json.dumps(strip(json.loads(path.read_text())), sort_keys=True)


def markdown_without_clocks(path: Path) -> str:
    """A Markdown report without the lines of dates and wall times and without any table column named for a cost."""
    out, drop = [], []
    for line in path.read_text().splitlines():
        if re.match(r"- (date|wall time|command|machine)\b", line) or "took" in line:
            continue
        if line.startswith("|"):
            cells = line.strip("|").split("|")
            if any("cost" in c for c in cells):
                drop = [i for i, c in enumerate(cells) if "cost" in c]
            if len(cells) > max(drop, default=-1):
                cells = [c for i, c in enumerate(cells) if i not in drop]
            line = "|".join(cells)
        else:
            drop = [] if not line.strip() else drop
        out.append(line)
    return "\n".join(out)


def chatterbench(*args: str) -> int:
    """``chatterbench ARGS`` in a fresh process, its output left out; its exit code (1: a tune found nothing robust)."""
    return subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", *args],
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode


def run(out: Path) -> list[int]:
    """Run the commands into ``out``; their exit codes."""
    codes = []
    for scene in SCENES:
        codes.append(chatterbench("compare", scene, "--engines", "mujoco,pybullet", "--out", str(out / "compare" / scene)))
    codes.append(chatterbench("tune", "bouncing-ball", "--engines", "pybullet", "--max-runs", "40", "--workers", "1",
                              "--repeats", "1", "--out", str(out / "tune")))
    codes.append(chatterbench("report", "--engines", "mujoco,pybullet,dart", "--atlas", "none", "--out",
                              str(out / "report")))
    (out / "exit_codes.txt").write_text(" ".join(map(str, codes)))
    return codes


def hashes(out: Path) -> dict[str, str]:
    """The outputs under ``out`` (``run``'s) hashed."""
    found: dict[str, str] = {}
    for scene in SCENES:
        d = out / "compare" / scene
        for name in ("episodes.csv", "impacts_mujoco.csv", "impacts_pybullet.csv", "reference_episodes.csv"):
            found[f"compare {scene} {name}"] = digest(csv_without_clocks(d / name))
    # the candidates are written as they are judged, in an order the workers' timing decides: sorted
    found["tune candidates.csv"] = digest(csv_without_clocks(out / "tune" / "candidates.csv", any_order=True))
    found["tune recommended.json"] = digest(json_without_clocks(out / "tune" / "recommended.json"))
    found["report report.md"] = digest(markdown_without_clocks(out / "report" / "report.md"))
    found["exit codes"] = (out / "exit_codes.txt").read_text()
    return found


if __name__ == "__main__":
    again = sys.argv[1:2] == ["--hash-only"]  # hash the outputs of an earlier run again
    args = sys.argv[2:] if again else sys.argv[1:]
    folder = Path(args[0]) if args else Path(tempfile.mkdtemp(prefix="chatterbench-hashes-"))
    if not again:
        run(folder)
    for key, value in hashes(folder).items():
        print(f"{value}  {key}")
