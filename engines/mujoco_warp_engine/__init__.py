"""The MuJoCo Warp adapter: the MuJoCo engine's model of a scene, stepped as one of many worlds on a warp device.

    >>> from chatterbench.engines.mujoco_warp_engine import MujocoWarpEngine, MujocoWarpSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> engine = MujocoWarpEngine()
    >>> traj = engine.run(load_scene("feigin-pair", ["duration=0.5"]), MujocoWarpSettings(dt=1e-3, device="cpu"))
    >>> traj.status, traj.settings["precision"], round(traj.contact_frequency)
    ('ok', 'float32', 30)

MuJoCo Warp (``pip install ".[warp]"``: ``mujoco-warp`` on ``warp-lang``) runs MuJoCo's
pipeline as warp kernels over a batch of worlds, on a CUDA GPU when there is one and on
warp's CPU device otherwise. The model is MuJoCo's (``mujoco_common``, which both adapters share), from
the same ``MjSpec`` with the same contact law, forces and controls, so that the two engines
differ only in what executes the model: MuJoCo C in float64, MuJoCo Warp in float32.

Modules: ``settings`` (``MujocoWarpSettings``: MuJoCo's fields plus ``precision`` and
``device``), ``worlds`` (many MuJoCo models as one MuJoCo Warp model of many worlds),
``run`` (stepping the worlds, handing each world's samples to its run as MuJoCo's are handed over).

What to expect: the first run on a machine compiles MuJoCo Warp's kernels (about a minute on
the CPU device; warp caches them under ``~/.cache/warp``). On the CPU device a step of any
number of worlds up to a few hundred costs about the same (1.5 to 3 ms on the 2-core machine
this was written on: each of its ~90 kernel launches costs Python time), so the engine is
slow for one run and pays off in batches (``run_batch``: a sweep unit's compatible points).
"""

from __future__ import annotations

from typing import Any, Sequence

from chatterbench.reference.scene import Scene

from .. import mujoco_common
from ..base import EngineAdapter, Recording, version_of
from ..trajectory import Trajectory
from . import run as _run
from .run import world_steps_per_s
from .settings import DEVICES, PRECISIONS, MujocoWarpSettings

__all__ = ["DEVICES", "PRECISIONS", "MujocoWarpEngine", "MujocoWarpSettings", "run", "run_batch", "world_steps_per_s"]


class MujocoWarpEngine(EngineAdapter):
    """MuJoCo Warp behind the engine contract (``base.EngineAdapter``): MuJoCo's soft contact in float32."""

    name = "mujoco_warp"
    package = "mujoco-warp"
    settings_type = MujocoWarpSettings
    compliant = True
    precision = "float32"
    batches = True
    bytes_per_step = 250.0  # per world: MuJoCo's samples (float64 on the host) and float32 copies on the device
    bench_step_cap = 2_000  # a step's cost is flat after the first few (launch-bound on the cpu device)
    same_model_as = "mujoco"  # MuJoCo's own MjSpec model (mujoco_common), stepped by warp in float32
    first_run_note = ("the first run on a machine compiles MuJoCo Warp's kernels (about a minute on the CPU; cached "
                      "under ~/.cache/warp), then steps at 1.5-3 ms a step on the CPU device")

    def simulate(self, run: Recording) -> None:
        """One world stepped on the device (``run.simulate``)."""
        _run.simulate(run)

    def validate(self, scene: Scene, settings: MujocoWarpSettings) -> None:
        """MuJoCo's MjSpec build refuses what the scene cannot run with; a device warp does not find is refused."""
        mujoco_common.build_spec(scene, settings)
        _run.device(settings)

    def record(self, scene: Scene, settings: MujocoWarpSettings) -> dict[str, Any]:
        """MuJoCo's record, and what computed the run: precision, device, versions."""
        from .worlds import warp_modules

        return {**mujoco_common.record(scene, settings), "precision": settings.precision, "device": _run.device(settings),
                "mujoco_warp_version": version_of("mujoco-warp"), "warp_version": warp_modules()[0].__version__}

    def contact_scales(self, scene: Scene, settings: MujocoWarpSettings) -> tuple[float, float]:
        """MuJoCo's (``mujoco_common.contact_scales``): the same model."""
        return mujoco_common.contact_scales(scene, settings)

    def run_batch(self, jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> list[Trajectory]:
        """Compatible runs as the worlds of one MuJoCo Warp model (``run.roll_batch``)."""
        return _run.roll_batch(self, list(jobs))

    def bare_seconds(self, scene: Scene, settings: MujocoWarpSettings, traj: Trajectory) -> float:
        """The bare ``mujoco_warp.step`` loop, one world (``run.bare_seconds``)."""
        return _run.bare_seconds(scene, settings)

    def build(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> Any:
        """The compiled ``MjModel`` MuJoCo Warp is given (before ``worlds.warp_model``)."""
        return mujoco_common.build(scene, settings or MujocoWarpSettings())

    def snippet(self, scene: Scene, settings: MujocoWarpSettings | None = None) -> str:
        """The scene's model as MJCF (``mujoco_common.export_mjcf``), to load with ``mujoco_warp.put_model``."""
        return mujoco_common.export_mjcf(scene, settings or MujocoWarpSettings())


def run(scene: Scene, settings: MujocoWarpSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """``MujocoWarpEngine().run``: one run, classified by the base (``base.EngineAdapter.run``)."""
    return MujocoWarpEngine().run(scene, settings, compact_above)


def run_batch(jobs: Sequence[tuple[Scene, MujocoWarpSettings]]) -> list[Trajectory]:
    """``MujocoWarpEngine().run_batch``: compatible runs together, each as it runs alone."""
    return MujocoWarpEngine().run_batch(jobs)
