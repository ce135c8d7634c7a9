"""Engine runs that several test modules make alike, made once per test session.

    traj = engine_run(tmp_path_factory, "pybullet", scene, 1e-4)   # in a test (tmp_path_factory: pytest's fixture)

Each is ``registry.run_engine(engine, scene, make_settings(engine, dt))``, the run a test would make itself. The
verdict invariance test (``comparisons/pipeline/test_judge.py``), the compact-form tests (``engines/test_window.py``)
and Feigin's pair compared (``comparisons/pipeline/test_compare.py``) run the same engines on the same scenes (the
built-in ones at 1e-4 s, PyBullet with a wrong R): each is kept in the session's temporary folder (pytest keeps
the last three sessions'; about 150 MB when all of these modules run), under pytest-xdist a folder every worker of the
session shares, where the first worker that needs a run makes it (holding that run's lock) and leaves it; a worker
that needs it later, or meanwhile, reads it there (bit for bit: a pickle); the last few are kept in memory too. A
shared run's arrays are read-only: a test that changed one in place would change it for every test after it; it
raises instead. ``share_compares_runs`` hands them to ``compare`` in one test: this repo's default gate, the README's
report and the ``chatter_gate`` fixture judge the same runs (the built-in engines at their defaults, 1e-4 s).
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import pickle
from pathlib import Path

from chatterbench.engines.registry import make_settings, run_engine
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene

from shared_runs import session_folder


def _session_folder(tmp_path_factory) -> Path:
    """The folder the pytest-xdist workers of this session share (``shared_runs.session_folder``; in a single
    process, one of its own)."""
    folder = (session_folder(tmp_path_factory) or tmp_path_factory.getbasetemp()) / "chatterbench-runs"
    folder.mkdir(exist_ok=True)
    return folder


def _read_only(traj: Trajectory) -> Trajectory:
    for values in (traj.t, traj.x1, traj.x2, traj.v1, traj.v2, traj.index, *traj.contact.values(),
                   *traj.normal_force.values()):
        if values is not None:
            values.flags.writeable = False
    return traj


@functools.lru_cache(maxsize=4)
def _made(engine: str, scene: Scene, dt: float, folder: Path) -> Trajectory:
    key = hashlib.sha256(repr((engine, scene, dt)).encode()).hexdigest()[:32]
    path = folder / f"{key}.pickle"
    with open(folder / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, or when its process dies
        if not path.exists():
            traj = run_engine(engine, scene, make_settings(engine, dt))
            (folder / f"{key}.tmp").write_bytes(pickle.dumps(traj, protocol=pickle.HIGHEST_PROTOCOL))
            os.replace(folder / f"{key}.tmp", path)
            return _read_only(traj)
    return _read_only(pickle.loads(path.read_bytes()))


def engine_run(tmp_path_factory, engine: str, scene: Scene, dt: float) -> Trajectory:
    """``engine``'s run of ``scene`` at its default settings with timestep ``dt`` [s], made once per session (module
    docstring); ``tmp_path_factory``: the test's pytest fixture (it finds the workers' shared folder)."""
    return _made(engine, scene, dt, _session_folder(tmp_path_factory))


def share_compares_runs(monkeypatch, tmp_path_factory) -> None:
    """For one test (``monkeypatch``, ``tmp_path_factory``: its pytest fixtures): ``compare``, and what runs through
    it (a gate, a report, the ``chatter_gate`` fixture), takes a built-in engine's run at its default settings (any
    dt) from this session's shared runs (``engine_run``) instead of making it again; every other run it makes as
    before. The shared run is the run ``compare`` would make, bit for bit, an isolated one (forked, under a time
    limit) included (tests/engines/test_determinism.py): what changes is that the test does not wait for it twice.
    Not for a test that plans a fault (``faults.py``): the shared run never saw it."""
    from chatterbench.comparisons.pipeline import compare as module
    from chatterbench.engines.registry import is_plugin

    real, real_isolated = module.run_engine, module.run_engine_isolated

    def default(name: str, settings) -> bool:
        return not is_plugin(name) and settings == make_settings(name, settings.dt)

    def run(name: str, scene: Scene, settings) -> Trajectory:
        if default(name, settings):
            return engine_run(tmp_path_factory, name, scene, settings.dt)
        return real(name, scene, settings)

    def run_isolated(name: str, scene: Scene, settings, timeout: float) -> Trajectory:
        if default(name, settings):
            return engine_run(tmp_path_factory, name, scene, settings.dt)
        return real_isolated(name, scene, settings, timeout)

    monkeypatch.setattr(module, "run_engine", run)
    monkeypatch.setattr(module, "run_engine_isolated", run_isolated)
