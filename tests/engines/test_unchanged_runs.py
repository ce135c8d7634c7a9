"""Every engine's trajectories as recorded, within a stated tolerance, on any machine and any engine version.

What the recorded values are: for each engine, each case (the four built-in scenes and feigin-pair with a prescribed
body 1, at two dts; three runs longer than a chunk of the loops) gives the run's status, its sample count, and the gap
y and body 1's x1 at 16 samples spread evenly over the run, with the run's range of y, L (``recorded_runs.json``,
written by ``python3 tests/engines/test_unchanged_runs.py > tests/engines/recorded_runs.json``).

What must hold, and why these tolerances:
- the status and the sample count are the recorded ones exactly (a run that fails, or runs another length, changed);
- every checkpoint's y and x1 is within ``TOLERANCE`` x L of the recorded one. Rounding does not reach it: a run whose
  initial speed is moved by 1e-9 m/s, ten million times a last-bit change, moves no checkpoint by more than 1e-5 L (the
  largest, PyBullet's feigin-pair at dt 1e-3, 9.3e-6 L; measured over every engine and case). A change of the physics
  does: R x 1.01 moves the bouncing ball's checkpoints by 1e-3 L and more (``test_a_changed_restitution_is_seen``).
  So another CPU, BLAS or a patch release of an engine passes, and a changed force, contact law or loop fails;
- bit for bit only between two runs on this machine: the batch gives the single runs' bits, and a case run twice gives
  the same bits (``digest``).

No case skips because a version moved: the versions recorded are printed beside a failure, to say what to re-record.
"""

from __future__ import annotations

import hashlib
import json
import platform
import sys
from pathlib import Path

import numpy as np
import pytest

from chatterbench.engines.registry import available_engines, engine_version, make_settings, run_engine, run_engine_batch
from chatterbench.reference.scene import load_scene

SCENES = {  # key -> (scene, overrides): short runs that still chatter, stick and leave
    "bouncing-ball": ("bouncing-ball", []),
    "feigin-pair": ("feigin-pair", ["duration=4"]),
    "impact-damper": ("impact-damper", []),
    "spring-pair": ("spring-pair", ["duration=4"]),
    "prescribed": ("feigin-pair", ["mass1=inf", "prescribed.amplitude=0.05", "prescribed.omega=2.0", "initial.v1=0.1",
                                   "forces.0.on=coupling", "duration=4"]),
}
DTS = (1e-3, 3e-4)  # [s]
SHORT = {"mujoco_warp": 0.6}  # [s] durations of an engine slow per step (1.5 to 3 ms a step on warp's CPU device)
BATCHED = ("bouncing-ball", "spring-pair", "impact-damper")  # run_batch's jobs, at the first dt
# runs of more than one chunk (``window.CHUNK`` = 16384 steps): where the loops plan their forces and prescribed
# motion anew and hand their samples over (not for the engines of ``SHORT``)
LONG = {"prescribed": (["duration=6"], 3e-4), "spring-pair": (["duration=6"], 3e-4), "impact-damper": ([], 2e-4)}
CHECKPOINTS = 16  # samples per run compared with the recorded ones, spread evenly from the first to the last
TOLERANCE = 1e-4  # [1] of the run's range of y, L: 10x the largest move of a 1e-9 m/s change of the start (docstring)
RECORDED_FILE = Path(__file__).with_name("recorded_runs.json")
SLOW = ("drake", "mujoco_warp")  # tens of seconds each (Drake's continuous integrator, warp's CPU device)


def scene_of(key: str, engine: str, extra: tuple[str, ...] = ()):
    name, overrides = SCENES[key]
    if engine in SHORT:
        overrides = [o for o in overrides if not o.startswith("duration")] + [f"duration={SHORT[engine]}"]
    return load_scene(name, [*overrides, *extra])


def cases(engine: str):
    """Every case of ``engine``: (key, scene, settings) of the single runs."""
    for key in SCENES:
        for dt in DTS:
            yield f"{key}@{dt:g}", scene_of(key, engine), make_settings(engine, dt)
    for key, (extra, dt) in LONG.items() if engine not in SHORT else ():
        scene = load_scene(SCENES[key][0], [o for o in SCENES[key][1] if not o.startswith("duration")] + extra)
        yield f"long:{key}@{dt:g}", scene, make_settings(engine, dt)


def digest(traj, walls) -> str:
    """The first 20 hex digits of the sha256 of the trajectory's samples and status: equal bits, equal digest."""
    h = hashlib.sha256()
    for name in ("t", "x1", "x2", "v1", "v2"):
        h.update(np.ascontiguousarray(getattr(traj, name), dtype=np.float64).tobytes())
    for wall in walls:
        h.update(np.ascontiguousarray(traj.contact[wall], dtype=bool).tobytes())
        h.update(np.ascontiguousarray(traj.normal_force[wall], dtype=np.float64).tobytes())
    h.update(str(traj.status).encode())
    return h.hexdigest()[:20]


def fingerprint(traj) -> dict:
    """What is recorded of a run: status, sample count, L [m] and y, x1 [m] at ``CHECKPOINTS`` samples."""
    at = np.linspace(0, len(traj.t) - 1, CHECKPOINTS).round().astype(int)
    return {"status": str(traj.status), "samples": len(traj.t), "L": float(np.ptp(traj.y)),
            "y": [float(v) for v in traj.y[at]], "x1": [float(v) for v in traj.x1[at]]}


def departures(got: dict, want: dict) -> list[str]:
    """How ``got`` departs from ``want`` beyond the tolerance, one line each (none: within it)."""
    if (got["status"], got["samples"]) != (want["status"], want["samples"]):
        return [f"status, samples {got['status']}, {got['samples']} (recorded {want['status']}, {want['samples']})"]
    allowed = TOLERANCE * want["L"]
    out = []
    for name in ("y", "x1"):
        moved = np.abs(np.asarray(got[name]) - np.asarray(want[name]))
        if not np.all(moved <= allowed):  # a NaN where a number was recorded is a departure too
            k = int(np.nanargmax(np.where(np.isnan(moved), np.inf, moved)))
            out.append(f"{name} at checkpoint {k}: {got[name][k]!r} (recorded {want[name][k]!r}; allowed +-{allowed:.3g} m)")
    return out


def versions(engine: str) -> dict[str, str]:
    return {"engine": engine_version(engine), "numpy": np.__version__, "machine": platform.machine()}


def record(engine: str) -> dict:
    return {"versions": versions(engine),
            "runs": {key: fingerprint(run_engine(engine, scene, settings)) for key, scene, settings in cases(engine)}}


RECORDED = json.loads(RECORDED_FILE.read_text())


@pytest.mark.parametrize("engine", [pytest.param(e, marks=pytest.mark.slow) if e in SLOW else e
                                    for e in available_engines() if e in RECORDED])
def test_every_engine_runs_as_recorded_within_its_tolerance(engine):
    recorded = RECORDED[engine]
    problems = {}
    for key, scene, settings in cases(engine):
        lines = departures(fingerprint(run_engine(engine, scene, settings)), recorded["runs"][key])
        if lines:
            problems[key] = lines
    assert not problems, (f"{engine}: trajectories changed beyond {TOLERANCE:g} of their range (recorded with "
                          f"{recorded['versions']}, installed {versions(engine)}): {problems}")


@pytest.mark.parametrize("engine", [pytest.param(e, marks=pytest.mark.slow) if e in SLOW else e
                                    for e in available_engines() if e in RECORDED])
def test_every_engine_runs_bit_for_bit_again_and_in_its_batch(engine):
    # on one machine: a case run twice gives the same bits, and the batch gives each single run's bits
    jobs = [(scene_of(key, engine), make_settings(engine, DTS[0])) for key in BATCHED]
    single = [digest(run_engine(engine, scene, settings), scene.gap.walls) for scene, settings in jobs]
    again = digest(run_engine(engine, *jobs[0]), jobs[0][0].gap.walls)
    batch = [digest(traj, scene.gap.walls) for (scene, _), traj in zip(jobs, run_engine_batch(engine, jobs))]
    assert again == single[0], f"{engine}: the same run twice gave other bits"
    assert batch == single, f"{engine}: the batch's runs differ from the single runs: {dict(zip(BATCHED, zip(batch, single)))}"


def test_a_changed_restitution_is_seen():
    # known answer the other way: the ball with R x 1.01 departs from the recorded run; the recorded R is within it
    engine, key = "pybullet", f"bouncing-ball@{DTS[0]:g}"
    want = RECORDED[engine]["runs"][key]
    settings = make_settings(engine, DTS[0])
    assert departures(fingerprint(run_engine(engine, scene_of("bouncing-ball", engine), settings)), want) == []
    changed = scene_of("bouncing-ball", engine, ("restitution=0.505",))
    lines = departures(fingerprint(run_engine(engine, changed, settings)), want)
    assert lines and lines[0].startswith("y at checkpoint"), lines


def test_the_digest_sees_one_bit():
    # a last-bit change of one sample of one column is a different digest (the bit-for-bit test can fail)
    scene = scene_of("bouncing-ball", "pybullet")
    traj = run_engine("pybullet", scene, make_settings("pybullet", DTS[0]))
    before = digest(traj, scene.gap.walls)
    traj.x2[100] = np.nextafter(traj.x2[100], np.inf)
    assert digest(traj, scene.gap.walls) != before


def test_a_nan_is_a_departure():
    want = RECORDED["pybullet"]["runs"][f"bouncing-ball@{DTS[0]:g}"]
    got = dict(want, y=[float("nan") if k == 3 else v for k, v in enumerate(want["y"])])
    assert departures(got, want) and "checkpoint 3" in departures(got, want)[0]


if __name__ == "__main__":  # record: python3 tests/engines/test_unchanged_runs.py [ENGINE ...] > recorded_runs.json
    names = sys.argv[1:] or available_engines()
    print(json.dumps({e: record(e) for e in names}, indent=1))
