"""The GPU targets of issue 31, measured on the machine this runs on and judged: one line each, PASS or FAIL with its number.

Run by ``examples/gpu/check.sh`` (which sets the paths) on a GPU machine staged as
``../shared/gpu/README.md`` says; every line also goes to ``$OUT/check.txt`` and
``$OUT/check.json`` as soon as it is measured, so a session cut short keeps what it got.
Steps (all by default, in this order; name some to run only those):

- ``env``: versions, the devices warp finds (FAIL without a CUDA device);
- ``warmup``: MuJoCo Warp's kernels loaded on cuda (compiled the first time on a machine): the time, said apart;
- ``one_world``: one world >= 1,000 steps/s through the adapter (feigin-pair, dt = 1e-3, 2000 steps, warm);
- ``compare``: ``compare feigin-pair --engines mujoco,mujoco_warp`` within 30 s warm, and its first-run note naming
  the device; the same with ``--set mujoco_warp.device=cpu`` for comparison (INFO);
- ``bench``: ``bench sweep --only warp`` (its default worlds) within 60 s warm;
- ``worlds``: at 65,536 worlds the adapter >= 50% of the bare ``mujoco_warp.step`` loop (launched from Python, as the
  issue measured it; against the captured loop: INFO), and the batch's host memory within 2 GiB;
- ``map``: a 64 x 64 dt x w0_dt map of feigin-pair (one forcing period) through ``sweep`` within 60 s warm;
- ``tune``: ``tune bouncing-ball --engines mujoco_warp --tolerance 0.05``: its time (INFO), whether its search passes
  went to MuJoCo Warp as batches of worlds (on cuda; on the CPU device each run alone) and each answer rerun in
  MuJoCo C (the conformance section of ``recommended.json``).

``--dry-run`` runs every step on warp's CPU device with small sizes (1,024 worlds, an 8 x 8 map, a tune of 30 runs), PASS/FAIL
against the same targets, each line marked ``(dry run, cpu)``: what this script does, checked without a GPU.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

OUT = Path(os.environ.get("OUT") or "gpu-check")
DRY = "--dry-run" in sys.argv
DEVICE = "cpu" if DRY else "cuda"
WORLDS = 1_024 if DRY else 65_536  # the issue: >= 65,536
MAP = 8 if DRY else 64  # points per axis of the dt x w0_dt map
PERIOD = 2.0 * math.pi  # [s] feigin-pair's forcing period (omega = 1 rad/s)
CLI = [sys.executable, "-m", "chatterbench.comparisons.cli"]
RESULTS: list[dict] = []


def say(kind: str, name: str, value: float | str, unit: str = "", target: str = "", note: str = "") -> None:
    """One result line, printed and kept (``check.txt``, ``check.json``) at once."""
    shown = f"{value:.4g}" if isinstance(value, float) else str(value)
    line = f"{kind}: {name} = {shown}{' ' + unit if unit else ''}"
    line += f" (target {target})" if target else ""
    line += f"; {note}" if note else ""
    line += " (dry run, cpu)" if DRY else ""
    print(line, flush=True)
    RESULTS.append({"kind": kind, "name": name, "value": value, "unit": unit, "target": target, "note": note,
                    "dry_run": DRY, "at": time.strftime("%Y-%m-%dT%H:%M:%S")})
    with open(OUT / "check.txt", "a") as f:
        f.write(line + "\n")
    (OUT / "check.json").write_text(json.dumps(RESULTS, indent=1, default=str))


def judged(name: str, value: float, unit: str, op: str, bound: float, note: str = "") -> None:
    passed = value >= bound if op == ">=" else value <= bound
    say("PASS" if passed else "FAIL", name, float(value), unit, f"{op} {bound:g}", note)


def cli(args: list[str], log: str, timeout: float) -> tuple[float, int, str]:
    """A chatterbench command in a fresh process, timed [s]; its output kept in ``$OUT/<log>``."""
    start = time.perf_counter()
    try:
        proc = subprocess.run(CLI + args, capture_output=True, text=True, timeout=timeout)
        code, out, err = proc.returncode, proc.stdout, proc.stderr
    except subprocess.TimeoutExpired as exc:
        code, out, err = 124, str(exc.stdout or ""), str(exc.stderr or "") + f"\nkilled after {timeout:g} s"
    wall = time.perf_counter() - start
    (OUT / log).write_text(f"$ chatterbench {' '.join(args)}\n# exit {code}, {wall:.1f} s\n{out}\n--- stderr\n{err}")
    return wall, code, err


def warp_settings(dt: float = 1e-3):
    from chatterbench.engines.registry import make_settings

    return make_settings("mujoco_warp", dt, [f"mujoco_warp.device='{DEVICE}'"])


def env() -> None:
    from importlib.metadata import version

    from chatterbench.engines.mujoco_warp_engine.worlds import gpu_count, warp_modules

    for package in ("warp-lang", "mujoco", "mujoco-warp", "numpy"):
        say("INFO", f"version {package}", version(package))
    wp, _ = warp_modules()
    say("INFO", "python", sys.version.split()[0])
    say("INFO", "warp devices", ", ".join(f"{d.alias} ({d.name})" for d in wp.get_devices()))
    try:
        smi = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=30).stdout.strip()
        say("INFO", "nvidia-smi -L", smi.replace("\n", " | ") or "(nothing)")
    except (OSError, subprocess.TimeoutExpired):
        say("INFO", "nvidia-smi -L", "(not there)")
    if not DRY:
        judged("CUDA devices warp finds", float(gpu_count()), "", ">=", 1)


def warmup() -> None:
    from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, kernels
    from chatterbench.reference.scene import load_scene

    kernels.listeners.append(lambda load: say("INFO", "kernel compile", load.describe()))
    for name in ("feigin-pair", "bouncing-ball"):  # the map's model, and the one a sweep worker warms up with
        start = time.perf_counter()
        traj = MujocoWarpEngine().run(load_scene(name, ["duration=0.05"]), warp_settings())
        say("INFO", f"kernels for {name} on {traj.settings.get('device')}", traj.settings.get("warmup_s", math.nan),
            "s", note=f"{traj.settings.get('kernels')}; the first run took {time.perf_counter() - start:.1f} s; "
                      f"status {traj.status} {traj.message}")


def one_world() -> None:
    from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, world_steps_per_s
    from chatterbench.reference.scene import load_scene

    scene, s = load_scene("feigin-pair", ["duration=2.0"]), warp_settings()
    engine = MujocoWarpEngine()
    engine.run(scene, s)  # graphs, caches
    start = time.perf_counter()
    traj = engine.run(scene, s)
    wall = time.perf_counter() - start
    judged("one world through the adapter", (len(traj.t) - 1) / wall, "steps/s", ">=", 1000,
           f"{len(traj.t) - 1} steps in {wall:.2f} s on {traj.settings.get('device')}, graph capture "
           f"{traj.settings.get('capture_s', math.nan):.2f} s of it, status {traj.status}")
    # the bare loops for information; a dry run times 200 steps (Python's launches on the CPU: ~500 steps/s)
    bare_scene = load_scene("feigin-pair", ["duration=0.2"]) if DRY else scene
    for captured in (True, False):
        bare = world_steps_per_s(bare_scene, s, nworld=1, repeats=2, captured=captured)
        say("INFO", f"one world, bare loop {'captured' if captured else 'launched'}", bare["world_steps_per_s"],
            "steps/s", note=f"{bare['steps']} steps")


def compare() -> None:
    wall, code, err = cli(["compare", "feigin-pair", "--engines", "mujoco,mujoco_warp"], "compare.txt", 300)
    judged("compare feigin-pair --engines mujoco,mujoco_warp (warm)", wall, "s", "<=", 30, f"exit {code}")
    named = f"for device {DEVICE}" in err
    say("PASS" if named else "FAIL", "the first-run note names the device", f"'for device {DEVICE}' in stderr: {named}")
    if not DRY:
        wall, code, _ = cli(["compare", "feigin-pair", "--engines", "mujoco,mujoco_warp", "--set",
                             "mujoco_warp.device='cpu'"], "compare_cpu.txt", 300)
        say("INFO", "the same compare with mujoco_warp on warp's CPU device", wall, "s", note=f"exit {code}")


def bench() -> None:
    args = ["bench", "sweep", "--only", "warp"] + (["--worlds", "1,16,64"] if DRY else [])
    wall, code, _ = cli(args, "bench_sweep.txt", 600)
    judged("bench sweep --only warp (warm)", wall, "s", "<=", 60, f"exit {code}; its table: bench_sweep.txt")


def _rss(field: str) -> float:
    """This process's VmRSS or VmHWM (peak) [GiB] (Linux /proc)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return float(line.split()[1]) / 2**20
    return math.nan


def worlds() -> None:
    from chatterbench.comparisons.studies.bench import bench_warp

    before = _rss("VmRSS")
    figures = bench_warp(worlds=(WORLDS,), steps=500)
    peak = _rss("VmHWM")
    figures.to_csv(OUT / "worlds.csv", index=False)
    row = figures.iloc[0]
    judged(f"adapter / bare loop (launched) at {WORLDS} worlds", float(row["adapter_over_bare"]), "", ">=", 0.5,
           f"adapter {row['warp_world_steps_per_s']:.4g}, bare {row['warp_bare_world_steps_per_s']:.4g} world-steps/s, "
           f"{row['blocks']} blocks, statuses {row['statuses']}")
    say("INFO", f"adapter / bare loop (captured) at {WORLDS} worlds",
        float(row["warp_world_steps_per_s"] / row["warp_bare_captured_world_steps_per_s"]), "",
        note=f"captured bare {row['warp_bare_captured_world_steps_per_s']:.4g} world-steps/s; MuJoCo C "
             f"{row['mujoco_c_steps_per_s']:.4g} steps/s on 1 thread, {row['mujoco_c_threaded_steps_per_s']:.4g} on "
             f"{row['threads']}")
    judged(f"host memory of the {WORLDS}-world batch", peak - before, "GiB", "<=", 2.0,
           f"peak {peak:.2f} GiB, {before:.2f} GiB before")


def map_spec(points: int) -> str:
    """The dt x w0_dt map of feigin-pair over one forcing period, ``points`` log-spaced values per axis: dt 2e-4 to
    2e-3 s, w0 dt 0.02 to 1.3 (under 0.9 of Euler's limit 1.55 for R = 0.5)."""
    def axis(lo: float, hi: float) -> str:
        return "[" + ", ".join(repr(float(f"{lo * (hi / lo) ** (i / (points - 1)):.6g}")) for i in range(points)) + "]"

    return (f'scene = "feigin-pair"\nengines = ["mujoco_warp"]\ntimeout = 600\n\n[set]\nduration = {PERIOD!r}\n'
            f"mujoco_warp.device = '{DEVICE}'\n\n[grid]\ndt = {axis(2e-4, 2e-3)}\n"
            f"mujoco_warp.w0_dt = {axis(0.02, 1.3)}\n")


def map_sweep() -> None:
    spec = OUT / "map.toml"
    spec.write_text(map_spec(MAP))
    workers = str(min(16, os.cpu_count() or 1))
    wall, code, _ = cli(["sweep", str(spec), "--out", str(OUT / f"map-{time.time_ns()}"), "--workers", workers],
                        "map.txt", 900)
    judged(f"a {MAP} x {MAP} dt x w0_dt map of feigin-pair through sweep (warm)", wall, "s", "<=", 60,
           f"exit {code}, {workers} workers; its table: map.txt")


def tune() -> None:
    out = OUT / f"tune-{time.time_ns()}"
    args = ["tune", "bouncing-ball", "--engines", "mujoco_warp", "--tolerance", "0.05", "--out", str(out)]
    wall, code, _ = cli(args + (["--max-runs", "30"] if DRY else []), "tune.txt", 900)
    rec_file = out / "recommended.json"
    if not rec_file.exists():
        say("FAIL", "tune bouncing-ball --engines mujoco_warp", f"no recommended.json, exit {code}; its output: tune.txt")
        return
    rec = json.loads(rec_file.read_text())
    say("INFO", "tune bouncing-ball --engines mujoco_warp", wall, "s",
        note=f"exit {code}, {rec['searched']['runs']} runs; {rec['answer']}")
    batched = rec["searched"].get("batched")
    say("PASS" if batched == (DEVICE == "cuda") else "FAIL", "tune's search passes go to MuJoCo Warp as batches of worlds "
        "on cuda (on the CPU device each run alone)", f"batched: {batched}")
    check = rec.get("same_model")
    say("PASS" if check else "FAIL", "each answer of the tune rerun in MuJoCo C at the same settings",
        check["sentence"] if check else "no same_model section in recommended.json")


STEPS = {"env": env, "warmup": warmup, "one_world": one_world, "compare": compare, "bench": bench, "worlds": worlds,
         "map": map_sweep, "tune": tune}


def main(argv: list[str]) -> int:
    names = [a for a in argv if not a.startswith("--")] or list(STEPS)
    unknown = [n for n in names if n not in STEPS]
    if unknown:
        print(f"check.py: unknown step {unknown[0]!r}: one of {', '.join(STEPS)}", file=sys.stderr)
        return 2
    OUT.mkdir(parents=True, exist_ok=True)
    for name in names:
        start = time.perf_counter()
        try:
            STEPS[name]()
        except Exception as exc:  # noqa: BLE001  a step that fails is a FAIL line; the next one still runs
            say("FAIL", f"step {name}", f"{type(exc).__name__}: {exc}".splitlines()[0])
        say("INFO", f"step {name} took", time.perf_counter() - start, "s")
    return 1 if any(r["kind"] == "FAIL" for r in RESULTS) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
