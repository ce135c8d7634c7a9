"""The MuJoCo Warp adapter: the MuJoCo engine's model of a scene, stepped as one of many worlds on a warp device.

    >>> from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, MujocoWarpSettings
    >>> engine = MujocoWarpEngine()
    >>> traj = engine.run(load_scene("feigin-pair", ["duration=0.5"]), MujocoWarpSettings(dt=1e-3, device="cpu"))
    >>> traj.status, traj.settings["precision"], round(traj.contact_frequency)
    ('ok', 'float32', 30)

MuJoCo Warp (``pip install ".[warp]"``: ``mujoco-warp`` on ``warp-lang``) runs MuJoCo's
pipeline as warp kernels over a batch of worlds, on a CUDA GPU when there is one and on
warp's CPU device otherwise. The model is MuJoCo's, built by ``mujoco_engine.model`` from
the same ``MjSpec`` with the same contact law, forces and controls, so that the two engines
differ only in what executes the model: MuJoCo C in float64, MuJoCo Warp in float32.

Modules: ``settings`` (``MujocoWarpSettings``: MuJoCo's fields plus ``precision`` and
``device``), ``worlds`` (many MuJoCo models as one MuJoCo Warp model of many worlds),
``run`` (stepping, recording, classification through the MuJoCo engine's own rules).

What to expect: the first run on a machine compiles MuJoCo Warp's kernels (about a minute on
the CPU device; warp caches them under ``~/.cache/warp``). On the CPU device a step of any
number of worlds up to a few hundred costs about the same (1.5 to 3 ms on the 2-core machine
this was written on: each of its ~90 kernel launches costs Python time), so the engine is
slow for one run and pays off in batches (``run_batch``: a sweep unit's compatible points).
"""

from __future__ import annotations

from typing import Any, Sequence

from chatterbench.reference.scene import Scene

from ..base import EngineAdapter
from ..mujoco_engine.model import build, export_mjcf
from ..trajectory import Trajectory
from .run import BENCH_STEP_CAP, benchmark, run, run_batch, world_steps_per_s
from .settings import DEVICES, PRECISIONS, MujocoWarpSettings

__all__ = ["BENCH_STEP_CAP", "DEVICES", "PRECISIONS", "MujocoWarpEngine", "MujocoWarpSettings", "benchmark", "run",
           "run_batch", "world_steps_per_s"]


class MujocoWarpEngine(EngineAdapter):
    """MuJoCo Warp behind the engine contract (``base.EngineAdapter``)."""

    name = "mujoco_warp"
    package = "mujoco-warp"
    settings_type = MujocoWarpSettings
    batches = True
    bytes_per_step = 250.0  # per world: MuJoCo's samples (float64 on the host) and float32 copies on the device

    def build(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> Any:
        """The compiled ``MjModel`` MuJoCo Warp is given (before ``worlds.warp_model``)."""
        return build(scene, settings or MujocoWarpSettings())

    def run(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> Trajectory:
        """Simulate ``scene`` in one world (``run.run``)."""
        return run(scene, settings)

    def run_batch(self, jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> list[Trajectory]:
        """Compatible runs as the worlds of one MuJoCo Warp model (``run.run_batch``)."""
        return run_batch(list(jobs))

    def snippet(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> str:
        """The scene's model as MJCF (``mujoco_engine.model.export_mjcf``), to load with ``mujoco_warp.put_model``."""
        return export_mjcf(scene, settings or MujocoWarpSettings())

    def benchmark(self, scene: Scene, settings: MujocoWarpSettings | None = None, n_steps: int = 200_000,
                  repeats: int = 3) -> dict[str, Any]:
        """Adapter against the bare ``mujoco_warp.step`` loop, steps per second (``run.benchmark``)."""
        return benchmark(scene, settings, n_steps, repeats)
