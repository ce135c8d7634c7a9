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
``run`` (the adapter: whole runs as worlds stepped together, each world's samples handed to its
run as MuJoCo's are handed over).

What to expect: the first run on a machine compiles MuJoCo Warp's kernels (about a minute on
the CPU device; warp caches them under ``~/.cache/warp``). On the CPU device a step of any
number of worlds up to a few hundred costs about the same (1.5 to 3 ms on the 2-core machine
this was written on: each of its ~90 kernel launches costs Python time), so the engine is
slow for one run and pays off in batches (``run_batch``: a sweep unit's compatible points).
"""

from __future__ import annotations

from .run import MujocoWarpEngine, world_steps_per_s
from .settings import DEVICES, PRECISIONS, MujocoWarpSettings

__all__ = ["DEVICES", "PRECISIONS", "MujocoWarpEngine", "MujocoWarpSettings", "world_steps_per_s"]
