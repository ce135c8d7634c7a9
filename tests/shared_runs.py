"""Runs that tests of several modules (and several pytest-xdist workers) read, made once per test session.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from shared_runs import made_once
    >>> folder = Path(tempfile.mkdtemp())
    >>> made_once(folder, "answer", lambda: [42, "said"]), made_once(folder, "answer", lambda: [0, "not run"])
    ([42, 'said'], [42, 'said'])

A test and ``docs/bad-inputs.md`` (``tests/test_bad_inputs.py``) read the same runs: in one
process each module caches its own; under pytest-xdist the workers share a folder of this test
session (``session_folder``), where the first worker that needs a run makes it, holding a lock,
and leaves it as JSON (``made_once``); a worker that needs it later, or meanwhile, reads it there.
"""

from __future__ import annotations

import fcntl
import json
import os
from pathlib import Path
from typing import Any, Callable


def session_folder(tmp_path_factory) -> Path | None:
    """A folder every pytest-xdist worker of this test session shares (None in a single process, whose own caches
    already share its runs): where one worker leaves runs that another would otherwise make again."""
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")
    if not run or not os.environ.get("PYTEST_XDIST_WORKER"):
        return None
    folder = tmp_path_factory.getbasetemp().parent / f"chatterbench-shared-{run}"
    folder.mkdir(exist_ok=True)
    return folder


def made_once(folder: Path | None, name: str, make: Callable[[], Any]) -> Any:
    """``make()`` (a value JSON holds), made once in this test session: by the first caller, which leaves it in
    ``folder`` as ``NAME.json`` (holding ``NAME.lock`` meanwhile); read there by every later one. ``folder`` None:
    ``make()`` itself (the caller caches it)."""
    if folder is None:
        return make()
    with open(folder / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, or when its process dies
        path = folder / f"{name}.json"
        if not path.exists():
            (folder / f"{name}.tmp").write_text(json.dumps(make()))
            os.replace(folder / f"{name}.tmp", path)
        return json.loads(path.read_text())


_MADE: dict[str, Any] = {}  # what ``folder_made_once`` made in this process, when no worker shares a folder with it


def folder_made_once(tmp_path_factory, name: str, make: Callable[[Path], Any]) -> tuple[Path, Any]:
    """``make(out)``, which writes the folder ``out`` and returns a value JSON holds, made once in this test session:
    every caller (every pytest-xdist worker: ``session_folder``, ``made_once``) gets the same ``out`` and what the
    first call returned. Tests read ``out``; one that writes copies it first."""
    shared = session_folder(tmp_path_factory)
    out = (shared if shared is not None else tmp_path_factory.getbasetemp()) / name
    if shared is not None:
        return out, made_once(shared, name, lambda: make(out))
    if name not in _MADE:
        _MADE[name] = make(out)
    return out, _MADE[name]


# PyBullet's default tune of the ball, as a user types it: tune's default search (tolerances, budget), which is the
# kept atlas's search too (comparisons/atlas_data/atlas.json); about 70 CPU s, so two test modules share one
PYBULLET_BALL_TUNE = ["tune", "bouncing-ball", "--engines", "pybullet", "--workers", "2"]


def pybullet_ball_tune(tmp_path_factory) -> tuple[Path, dict]:
    """``chatterbench tune bouncing-ball --engines pybullet --workers 2 --out DIR`` run once this session: (DIR,
    {"code": its exit code, "err": the end of its stderr})."""
    from helpers import cli

    def make(out: Path) -> dict:
        done = cli([*PYBULLET_BALL_TUNE, "--out", str(out)])
        return {"code": done.code, "err": done.err[-2000:]}

    return folder_made_once(tmp_path_factory, "pybullet-ball-tune", make)
