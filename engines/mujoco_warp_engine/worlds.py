"""Many MuJoCo models as one MuJoCo Warp model of many worlds, on the warp device the settings ask for.

    >>> from chatterbench.engines.mujoco_warp_engine.worlds import device_name, put_worlds, warp_model
    >>> from chatterbench.engines.mujoco_common import build
    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> models = [warp_model(build(load_scene("bouncing-ball", [f"restitution={r}"]), MujocoSettings(dt=1e-3)))
    ...           for r in (0.5, 0.8)]
    >>> worlds = put_worlds(models, device_name("cpu"))
    >>> worlds.varying                                   # R enters the contact's damping: one value per world
    ('jnt_solref',)

``warp_model`` adapts the MuJoCo engine's compiled model (``mujoco_engine.model.build``,
the same MjSpec, contact law and forces) to what MuJoCo Warp accepts; ``put_worlds`` puts
a list of such models on the device as one ``mujoco_warp.Model`` whose per-world fields
(MuJoCo Warp's fields with a leading ``*`` dimension: masses, joint ranges, solref, springs,
the timestep) hold one row per model, so that one ``mujoco_warp.step`` advances them all.

Promises: world i is model i exactly (every field that differs between the models is a
per-world field, checked field by field; a difference anywhere else is ``Incompatible`` and
the caller runs those models apart); the models are not changed.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np



@functools.cache
def warp_modules() -> tuple[Any, Any]:
    """``(warp, mujoco_warp)``, imported on first use; warp's log keeps its warnings only (its banner and
    one "Module ... load" line per kernel would otherwise interleave with every table)."""
    import warp as wp

    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)
    import mujoco_warp as mjw

    wp.init()
    return wp, mjw


def device_name(requested: str) -> str:
    """The warp device for settings ``device`` ``"auto"``, ``"cpu"`` or ``"cuda"``: ``"cuda"`` when asked for
    or, for ``"auto"``, when warp finds a GPU; else ``"cpu"``. Raises ``RuntimeError`` for ``"cuda"`` without one."""
    wp, _ = warp_modules()
    gpus = wp.get_cuda_device_count()
    if requested == "cuda" and not gpus:
        raise RuntimeError("mujoco_warp.device = 'cuda': warp finds no CUDA device here (use 'cpu' or 'auto')")
    return "cuda" if requested == "cuda" or (requested == "auto" and gpus) else "cpu"


def warp_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of the MuJoCo engine's model that MuJoCo Warp accepts and steps as fast as it can, same physics.

    - autoreset: MuJoCo Warp never resets a world (it has no autoreset to disable, and refuses
      the flag), so the MuJoCo engine's "disable autoreset" is dropped, not its meaning;
    - contacts: with the gap as a joint limit the model has no geoms, so collision detection
      is disabled (on the CPU device its kernels are half of a step's cost); the geom gap
      model keeps it.
    """
    out = model.__copy__()
    out.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    if model.ngeom == 0:
        out.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return out


class Incompatible(ValueError):
    """Models that cannot share one MuJoCo Warp model: they differ in a field that is not per world."""


@dataclass(frozen=True)
class Worlds:
    """One MuJoCo Warp model of ``nworld`` worlds on ``device``; ``varying`` names the per-world fields that differ."""

    model: Any  # mujoco_warp.Model
    nworld: int
    device: str
    varying: tuple[str, ...]


def _per_world(spec: Any) -> bool:
    shape = getattr(spec, "shape", ())
    return bool(shape) and shape[0] == "*"


def _stack(first: Any, uniques: list[Any], index: list[int], device: str, path: str, varying: list[str]) -> None:
    """Make ``first`` (a mujoco_warp dataclass, ``uniques[0]``) hold world w's rows from ``uniques[index[w]]``
    wherever the unique models differ (recursively)."""
    wp, _ = warp_modules()
    from mujoco_warp._src import warp_util

    for f in dataclasses.fields(first):
        mine, theirs = getattr(first, f.name), [getattr(u, f.name) for u in uniques[1:]]
        name = f"{path}{f.name}"
        if dataclasses.is_dataclass(mine) and not isinstance(mine, type):
            _stack(mine, [mine, *theirs], index, device, f"{name}.", varying)
        elif all(_same(mine, t) for t in theirs):
            continue
        elif isinstance(mine, wp.array) and warp_util.is_array_spec(f.type) and _per_world(f.type):
            rows = [mine.numpy()] + [t.numpy() for t in theirs]
            stacked = wp.array(np.concatenate([rows[i] for i in index]), dtype=mine.dtype, device=device)
            stacked._is_batched = True  # as mujoco_warp marks its per-world arrays
            setattr(first, f.name, stacked)
            varying.append(name)
        else:
            raise Incompatible(f"field {name} differs between the models and is not per world")


def _same(a: Any, b: Any) -> bool:
    """Equal values of a shared (not per-world) field: arrays by content, sequences item by item."""
    wp, _ = warp_modules()
    if isinstance(a, wp.array):
        return isinstance(b, wp.array) and a.shape == b.shape and np.array_equal(a.numpy(), b.numpy(), equal_nan=True)
    if isinstance(a, (tuple, list)):
        return isinstance(b, (tuple, list)) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, (int, float, str, bool, type(None), np.ndarray)):
        return bool(np.array_equal(a, b))
    return True  # kernels, callbacks: made from the model's structure, which the sizes already fix


def _fingerprint(model: mujoco.MjModel) -> bytes:
    """The model's MJB bytes, hashed: equal for models compiled alike (a batch's copies share one device model)."""
    buf = np.empty(mujoco.mj_sizeModel(model), np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return hashlib.sha256(buf.tobytes()).digest()


def put_worlds(models: list[mujoco.MjModel], device: str) -> Worlds:
    """The models (``warp_model`` output, one per world) as one MuJoCo Warp model on ``device``.

    Equal models are put on the device once. Raises ``Incompatible`` when they differ in a
    field MuJoCo Warp shares between worlds.
    """
    wp, mjw = warp_modules()
    keys: dict[bytes, int] = {}
    index = [keys.setdefault(_fingerprint(m), len(keys)) for m in models]
    firsts = {k: models[index.index(k)] for k in range(len(keys))}
    with wp.ScopedDevice(device):
        uniques = [mjw.put_model(firsts[k]) for k in range(len(keys))]
        varying: list[str] = []
        if len(uniques) > 1:
            _stack(uniques[0], uniques, index, device, "", varying)
    return Worlds(uniques[0], len(models), device, tuple(varying))
