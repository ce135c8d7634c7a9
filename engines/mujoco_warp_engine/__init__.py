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
``device``), ``worlds`` (many runs as one MuJoCo Warp model of many worlds: one compiled
structure, per-world timestep and solref set on the device), ``kernels`` (the step and the
per-step recording: kernels loaded and timed, steps captured as a graph and replayed),
``rigs`` (a block's device set-up and captured steps, kept per process for the next block of its shape),
``samples`` (controls out and samples back, per chunk, for all worlds at once), ``batch``
(compatible runs grouped, in blocks within the host's memory), ``run`` (the adapter).

What to expect: the first run on a machine compiles MuJoCo Warp's kernels for its device
(about a minute on the CPU device, minutes on a GPU; warp caches them under
``~/.cache/warp``). With the steps captured as a graph (CUDA, and the CPU device from warp
1.17), one world steps at about 10,000 steps/s through the adapter on the CPU device of the
2-core machine this was written on, and a batch of 1,024 worlds at about 230,000
world-steps/s (``chatterbench bench sweep --only warp``); on a GPU a step of thousands of
worlds costs about what one costs, so the engine pays off in batches (``run_batch``: a sweep
unit's compatible points, up to 4,096 worlds on cuda).
"""

from __future__ import annotations

from .run import MujocoWarpEngine, world_steps_per_s
from .settings import DEVICES, PRECISIONS, MujocoWarpSettings

__all__ = ["DEVICES", "PRECISIONS", "MujocoWarpEngine", "MujocoWarpSettings", "world_steps_per_s"]
