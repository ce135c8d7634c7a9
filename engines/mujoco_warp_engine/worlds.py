"""Many runs as one MuJoCo Warp model of many worlds, on the warp device the settings ask for: one compile, one put.

    >>> from chatterbench.engines.mujoco_warp_engine.worlds import device_name, put_worlds
    >>> from chatterbench.engines.mujoco_common import prepare
    >>> from chatterbench.engines.mujoco_engine import MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> runs = [prepare(load_scene("bouncing-ball", [f"restitution={r}"]), MujocoSettings(dt=dt), 10)
    ...         for r, dt in ((0.5, 1e-3), (0.8, 1e-3), (0.5, 1e-4))]
    >>> worlds = put_worlds(runs, device_name("cpu"))
    >>> worlds.nworld, worlds.varying           # R enters the contact's damping; dt the timestep
    (3, ('opt.timestep', 'jnt_solref'))

A batch's runs share their compiled structure (``mujoco_engine.compiled``: one MjSpec
compile for every run that differs only in start, length, dt, w0 dt and R), and
``put_worlds`` puts each structure on the device once (``mujoco_warp.put_model`` of
``warp_model``'s copy, kept per device) and sets the per-world values on the device: every
world's timestep and contact solref (``Prepared.law``) as per-world rows of MuJoCo Warp's
``opt.timestep`` and ``jnt_solref`` / ``geom_solref`` (fields with a leading ``*``
dimension). Runs of different structures (masses, springs, gap) stack the fields in which
their structures differ, one row per world, wherever MuJoCo Warp keeps them per world.

Promises: world i is run i's model exactly: its device fields are those of
``mujoco_warp.put_model(warp_model(model_i))`` bit for bit, model_i the run's own
compiled model (``tests/engines/test_mujoco_warp.py`` compares them field by field); a
difference in a field MuJoCo Warp shares between worlds is ``Incompatible`` (the caller runs
those apart); no model is changed (the kept device models are copied before rows are set).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from dataclasses import dataclass
from typing import Any, Sequence

import mujoco
import numpy as np

from ..mujoco_common import Prepared
from ..mujoco_engine.compiled import Kept

MOST_DEVICE_MODELS = 16  # structures kept on a device (a few kB of device memory each)
_DEVICE_MODELS = Kept(MOST_DEVICE_MODELS)


@functools.cache
def warp_modules() -> tuple[Any, Any]:
    """``(warp, mujoco_warp)``, imported on first use and warp initialised; warp's log keeps its warnings only (its
    banner and one "Module ... load" line per kernel would otherwise interleave with every table)."""
    import warp as wp

    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)
    import mujoco_warp as mjw

    wp.init()
    return wp, mjw


def _counted_here() -> int:
    """CUDA devices warp finds, asked in this process (which then holds a CUDA context if there is a GPU)."""
    import warp as wp

    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)
    wp.init()
    return int(wp.get_cuda_device_count())


@functools.cache
def gpu_count() -> int:
    """CUDA devices warp finds. Asked in a forked child unless warp is already initialised here: a process that
    only asks (a sweep choosing its units, a progress note) holds no CUDA context, which a fork would break for
    the workers it starts afterwards; 0 where the child fails."""
    import sys

    from ..isolate import run_isolated

    if "warp" in sys.modules:
        try:
            from warp._src import context  # where warp keeps its runtime (None until ``wp.init``)
        except ImportError:  # another layout: ask in a child, as below
            context = None
        if getattr(context, "runtime", None) is not None:
            return _counted_here()
    outcome = run_isolated(_counted_here, timeout=120.0)
    return int(outcome.value) if outcome.status == "ok" else 0


def device_name(requested: str) -> str:
    """The warp device for settings ``device`` ``"auto"``, ``"cpu"`` or ``"cuda"``: ``"cuda"`` when asked for
    or, for ``"auto"``, when warp finds a GPU (``gpu_count``); else ``"cpu"``. Raises ``RuntimeError`` for
    ``"cuda"`` without one."""
    if requested == "cpu":
        return "cpu"
    gpus = gpu_count()
    if requested == "cuda" and not gpus:
        raise RuntimeError("mujoco_warp.device = 'cuda': warp finds no CUDA device here (use 'cpu' or 'auto')")
    return "cuda" if gpus else "cpu"


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
    """Runs that cannot share one MuJoCo Warp model: their structures differ in a field that is not per world."""


@dataclass(frozen=True)
class Worlds:
    """One MuJoCo Warp model of ``nworld`` worlds on ``device``; ``varying`` names the per-world fields set."""

    model: Any  # mujoco_warp.Model
    nworld: int
    device: str
    varying: tuple[str, ...]
    rows: tuple[str, ...] = ()  # the fields set per world from each run's law: timestep, the contact's solref
    base: Any = None  # the kept device model every other field is from (None: rows of several structures stacked)


def device_model(model: mujoco.MjModel, device: str) -> Any:
    """``mujoco_warp.put_model(warp_model(model))`` on ``device``, kept per (model, device): never change it."""
    wp, mjw = warp_modules()

    def put() -> Any:
        with wp.ScopedDevice(device):
            return mjw.put_model(warp_model(model))

    return _DEVICE_MODELS.get((model, device), put)


def put_worlds(ps: Sequence[Prepared], device: str) -> Worlds:
    """The runs ``ps`` (``mujoco_common.prepare``: compiled structure, timestep and solref) as one MuJoCo Warp model
    of ``len(ps)`` worlds on ``device`` (module docstring). Raises ``Incompatible`` when their structures differ in a
    field MuJoCo Warp shares between worlds."""
    wp, _ = warp_modules()
    structures: dict[int, Any] = {}
    index = [structures.setdefault(id(p.structure), len(structures)) for p in ps]
    uniques = list({id(p.structure): p.structure for p in ps}.values())
    if len({st.solref for st in uniques}) > 1:
        raise Incompatible("the runs hold their contact in different fields (a joint limit and geoms)")
    with wp.ScopedDevice(device):
        kept = [device_model(st.model, device) for st in uniques]
        model = copied(kept[0])
        varying: list[str] = []
        if len(kept) > 1:
            _stack(model, kept, index, device, "", varying)
        _set_rows(model, "opt.timestep", np.array([p.law[0] for p in ps]), device, varying)
        st = uniques[0]
        rows = np.stack([u.model.__getattribute__(st.solref) for u in uniques])[index]  # (nworld, n, 2) float64
        rows[:, st.rows] = np.array([p.law[1:] for p in ps])[:, None, :]
        _set_rows(model, st.solref, rows, device, varying)
    law = ("opt.timestep", st.solref)
    return Worlds(model, len(ps), device, tuple(varying), law, kept[0] if set(varying) <= set(law) else None)


def copied(obj: Any) -> Any:
    """A copy of a mujoco_warp dataclass and of the dataclasses in it, sharing their arrays (rows are then set on the
    copy, never on a kept model)."""
    out = copy.copy(obj)
    for f in dataclasses.fields(out):
        value = getattr(out, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            setattr(out, f.name, copied(value))
    return out


def _set_rows(model: Any, path: str, values: np.ndarray, device: str, varying: list[str]) -> None:
    """Field ``path`` of ``model`` as one row per world (``values``: shape (nworld, ...)), or one shared row when the
    worlds agree; converted to the field's dtype as ``put_model`` converts MuJoCo's float64 (``wp.array``)."""
    wp, _ = warp_modules()
    old = field(model, path)
    same = bool((values == values[:1]).all())
    rows = values[:1] if same else values
    new = wp.array(np.ascontiguousarray(rows), dtype=old.dtype, shape=(len(rows), *old.shape[1:]), device=device)
    new._is_batched = True  # as mujoco_warp marks its per-world arrays
    set_field(model, path, new)
    if not same:
        varying.append(path)


def field(obj: Any, path: str) -> Any:
    """The attribute at dotted ``path`` of ``obj`` (``"opt.timestep"``: ``obj.opt.timestep``)."""
    return functools.reduce(getattr, path.split("."), obj)


def set_field(obj: Any, path: str, value: Any) -> None:
    """Set the attribute at dotted ``path`` of ``obj`` to ``value``."""
    *outer, name = path.split(".")
    setattr(field(obj, ".".join(outer)) if outer else obj, name, value)


def _per_world(spec: Any) -> bool:
    shape = getattr(spec, "shape", ())
    return bool(shape) and shape[0] == "*"


def _stack(first: Any, uniques: list[Any], index: list[int], device: str, path: str, varying: list[str]) -> None:
    """Make ``first`` (a copy of ``uniques[0]``, ``_copied``) hold world w's rows from ``uniques[index[w]]``
    wherever the unique models differ (recursively)."""
    wp, _ = warp_modules()
    from mujoco_warp._src import warp_util

    for f in dataclasses.fields(first):
        mine, theirs = getattr(first, f.name), [getattr(u, f.name) for u in uniques[1:]]
        name = f"{path}{f.name}"
        if dataclasses.is_dataclass(mine) and not isinstance(mine, type):
            _stack(mine, [getattr(uniques[0], f.name), *theirs], index, device, f"{name}.", varying)
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
