"""Running MuJoCo Warp: the adapter, many worlds stepped together on a warp device, each world one run, float32.

    >>> from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, MujocoWarpSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = MujocoWarpEngine().run(load_scene("bouncing-ball", ["duration=0.2"]), MujocoWarpSettings(dt=1e-3, device="cpu"))
    >>> traj.status, traj.engine, traj.settings["precision"], traj.settings["device"]
    ('ok', 'mujoco_warp', 'float32', 'cpu')

Each run is the MuJoCo engine's own model (``mujoco_engine.compiled``: the same MjSpec,
contact law, forces and precomputed controls, compiled once per structure), adapted by
``worlds.warp_model`` and put on the device as one world. ``run_batch`` puts compatible runs
(same sizes, step count and control layout, any per-world parameter: masses, R, gap, springs,
forcing, initial state, dt, w0 dt) into one MuJoCo Warp model of many worlds
(``batch.iter_blocks``: blocks within the host's memory); one ``mujoco_warp.step`` advances
them all, and the steps and the per-step recording are captured as a graph and replayed
(``kernels.Stepper``). Every chunk of samples comes back and goes to the base, which records
it in the runs' ``base.Recording`` as MuJoCo's and times it (``wholerun.py``) (``samples.hand_over``: contact flags and forces from the
same sensors, blow-ups, a long run kept compact), so memory stays bounded.

Promises: sample k is the state after k steps and its contact force the one MuJoCo Warp
computed at the start of step k (MuJoCo's rollout convention, so the two engines'
trajectories line up sample by sample); the arrays are float32 values widened to float64;
a world's samples do not depend on the other worlds of its batch (bit for bit: a batch's run is
the run alone); MuJoCo C's blow-up checks hold (a state past ``MAXVAL`` or not finite, and its
qacc check, done on the device: an acceleration past ``base.MAXVAL`` drops the states after it);
``settings["precision"]`` and ``settings["device"]`` say what computed them; a run never
raises from inside MuJoCo Warp (``status = "error"`` / ``"diverged"``, as for MuJoCo); the
kernels' loading (compiling, the first time on a machine: minutes on a GPU, tens of seconds on
the CPU device; then cached by warp) is not counted in ``wall_time`` but reported as
``settings["warmup_s"]`` and ``settings["kernels"]`` (``compiled`` or ``cached``).
"""

from __future__ import annotations

import math
import time
from typing import Any, Iterator, Sequence

import mujoco
import numpy as np

from chatterbench.reference.errors import check_integer
from chatterbench.reference.scene import Scene

from .. import mujoco_common
from ..api import EngineAdapter, Recording, Samples
from ..base import n_steps, version_of
from ..mujoco_common import prepare, rollout_controls
from ..trajectory import Trajectory
from ..wholerun import one_of_block
from .batch import HOST_BYTES, block_plan, finished, iter_blocks, roll_worlds
from .kernels import STEPS_PER_GRAPH, graphs, load_kernels
from .settings import MujocoWarpSettings
from .worlds import device_model, device_name, put_worlds, warp_model, warp_modules


GPU_UNIT_RUNS = 4096  # [runs] a sweep's unit of work on a GPU: one batch of worlds (``unit_runs``)


def device(s: MujocoWarpSettings) -> str:
    """The warp device of settings ``s``; a device that is not there is the user's SettingsError."""
    from ..settings import SettingsError

    try:
        return device_name(s.device)
    except RuntimeError as exc:
        raise SettingsError(str(exc)) from None


class _FirstRunNote(str):
    """The first-run note: a str on the class (the contract's fact), the same text naming the device the default
    settings find when read from an adapter (``progress`` reads it before a run)."""

    def __get__(self, obj: Any, owner: Any = None) -> str:
        if obj is None:
            return self
        try:
            found = device_name("auto")
        except Exception:  # noqa: BLE001  a note is never worth a failure
            return str(self)
        return str(self).replace("its device", f"device {found}")


class MujocoWarpEngine(EngineAdapter):
    """MuJoCo Warp behind the engine contract (``base.EngineAdapter``): MuJoCo's soft contact in float32."""

    name = "mujoco_warp"
    package = "mujoco-warp"
    settings_type = MujocoWarpSettings
    compliant = True
    precision = "float32"
    batches = True
    bytes_per_step = 250.0  # per world: MuJoCo's samples (float64 on the host) and float32 copies on the device
    bench_step_cap = 20_000  # a repeat of the benchmark: enough steps for the captured loop to show its rate
    same_model_as = "mujoco"  # MuJoCo's own MjSpec model (mujoco_common), stepped by warp in float32
    first_run_note = _FirstRunNote(
        "the first run on a machine compiles MuJoCo Warp's kernels for its device (minutes on a GPU, about a minute "
        "on the CPU; cached by warp under ~/.cache/warp, then loaded in seconds)")
    host_bytes = HOST_BYTES  # [B] a batch's host memory: its worlds go in blocks within it (``batch.block_plan``)

    def samples(self, run: Recording) -> Iterator[Samples | None]:
        """One run as a model of one world (``batch.roll_worlds``, set up once its kernels are loaded and its steps
        captured); ``Diverged`` for MuJoCo's acceleration warning."""
        p = prepare(run.scene, run.settings, run.n)
        m = p.structure.model
        plan = block_plan(1, p.nstep, len(run.scene.gap.walls), m.nq + m.nv + m.nsensordata, self.host_bytes)
        worlds = put_worlds([p], self.device_of(run.settings))
        done = yield from one_of_block(roll_worlds(worlds, [p], [run], plan.chunk), run)
        (failure,) = finished([run], done)
        if failure is not None:
            raise failure

    def run_batch(self, jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> list[Trajectory]:
        """Compatible runs as the worlds of one MuJoCo Warp model (``batch.iter_blocks``), in the jobs' order."""
        out: list[Trajectory | None] = [None] * len(jobs)
        for block in iter_blocks(self, list(jobs), self.host_bytes):
            for i, traj in block:
                out[i] = traj
        return out  # type: ignore[return-value]  # every job is in a block

    def iter_batch(self, jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> Iterator[tuple[int, Trajectory]]:
        """The batch block by block (``batch.iter_blocks``): a caller that keeps a summary of each trajectory holds
        one block's samples at a time, within ``host_bytes``."""
        for block in iter_blocks(self, list(jobs), self.host_bytes):
            yield from block

    def forks(self, settings: MujocoWarpSettings) -> bool:
        """On the CPU device a run may be forked; on cuda not (a CUDA context does not survive a fork)."""
        return self.device_of(settings) != "cuda"

    def unit_runs(self, settings: MujocoWarpSettings) -> int | None:
        """On cuda, ``GPU_UNIT_RUNS`` worlds per unit (a step of thousands costs about what one costs); else the
        sweep's own choice."""
        return GPU_UNIT_RUNS if self.device_of(settings) == "cuda" else None

    def device_of(self, settings: MujocoWarpSettings) -> str:
        """The warp device ``settings`` run on (``cuda`` or ``cpu``); SettingsError for one that is not there."""
        return device(settings)

    def bare_seconds(self, scene: Scene, settings: MujocoWarpSettings, traj: Trajectory) -> float:
        """Seconds of the bare ``mujoco_warp.step`` loop over the run, one world, captured where warp can (scaled to
        the run's steps: a captured loop steps whole graphs)."""
        bare = world_steps_per_s(scene, settings, nworld=1, repeats=1)
        return bare["seconds"] * (n_steps(scene.duration, settings.dt) + 1) / bare["steps"]

    def validate(self, scene: Scene, settings: MujocoWarpSettings) -> None:
        """MuJoCo's MjSpec build refuses what the scene cannot run with (compiled once per structure:
        ``mujoco_common.structure``); a device warp does not find is refused."""
        mujoco_common.structure(scene, settings)
        device(settings)

    def record(self, scene: Scene, settings: MujocoWarpSettings) -> dict[str, Any]:
        """MuJoCo's record, and what computed the run: precision, device, versions."""
        return {**mujoco_common.record(scene, settings), "precision": settings.precision, "device": device(settings),
                "mujoco_warp_version": version_of("mujoco-warp"), "warp_version": warp_modules()[0].__version__}

    def contact_scales(self, scene: Scene, settings: MujocoWarpSettings) -> tuple[float, float]:
        """MuJoCo's (``mujoco_common.contact_scales``): the same model."""
        return mujoco_common.contact_scales(scene, settings)

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """MuJoCo's space (``MujocoEngine.tuning_space``: the same model, contact law and knobs) under this engine's
        keys (``mujoco_warp.FIELD``): ``tune --engines mujoco_warp`` answers for MuJoCo Warp itself, in float32."""
        from ..mujoco_engine.run import MujocoEngine

        return {key if key == "dt" else f"{self.name}.{key.split('.', 1)[1]}": values
                for key, values in MujocoEngine().tuning_space(scene).items()}

    def snippet(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> str:
        """The scene's model as MJCF (``mujoco_common.export_mjcf``), to load with ``mujoco_warp.put_model``."""
        return mujoco_common.export_mjcf(scene, settings or MujocoWarpSettings())


def world_steps_per_s(scene: Scene, settings: MujocoWarpSettings | None = None, nworld: int = 1,
                      repeats: int = 3, captured: bool | None = None) -> dict[str, Any]:
    """World-steps per second of the bare ``mujoco_warp.step`` loop: ``nworld`` copies of ``scene`` stepped
    ``n_steps(scene.duration, dt)`` times, best of ``repeats`` (kernels loaded before the clock starts).

    ``captured``: the steps captured as one graph of ``kernels.STEPS_PER_GRAPH`` steps and replayed (as MuJoCo Warp's
    ``testspeed`` does), or launched one by one from Python (False: the loop a user writes first); None: captured
    where warp can (``kernels.graphs``). Returns ``device``, ``nworld``, ``steps``, ``seconds`` (best repeat),
    ``world_steps_per_s``, ``warmup_s`` (kernel loading), ``captured``.
    """
    check_integer("nworld", nworld, lo=1)
    check_integer("repeats", repeats, lo=1)
    s = settings or MujocoWarpSettings()
    wp, mjw = warp_modules()
    dev = device(s)
    p = prepare(scene, s, n_steps(scene.duration, s.dt))
    mjm = warp_model(p.model)
    captured = graphs(dev) if captured is None else bool(captured and graphs(dev))
    per_graph = STEPS_PER_GRAPH
    with wp.ScopedDevice(dev):
        model = device_model(p.model, dev)
        d = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=nworld)
        d.qpos.assign(np.tile(p.initial_state[0, 1:1 + mjm.nq].astype(np.float32), (nworld, 1)))
        if mjm.nu:
            d.ctrl.assign(np.tile(rollout_controls(p, 0, 1)[0, :, : mjm.nu].astype(np.float32), (nworld, 1)))
        warmup = load_kernels(model, d, dev).seconds
        if captured:
            with wp.ScopedCapture() as capture:
                for _ in range(per_graph):
                    mjw.step(model, d)
            launches, step = math.ceil(p.nstep / per_graph), lambda: wp.capture_launch(capture.graph)
        else:
            launches, step = p.nstep, lambda: mjw.step(model, d)
        best = math.inf
        for _ in range(repeats):
            wp.synchronize()
            start = time.perf_counter()
            for _ in range(launches):
                step()
            wp.synchronize()
            best = min(best, time.perf_counter() - start)
    steps = launches * per_graph if captured else p.nstep
    return {"device": dev, "nworld": nworld, "steps": steps, "seconds": best,
            "world_steps_per_s": nworld * steps / best, "warmup_s": warmup, "captured": captured}
