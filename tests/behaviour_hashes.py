"""The judge's, tune's and report's outputs hashed, the measured times left out: equal hashes, equal behaviour.

Run before and after a change that must not change what the suite answers (a refactoring)::

    python3 tests/behaviour_hashes.py [OUT_DIR]

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


def csv_without_clocks(path: Path) -> str:
    """A CSV file's rows without its clocked columns."""
    rows = list(csv.reader(io.StringIO(path.read_text())))
    keep = [i for i, name in enumerate(rows[0]) if name not in CLOCKED_COLUMNS]
    return "\n".join(",".join(row[i] for i in keep) for row in rows)


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


def chatterbench(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", *args], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def main(out: Path) -> dict[str, str]:
    hashes: dict[str, str] = {}
    for scene in SCENES:
        d = out / "compare" / scene
        chatterbench("compare", scene, "--engines", "mujoco,pybullet", "--out", str(d))
        for name in ("episodes.csv", "impacts_mujoco.csv", "impacts_pybullet.csv", "reference_episodes.csv"):
            hashes[f"compare {scene} {name}"] = digest(csv_without_clocks(d / name))
    d = out / "tune"
    chatterbench("tune", "bouncing-ball", "--engines", "pybullet", "--max-runs", "40", "--workers", "1",
                 "--repeats", "1", "--out", str(d))
    hashes["tune candidates.csv"] = digest(csv_without_clocks(d / "candidates.csv"))
    hashes["tune recommended.json"] = digest(json_without_clocks(d / "recommended.json"))
    d = out / "report"
    chatterbench("report", "--engines", "mujoco,pybullet,dart", "--atlas", "none", "--out", str(d))
    hashes["report report.md"] = digest(markdown_without_clocks(d / "report.md"))
    return hashes


if __name__ == "__main__":
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="chatterbench-hashes-"))
    for key, value in main(folder).items():
        print(f"{value}  {key}")
