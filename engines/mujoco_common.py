"""What the two MuJoCo adapters share: a scene's compiled model and initial state, its controls, its record, its samples.

    >>> from chatterbench.engines.mujoco_common import prepare, rollout_controls
    >>> from chatterbench.engines.mujoco_engine.settings import MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> p = prepare(load_scene("feigin-pair"), MujocoSettings(dt=1e-3), n=10)
    >>> p.nstep, rollout_controls(p, 0, p.nstep).shape      # steps rolled, (1, steps, controls)
    (11, (1, 11, 1))

MuJoCo (``mujoco_engine``, ``mujoco.rollout`` in float64) and MuJoCo Warp
(``mujoco_warp_engine``, warp kernels in float32) run the same model (``mujoco_engine.model``:
the MjSpec, contact law, forces, controls) and read their samples the same way: rows of
rollout's layout (time, qpos, qvel) and the sensors at the start of each step, yielded to the
base as ``wholerun.Samples`` (``take``). Both import these pieces from here, never from each other.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from chatterbench.reference.scene import Scene

from .wholerun import Samples
from .restitution import contact_duration

if TYPE_CHECKING:
    from .mujoco_engine.compiled import Structure
    from .mujoco_engine.settings import MujocoSettings

__all__ = ["Prepared", "WARNINGS", "build", "build_spec", "contact_scales", "export_mjcf", "prepare", "quiet_log", "record",
           "rollout_controls", "structure", "take", "warned", "warning_note"]

WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")  # MuJoCo's warnings of a blow-up
_WARNING_INDEX = tuple(int(getattr(mujoco.mjtWarning, w)) for w in WARNINGS)


# The model's modules are imported when first used: ``mujoco_engine`` imports this module as it loads.
def build(scene: Scene, s: MujocoSettings) -> mujoco.MjModel:
    """The compiled model of ``scene`` (``mujoco_engine.model.build``)."""
    from .mujoco_engine.model import build as build_model

    return build_model(scene, s)


def build_spec(scene: Scene, s: MujocoSettings) -> mujoco.MjSpec:
    """The model's MjSpec; SettingsError for settings the scene cannot run with (``mujoco_engine.model``)."""
    from .mujoco_engine.model import build_spec as spec

    return spec(scene, s)


def structure(scene: Scene, s: MujocoSettings) -> Structure:
    """The scene's compiled structure, shared by runs that differ in start, length and contact law
    (``mujoco_engine.compiled``); SettingsError, as ``build_spec``, for settings the scene cannot run with."""
    from .mujoco_engine.compiled import structure as compiled_structure

    return compiled_structure(scene, s)


def export_mjcf(scene: Scene, s: MujocoSettings) -> str:
    """The scene's model as a complete MJCF file (``mujoco_engine.export``)."""
    from .mujoco_engine.export import export_mjcf as export

    return export(scene, s)


@contextlib.contextmanager
def quiet_log():
    """Silence MuJoCo's console and MUJOCO_LOG.TXT warnings while stepping: a blow-up is
    reported in the Trajectory (status, message with the warning names) instead."""
    saved = mujoco.MjLogConfig.get()
    quiet = mujoco.MjLogConfig.get()
    quiet.logto_console, quiet.logto_file = False, False
    quiet.set()
    try:
        yield
    finally:
        saved.set()


@dataclass
class Prepared:
    """A run's model with everything ``rollout`` needs, made before the clock starts (no compile, no MjData:
    ``mujoco_engine.compiled``)."""

    scene: Scene
    settings: MujocoSettings
    structure: Structure  # the compiled structure it shares with runs that differ in start, length and contact law
    law: tuple[float, float, float]  # its timestep [s] and contact solref (``compiled.contact``)
    initial_state: np.ndarray  # (1, nstate), rollout's layout
    control_spec: int
    nstep: int  # steps rolled out: n + 1 (the last gives the final sample's sensors)

    @property
    def model(self) -> mujoco.MjModel:
        """The run's compiled model (``compiled.shared_model``: shared, not to be changed)."""
        return variant_model(self.structure, self.law)


def prepare(scene: Scene, s: MujocoSettings, n: int) -> Prepared:
    """The model of ``scene`` (its shared structure and contact law), its initial state, rollout's control layout,
    for ``n`` steps."""
    from .mujoco_engine.compiled import contact, initial_state, structure

    st = structure(scene, s)
    model = st.model
    control_spec = 0
    if model.nu:
        control_spec |= mujoco.mjtState.mjSTATE_CTRL
    if model.nmocap:
        control_spec |= mujoco.mjtState.mjSTATE_MOCAP_POS
    return Prepared(scene, s, st, contact(scene, s, st), initial_state(st, scene),
                    int(control_spec) or int(mujoco.mjtState.mjSTATE_CTRL), n + 1)


def variant_model(st: Structure, law: tuple[float, float, float]) -> mujoco.MjModel:
    """The structure ``st`` with timestep and solref ``law``, kept (``compiled.shared_model``)."""
    from .mujoco_engine.compiled import kept_variant

    return kept_variant(st, law)


def rollout_controls(p: Prepared, k0: int, k1: int) -> np.ndarray | None:
    """Rollout's control input for steps k0 .. k1 - 1, shape (1, k1 - k0, ncontrol), or None (no controls)."""
    t = p.scene.initial.t + p.settings.dt * np.arange(k0, k1)  # = sample_times(scene, dt)[k0:k1], bit for bit
    from .mujoco_engine.model import controls

    parts = []
    model = p.structure.model  # sizes: every variant's
    if model.nu:
        parts.append(controls(p.scene, p.settings, t))
    if model.nmocap:  # mocap_pos comes after ctrl in mjtState order; held over step k at x1(t_{k})
        mpos = np.zeros((len(t), 3))
        mpos[:, 0] = p.scene.prescribed.position(t)
        parts.append(mpos)
    return np.ascontiguousarray(np.concatenate(parts, axis=1)[None]) if parts else None


def record(scene: Scene, s: MujocoSettings) -> dict[str, Any]:
    """What the settings record adds, by MuJoCo's names: the solref / solimp the settings make."""
    zeta = s.zeta(scene.restitution)
    return {"w0": s.w0, "zeta": zeta, "solref": [-s.w0**2, -2.0 * zeta * s.w0],
            "solimp": [s.impedance, s.impedance, 0.001, 0.5, 2.0], "mujoco_version": mujoco.__version__}


def contact_scales(scene: Scene, s: MujocoSettings) -> tuple[float, float]:
    """One bounce's duration [s] and the natural frequency w0 [rad/s] of the soft contact."""
    return contact_duration(s.zeta(scene.restitution), s.w0), s.w0


def take(p: Prepared, k0: int, before: np.ndarray, state: np.ndarray, sensordata: np.ndarray) -> Samples:
    """Samples k0 .. k0 + c - 1 of the run ``p`` (the base records them) from ``before`` (the state at sample k0),
    ``state`` (c rows of rollout's layout: time, qpos, qvel after each step) and ``sensordata`` (c rows, at the
    start of each step, i.e. at the samples). A sensor that is not finite or a time that went back (a reset) is a blow-up."""
    scene, s, nq = p.scene, p.settings, p.structure.model.nq
    c = len(state)
    rows = np.concatenate([before[None], state[:c - 1]])  # the state at samples k0 .. k0 + c - 1
    qpos, qvel, sens = rows[:, 1:1 + nq], rows[:, 1 + nq:1 + 2 * nq], sensordata
    t = scene.initial.t + s.dt * np.arange(k0, k0 + c)  # = sample_times(scene, dt)[k0:k0 + c]
    t_end = scene.initial.t + s.dt * (p.nstep - 1)
    slack = 1e-6 * max(s.dt, abs(t_end) * 1e-3)  # [s] a reset would rewind time
    bad = ~np.isfinite(sens).all(axis=1) | (np.abs(rows[:, 0] - t) > slack)
    y, vy = qpos[:, -1], qvel[:, -1]
    walls = scene.gap.walls
    if s.gap_model == "limit":
        f = np.maximum(sens[:, 0], 0.0)
        if len(walls) == 2:
            upper_side = y > 0.5 * (scene.gap.lower + scene.gap.upper)  # only the wall y is beyond can push
            force = {"lower": np.where(upper_side, 0.0, f), "upper": np.where(upper_side, f, 0.0)}
        else:
            force = {"lower": f}
    else:
        force = {w: np.maximum(sens[:, 3 * i], 0.0) for i, w in enumerate(walls)}
    body1 = {} if scene.body1_infinite else {"x1": qpos[:, 0], "v1": qvel[:, 0]}
    return Samples(t, force, y=y, vy=vy, bad=bad, **body1)


def warned(data: mujoco.MjData) -> set[str]:
    """The blow-up warnings MuJoCo raised on ``data``."""
    number = data.warning.number  # a view of every warning's count
    return {w for w, i in zip(WARNINGS, _WARNING_INDEX) if number[i] > 0}


def warning_note(names: set[str], s: MujocoSettings) -> str:
    """The message of a run MuJoCo warned about: the warnings and the settings that set its stiffness."""
    return (f"MuJoCo warnings: {', '.join(sorted(names, key=WARNINGS.index)) or 'none'}; "
            f"w0_dt = {s.w0_dt}, integrator = {s.integrator}")
