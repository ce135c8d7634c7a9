"""Every engine's trajectories, bit for bit, as they were before the base took over the run (``base.py``'s step loop).

The hashes below were recorded from the code before the change (``python3 tests/engines/test_unchanged_runs.py``
prints them) with the versions beside them: each engine's own package and numpy. A hash covers t, x1, x2, v1, v2,
every wall's contact flags and normal force (their bytes: a sign of zero counts) and the status, of five scenes
(the four built-in ones, and feigin-pair with a prescribed body 1) at two dts, three runs longer than a chunk of
the loops, and every engine's batch (MuJoCo's and MuJoCo Warp's share their runs). With other versions of an engine or of numpy the recorded bits do not apply: the test skips, saying so.
"""

from __future__ import annotations

import hashlib
import json
import platform
import sys

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

RECORDED = {  # engine -> the versions and each case's hash, recorded before the change (module docstring)
    "mujoco": {"versions": {"engine": "4.0.0", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "8701935a4b02ee7b1f4a", "bouncing-ball@0.0003": "c88179361f3e7bb49eed", "feigin-pair@0.001": "380a94bf1c982b043beb",
        "feigin-pair@0.0003": "12db88812d8c0bc109de", "impact-damper@0.001": "e7468f64b03f59ac5f05", "impact-damper@0.0003": "580ecd2f156215357113",
        "spring-pair@0.001": "27069fa9f83bb913c0ac", "spring-pair@0.0003": "f7d2da374d1683eb9ca3", "prescribed@0.001": "2d3a45dba9457898ee82",
        "prescribed@0.0003": "5b52cda66795afeddb6a", "long:prescribed@0.0003": "32cdda7cb699daa0e01d", "long:spring-pair@0.0003": "913cb3806a70d63c3ecd",
        "long:impact-damper@0.0002": "f422e70a512a692837fb", "batch:bouncing-ball@0.001": "8701935a4b02ee7b1f4a", "batch:spring-pair@0.001": "27069fa9f83bb913c0ac",
        "batch:impact-damper@0.001": "e7468f64b03f59ac5f05",
    }},
    "pybullet": {"versions": {"engine": "3.2.7", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "aedb49814e3a07840193", "bouncing-ball@0.0003": "7b28cd6c35a77e8a95d9", "feigin-pair@0.001": "b07c97456ea5b8fc095f",
        "feigin-pair@0.0003": "308f0b00884e19f31026", "impact-damper@0.001": "71c119d808ce780694c2", "impact-damper@0.0003": "7aa2ce491b1901469226",
        "spring-pair@0.001": "019326c277e5ce828920", "spring-pair@0.0003": "871e005e11ae1d605714", "prescribed@0.001": "20f9b01ffd1ed2790073",
        "prescribed@0.0003": "7f4da2fd55a8d5269618", "long:prescribed@0.0003": "121df879f347cdfd3936", "long:spring-pair@0.0003": "01c4e59fbb993257c1d7",
        "long:impact-damper@0.0002": "dd997eff4bbc3316ee57", "batch:bouncing-ball@0.001": "aedb49814e3a07840193", "batch:spring-pair@0.001": "019326c277e5ce828920",
        "batch:impact-damper@0.001": "71c119d808ce780694c2",
    }},
    "drake": {"versions": {"engine": "1.51.1", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "1a812ded79da0beb8aa3", "bouncing-ball@0.0003": "d2c8756c3bb1b1cd9a74", "feigin-pair@0.001": "d709d3545dfb2add3a4f",
        "feigin-pair@0.0003": "da9998d7bb6b38f83b6d", "impact-damper@0.001": "35a3fda5353afe0542d9", "impact-damper@0.0003": "665a9adabd82d9c53721",
        "spring-pair@0.001": "e116bfa690ddf45dd6a0", "spring-pair@0.0003": "ac5c0cb40e6b5f5c5a13", "prescribed@0.001": "9f65592b4f1329cdd3e6",
        "prescribed@0.0003": "c5651f495d218fc38970", "long:prescribed@0.0003": "0e15dee48e7413d541c3", "long:spring-pair@0.0003": "6257f3733a5384ccb584",
        "long:impact-damper@0.0002": "5ca8ce7368a347fafba0", "batch:bouncing-ball@0.001": "1a812ded79da0beb8aa3", "batch:spring-pair@0.001": "e116bfa690ddf45dd6a0",
        "batch:impact-damper@0.001": "35a3fda5353afe0542d9",
    }},
    "mujoco_warp": {"versions": {"engine": "4.0.0", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "35ba0a0fd94249ff86bf", "bouncing-ball@0.0003": "ef303cb5264b26f4596b", "feigin-pair@0.001": "cc099f92e8c940c19c41",
        "feigin-pair@0.0003": "8f6d57c55811503c31bb", "impact-damper@0.001": "fb5b8765ed80dc2ec4af", "impact-damper@0.0003": "3fe8a973f2d60409086f",
        "spring-pair@0.001": "6da1f2d294abedd15c79", "spring-pair@0.0003": "a06f66bda0c3dfd1ce52", "prescribed@0.001": "802f1bc133ab4984ccbc",
        "prescribed@0.0003": "e21710df009b05eb58fb", "batch:bouncing-ball@0.001": "35ba0a0fd94249ff86bf", "batch:spring-pair@0.001": "6da1f2d294abedd15c79",
        "batch:impact-damper@0.001": "fb5b8765ed80dc2ec4af",
    }},
    "physx": {"versions": {"engine": "3.0.3", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "b37ad4c6434291d8d7a6", "bouncing-ball@0.0003": "96a5137d44e40a9d3a84", "feigin-pair@0.001": "7e8d1ee2c7257e3e0735",
        "feigin-pair@0.0003": "37cdd17c7e174c58b069", "impact-damper@0.001": "d7dd7ae70cede808f433", "impact-damper@0.0003": "9a59f248bdb90b70b89c",
        "spring-pair@0.001": "1c25ca12b2aa7a22e3e8", "spring-pair@0.0003": "10a6658c38b9f2a00f1f", "prescribed@0.001": "7a8d99a9a42b83884505",
        "prescribed@0.0003": "8567d3bf5d8c35bd49bc", "long:prescribed@0.0003": "8d4f35e548c4cdbd78c9", "long:spring-pair@0.0003": "63ea558c715c27c7e8ba",
        "long:impact-damper@0.0002": "76bc7a1643aa646ba0ef", "batch:bouncing-ball@0.001": "b37ad4c6434291d8d7a6", "batch:spring-pair@0.001": "1c25ca12b2aa7a22e3e8",
        "batch:impact-damper@0.001": "d7dd7ae70cede808f433",
    }},
    "dart": {"versions": {"engine": "6.20.0", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "643adab2133841958fff", "bouncing-ball@0.0003": "7aae3b03a132548fb10a", "feigin-pair@0.001": "b22ebc07e11dc0e8cf13",
        "feigin-pair@0.0003": "d472c0c06cfd06c9a54d", "impact-damper@0.001": "8add103d21d057bb54d3", "impact-damper@0.0003": "9b84b55f35f627086b83",
        "spring-pair@0.001": "041cace63be51085a84f", "spring-pair@0.0003": "09bcbf19defd9edc9779", "prescribed@0.001": "0040e05c258b5c834b5d",
        "prescribed@0.0003": "4a7bc3c28941c42e44ce", "long:prescribed@0.0003": "3ffebe099688c43525ee", "long:spring-pair@0.0003": "3ae48e026749396edfd5",
        "long:impact-damper@0.0002": "8ae8eaada492c3c62afe", "batch:bouncing-ball@0.001": "643adab2133841958fff", "batch:spring-pair@0.001": "041cace63be51085a84f",
        "batch:impact-damper@0.001": "8add103d21d057bb54d3",
    }},
    "siconos": {"versions": {"engine": "4.5.0", "numpy": "2.4.6", "machine": "x86_64"}, "runs": {
        "bouncing-ball@0.001": "c0e189cfcbd1186709ed", "bouncing-ball@0.0003": "9bcf186c783663bdbec0", "feigin-pair@0.001": "3f1c2ccc7f635303fc88",
        "feigin-pair@0.0003": "88cf8aa4f3df0255b576", "impact-damper@0.001": "de100183974efd7367be", "impact-damper@0.0003": "5150baf1cdb366e40ed2",
        "spring-pair@0.001": "e964eb089541cdc1fa34", "spring-pair@0.0003": "a60f7b5c93d831473e98", "prescribed@0.001": "68aabe20d861a3e52de9",
        "prescribed@0.0003": "2cd83f1fc5839da1b869", "long:prescribed@0.0003": "5b9ebacbbc67d44a1621", "long:spring-pair@0.0003": "820e038194ebb2b67869",
        "long:impact-damper@0.0002": "88c3744cedc1d10607c3", "batch:bouncing-ball@0.001": "c0e189cfcbd1186709ed", "batch:spring-pair@0.001": "e964eb089541cdc1fa34",
        "batch:impact-damper@0.001": "de100183974efd7367be",
    }},
}


def scene_of(key: str, engine: str):
    name, overrides = SCENES[key]
    if engine in SHORT:
        overrides = [o for o in overrides if not o.startswith("duration")] + [f"duration={SHORT[engine]}"]
    return load_scene(name, overrides)


def digest(traj, walls) -> str:
    """The first 20 hex digits of the sha256 of the trajectory's samples and status."""
    h = hashlib.sha256()
    for name in ("t", "x1", "x2", "v1", "v2"):
        h.update(np.ascontiguousarray(getattr(traj, name), dtype=np.float64).tobytes())
    for wall in walls:
        h.update(np.ascontiguousarray(traj.contact[wall], dtype=bool).tobytes())
        h.update(np.ascontiguousarray(traj.normal_force[wall], dtype=np.float64).tobytes())
    h.update(str(traj.status).encode())
    return h.hexdigest()[:20]


def versions(engine: str) -> dict[str, str]:
    return {"engine": engine_version(engine), "numpy": np.__version__, "machine": platform.machine()}


def hashes(engine: str) -> dict[str, str]:
    """Every case's hash for ``engine``: each scene at each dt, and the batch where the engine batches."""
    out = {}
    for key in SCENES:
        for dt in DTS:
            scene = scene_of(key, engine)
            out[f"{key}@{dt:g}"] = digest(run_engine(engine, scene, make_settings(engine, dt)), scene.gap.walls)
    for key, (extra, dt) in LONG.items() if engine not in SHORT else ():
        scene = load_scene(SCENES[key][0], [o for o in SCENES[key][1] if not o.startswith("duration")] + extra)
        out[f"long:{key}@{dt:g}"] = digest(run_engine(engine, scene, make_settings(engine, dt)), scene.gap.walls)
    jobs = [(scene_of(key, engine), make_settings(engine, DTS[0])) for key in BATCHED]
    for key, (scene, _), traj in zip(BATCHED, jobs, run_engine_batch(engine, jobs)):
        out[f"batch:{key}@{DTS[0]:g}"] = digest(traj, scene.gap.walls)
    return out


# the one change the base's loop made, each with its new hash and why: DART's loop commanded a prescribed body 1 to
# x1(t_k + dt) on the last step of each chunk, the base to x1(t0 + (k + 1) dt), the time of the next step's start
# (as every other step and engine): the same time to 1 ulp; feigin-pair's last sample (20,001 of 20,001) moves by
# 8e-17 m in y and 2.5e-13 m/s in y', no contact flag changes (measured against the recorded code)
CHANGED = {("dart", "long:prescribed@0.0003"): "7b96f12181cb69291512"}
SLOW = ("drake", "mujoco_warp")  # tens of seconds each (Drake's continuous integrator, warp's CPU device)


@pytest.mark.parametrize("engine", [pytest.param(e, marks=pytest.mark.slow) if e in SLOW else e
                                    for e in available_engines() if e in RECORDED])
def test_every_engine_runs_bit_for_bit_as_before_the_base_owned_the_loop(engine):
    recorded = RECORDED[engine]
    if versions(engine) != recorded["versions"]:
        pytest.skip(f"{engine}: hashes recorded with {recorded['versions']}, installed {versions(engine)}")
    got = hashes(engine)
    want = {case: CHANGED.get((engine, case), h) for case, h in recorded["runs"].items()}
    changed = {case: (h, got.get(case)) for case, h in want.items() if got.get(case) != h}
    assert not changed, f"{engine}: trajectories changed (recorded, now): {changed}"


def test_the_hash_sees_one_bit():
    # a last-bit change of one sample of one column is a different hash (the test above can fail)
    scene = scene_of("bouncing-ball", "pybullet")
    traj = run_engine("pybullet", scene, make_settings("pybullet", DTS[0]))
    before = digest(traj, scene.gap.walls)
    traj.x2[100] = np.nextafter(traj.x2[100], np.inf)
    assert digest(traj, scene.gap.walls) != before


if __name__ == "__main__":  # record: python3 tests/engines/test_unchanged_runs.py [ENGINE ...] > hashes.json
    names = sys.argv[1:] or available_engines()
    print(json.dumps({e: {"versions": versions(e), "runs": hashes(e)} for e in names}, indent=1))
