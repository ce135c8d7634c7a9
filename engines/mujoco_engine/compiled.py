"""Compiled models shared by runs: one MjSpec compile per model structure, its timestep and contact law set per run.

    >>> from chatterbench.engines.mujoco_engine.compiled import shared_model, structure
    >>> from chatterbench.engines.mujoco_engine.settings import MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> a, b = load_scene("bouncing-ball"), load_scene("bouncing-ball", ["initial.y=0.5", "duration=0.2"])
    >>> shared_model(a, MujocoSettings(dt=1e-3)) is shared_model(b, MujocoSettings(dt=1e-3))   # a strike, a drop
    True
    >>> structure(a, MujocoSettings(dt=1e-3)) is structure(a, MujocoSettings(dt=1e-4, w0_dt=0.3))  # one compile
    True

A scene's MuJoCo model (``model.build_spec``) depends on the run's start (t0, x1, v1, y, vy)
and length only through an infinite body 1's place, and on ``dt``, ``w0_dt`` and R only
through ``opt.timestep`` and the contact's ``solref``: the compiler derives nothing from
either (the impedance factor d / d' of ``model._impedance_factor`` depends on solimp and
the masses, not on solref). So the runs of a strike study, a sweep over initial phase or a
dt x w0 dt map need not compile a model each:

- ``structure(scene, s)``: the compiled model of everything but the contact law and the
  timestep (``structure_key``: the scene without its name, description, start, length and
  R; the settings without dt, w0 dt, ``plastic_zeta_w0_dt`` and ``allow_unstable``), built
  once (two compiles: ``build_spec``'s impedance probe and the model) and kept
  (``MOST_STRUCTURES``, least recently used dropped first);
- ``contact(scene, s)``: a run's timestep [s] and contact solref (-k d/d', -b d/d'), from
  ``model.contact_law`` (which refuses an unstable w0 dt), the arithmetic ``build_spec`` does;
- ``shared_model(scene, s)``: the structure with that timestep and solref, a copy made once
  per (structure, timestep, solref) and kept (``MOST_VARIANTS``): MuJoCo C's runs;
- ``initial_state(st, scene)``: a run's full physics state (``mjSTATE_FULLPHYSICS``) at
  its start, the structure's fresh-MjData state with t0, qpos and qvel written in.

Promises: ``shared_model(scene, s)`` is ``model.build(scene, s)`` byte for byte (its MJB,
``mujoco.mj_saveModel``) except for the model's name, which is the first scene's
(``tests/engines/test_mujoco.py`` checks it over dt, w0 dt, R, integrators, gap models and
impedances); the models handed out are shared and must not be changed (MuJoCo Warp copies
before it adapts one, ``mujoco_warp_engine.worlds.warp_model``).
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Callable

import mujoco
import numpy as np

from chatterbench.reference.scene import Scene

from .model import compiled, contact_law, spec_and_factor
from .settings import MujocoSettings

MOST_STRUCTURES = 64  # compiled structures kept (a few kB each)
MOST_VARIANTS = 256  # (structure, timestep, solref) models kept for MuJoCo C's runs
_NOT_IN_STRUCTURE = ("name", "description", "initial", "duration", "restitution")  # Scene fields
_CONTACT_SETTINGS = ("dt", "w0_dt", "plastic_zeta_w0_dt", "allow_unstable")  # MujocoSettings fields
_SCENE_PARTS = tuple(f.name for f in dataclasses.fields(Scene) if f.name not in _NOT_IN_STRUCTURE)
_SETTINGS_PARTS = tuple(f.name for f in dataclasses.fields(MujocoSettings) if f.name not in _CONTACT_SETTINGS)


@dataclass(frozen=True, eq=False)
class Structure:
    """A scene's compiled model (never changed), what its contact law sets, and its initial state layout."""

    model: mujoco.MjModel  # compiled with the first run's timestep and solref
    factor: float  # [-] d / d', the impedance rescaling of solref (``model._impedance_factor``)
    solref: str  # the model field holding the contact's solref: "jnt_solref" (gap as a limit) or "geom_solref"
    rows: np.ndarray  # the rows of that field that are the contact's (int)
    state0: np.ndarray  # a fresh MjData's mjSTATE_FULLPHYSICS state, shape (nstate,)


class Kept:
    """A small thread-safe least-recently-used table: ``get(key, make)`` returns the kept value or makes it."""

    def __init__(self, most: int) -> None:
        self.most, self.items, self.lock = most, OrderedDict(), threading.Lock()

    def get(self, key: Any, make: Callable[[], Any]) -> Any:
        with self.lock:
            if key in self.items:
                self.items.move_to_end(key)
                return self.items[key]
        value = make()  # outside the lock: a compile takes milliseconds; two threads may make the same one
        with self.lock:
            self.items[key] = value
            while len(self.items) > self.most:
                self.items.popitem(last=False)
        return value


_STRUCTURES, _VARIANTS = Kept(MOST_STRUCTURES), Kept(MOST_VARIANTS)


def structure_key(scene: Scene, s: MujocoSettings) -> tuple:
    """What a scene's compiled model depends on besides its contact law and timestep (module docstring): hashable."""
    body1 = (scene.initial.x1,) if scene.body1_infinite else ()  # a fixed body 1's place, a mocap body's start
    return (type(scene), *(getattr(scene, name) for name in _SCENE_PARTS), *body1,
            *(getattr(s, name) for name in _SETTINGS_PARTS))


def _make_structure(scene: Scene, s: MujocoSettings) -> Structure:
    spec, factor = spec_and_factor(scene, s)
    model = compiled(spec, scene)
    if s.gap_model == "limit":
        field, rows = "jnt_solref", np.array([model.joint("y").id])
    else:  # every geom: the walls and the ball (``build_spec``)
        field, rows = "geom_solref", np.arange(model.ngeom)
    spec_state = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec_state))
    mujoco.mj_getState(model, mujoco.MjData(model), state0, spec_state)
    return Structure(model, factor, field, rows, state0)


def structure(scene: Scene, s: MujocoSettings, key: tuple | None = None) -> Structure:
    """The compiled structure of ``scene`` at ``s`` (kept: module docstring; ``key``: its ``structure_key`` when
    known); SettingsError, as ``build_spec``, for settings the scene cannot run with (an unstable w0 dt is refused
    here too, before anything compiles)."""
    contact_law(scene, s)
    return _STRUCTURES.get(structure_key(scene, s) if key is None else key, lambda: _make_structure(scene, s))


def contact(scene: Scene, s: MujocoSettings, st: Structure) -> tuple[float, float, float]:
    """A run's timestep [s] and contact solref (-k d/d' [1/s^2], -b d/d' [1/s]) as ``build_spec`` writes them."""
    k, b = contact_law(scene, s)
    return s.dt, -(k * st.factor), -(b * st.factor)


def shared_model(scene: Scene, s: MujocoSettings) -> mujoco.MjModel:
    """``model.build(scene, s)``, compiled once per structure and kept per timestep and solref; do not change it."""
    st = structure(scene, s)
    return kept_variant(st, contact(scene, s, st))


def kept_variant(st: Structure, law: tuple[float, float, float]) -> mujoco.MjModel:
    """``variant(st, law)``, made once and kept (``MOST_VARIANTS``) while ``st`` is kept: the key holds ``st`` itself
    (compared by identity), so a variant never outlives its structure's identity."""
    return _VARIANTS.get((st, law), lambda: variant(st, law))


def variant(st: Structure, law: tuple[float, float, float]) -> mujoco.MjModel:
    """A copy of ``st.model`` with timestep and solref ``law`` (``contact``)."""
    model = st.model.__copy__()
    model.opt.timestep = law[0]
    getattr(model, st.solref)[st.rows] = law[1:]
    return model


def initial_state(st: Structure, scene: Scene) -> np.ndarray:
    """The full physics state [rollout's layout: time, qpos, qvel, ...] of ``scene.initial``, shape (1, nstate)."""
    ini, nq = scene.initial, st.model.nq
    state = st.state0.copy()
    state[0] = ini.t
    if scene.body1_infinite:
        state[1], state[1 + nq] = ini.y, ini.vy
    else:
        state[1:3] = ini.x1, ini.y
        state[1 + nq:3 + nq] = ini.v1, ini.vy
    return state[None]
