"""Stepping Newton: two adapters, ``newton_xpbd`` and ``newton_semi``, one world each run, one captured step per step.

    >>> from chatterbench.engines.newton_engine import NewtonXpbdEngine, XpbdSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = NewtonXpbdEngine().run(load_scene("bouncing-ball", ["duration=0.5"]), XpbdSettings(dt=1e-3, device="cpu"))
    >>> traj.status, traj.settings["precision"], traj.settings["kernels"] in ("compiled", "cached")
    ('ok', 'float32', True)

The base owns the run (``stepping.py``: forces, samples, time); an adapter builds the world
(``world.build``) and steps it: the base's forces into ``body_f`` (the weights Newton's model
adds taken off), one launch of the captured step, the state read back. Sample k is the state
after k steps. What each wall pushed body 2 with in a step:

- XPBD: its contacts are position corrections and a velocity pass, so the push is read from body
  2's momentum: m2 (v2_after - v2_before - f2 dt / m2) / dt, beyond float32 rounding
  (``IMPULSE_RELATIVE_TOLERANCE``, ``IMPULSE_ABSOLUTE_TOLERANCE``); its sign names the wall (the
  lower wall pushes toward +x, the upper toward -x).
- semi-implicit: the penalty force Newton's kernel evaluates from the state at the step's start,
  ke (-d) + kd max(-vn, 0) where d = y - lower < 0 (upper - y for the upper wall), vn the approach speed.

The kernels are loaded before a run's clock starts (``record``: ``world.load_kernels``, once per
process and solver; compiled the first time on a machine), and the record says how long that
took (``warmup_s``) and whether they were ``compiled`` or ``cached``.
"""

from __future__ import annotations

import math
from typing import Any

from chatterbench.reference.scene import Scene

from ..api import EngineAdapter, SettingsError
from .penalty import contact_duration, ke_kd, relative_mass
from .settings import SemiSettings, XpbdSettings
from .world import IMPULSE_ABSOLUTE_TOLERANCE, IMPULSE_RELATIVE_TOLERANCE, World, build, device_name, load_kernels, modules


FIRST_RUN = ("the first run on a machine compiles Newton's {solver} kernels for warp's device ({cold} on a 2-core CPU, "
             "minutes when it is loaded; cached by warp under ~/.cache/warp, then loaded in under a second)")


class _Newton(EngineAdapter):
    """What the two solvers share: the package, float32, the kernels loaded before the clock, the device."""

    package = "newton"
    precision = "float32"
    # [B] per step: measured 11 B (feigin-pair, 4.0e5 -> 8.0e5 steps: 341,768 -> 346,052 KiB peak; warp and newton are
    # 340 MB of it), kept at PyBullet's 125 for the base's recording of a run that is not compacted
    bytes_per_step = 125.0
    solver: str = ""

    def build(self, scene: Scene, settings: Any) -> World:
        """The scene's world (``world.build``), its step captured."""
        w = build(scene, settings, self.solver)
        w.m2, w.lower = scene.mass2, scene.gap.lower
        w.upper = scene.gap.upper if scene.gap.upper is not None else math.inf
        w.two = scene.gap.upper is not None
        w.x1, w.v1 = scene.initial.x1, scene.initial.v1  # an infinite body 1: at rest there, or moved by ``drive``
        w.last = w.state()
        return w

    def drive(self, w: World, x1: float, v1: float, x1_end: float) -> None:
        """The prescribed body 1 (a kinematic link) set to its path's state at the step's start."""
        w.drive(x1, v1)
        w.x1, w.v1 = x1, v1

    def validate(self, scene: Scene, settings: Any) -> None:
        """A device warp does not find is refused."""
        device_name(settings.device)

    def record(self, scene: Scene, settings: Any) -> dict[str, Any]:
        """The device, the precision, the versions, and the kernels' loading (done here, before the run's clock)."""
        wp, _ = modules()
        device = device_name(settings.device)
        load = load_kernels(self.solver, device)
        return {"solver": self.solver, "precision": self.precision, "device": device, "warp_version": wp.__version__,
                "warmup_s": load.seconds, "kernels": "compiled" if load.compiled else "cached"}

    exports = ("scene.py",)  # a complete Newton script
    export_kind = "a Python script"

    def snippet(self, scene: Scene, settings: Any = None) -> str:
        """The shape settings and the solver these settings make, as Newton code (``export.snippet``)."""
        from .export import snippet

        return snippet(scene, self.settings(settings), self.solver)

    def export(self, scene: Scene, settings: Any, command: str | None = None) -> dict[str, str]:
        """``scene.py``: the scene built and stepped with Newton alone (``export.scene_script``)."""
        from .export import scene_script

        return {self.exports[0]: scene_script(scene, self.settings(settings), self.solver)}

    def forks(self, settings: Any) -> bool:
        """On the CPU device a run may be forked; on cuda not (a CUDA context does not survive a fork)."""
        return device_name(settings.device) != "cuda"


class NewtonXpbdEngine(_Newton):
    """Newton's XPBD (``SolverXPBD``, restitution pass on) behind the engine contract: rigid, float32."""

    name = "newton_xpbd"
    settings_type = XpbdSettings
    solver = "xpbd"
    first_run_note = FIRST_RUN.format(solver="XPBD", cold="about 15 s")

    def step(self, w: World, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        """One captured step; the walls' push from body 2's momentum (module docstring)."""
        f1, f2 = forces
        w.push(f1, f2)
        v_free = w.last[3] + f2 * w.dt / w.m2
        w.launch()
        state = w.last = w.state()
        x1, v1, x2, v2 = state
        dv = v2 - v_free
        out = (x1, v1, x2, v2) if w.finite1 else (None, None, x2, v2)
        if abs(dv) > IMPULSE_RELATIVE_TOLERANCE * (abs(v_free) + abs(f2 * w.dt / w.m2)) + IMPULSE_ABSOLUTE_TOLERANCE:
            f = w.m2 * dv / w.dt
            if f > 0.0:
                return out, ((f, 0.0) if w.two else (f,))
            if w.two:
                return out, (0.0, -f)
        return out, ()

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms to 10 us (the restitution threshold 2 |g| dt falls with it); the iterations, the contact
        relaxation, gravity in the model or as a force (the threshold on or off), metres or millimetres (XPBD's speed
        floor 1e-4 model units/s). Defaults first."""
        base = XpbdSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5),
                "newton_xpbd.iterations": (base.iterations, 1, 4, 8),
                "newton_xpbd.rigid_contact_relaxation": (base.rigid_contact_relaxation, 0.5, 1.0),
                "newton_xpbd.gravity_in_model": (base.gravity_in_model, not base.gravity_in_model),
                "newton_xpbd.length_unit": (base.length_unit, 1000.0)}


class NewtonSemiEngine(_Newton):
    """Newton's semi-implicit integrator (``SolverSemiImplicit``) with its penalty contact: compliant, float32."""

    name = "newton_semi"
    settings_type = SemiSettings
    solver = "semi"
    compliant = True
    first_run_note = FIRST_RUN.format(solver="semi-implicit", cold="about 10 s")

    def validate(self, scene: Scene, settings: SemiSettings) -> None:
        """The explicit damper overshoots past zeta w0 dt = 1 (R small, ``kd_scale`` large): refused."""
        super().validate(scene, settings)
        zeta = settings.zeta(scene.restitution)
        if zeta * settings.w0_dt > 1.0:
            raise SettingsError(f"newton_semi: zeta w0 dt = {zeta * settings.w0_dt:.3g} at R = {scene.restitution}: "
                                "must be <= 1 (the explicit damper overshoots); lower newton_semi.w0_dt or kd_scale")

    def build(self, scene: Scene, settings: SemiSettings) -> World:
        w = super().build(scene, settings)
        w.ke, w.kd = ke_kd(settings.w0, settings.zeta(scene.restitution), relative_mass(scene.mass1, scene.mass2))
        return w

    def step(self, w: World, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        """One captured step; each wall's penalty force from the state at the step's start (module docstring)."""
        x1, v1, x2, v2 = w.last
        y, vy = (x2 - x1, v2 - v1) if w.finite1 else (x2 - w.x1, v2 - w.v1)
        pushes = ()
        d = y - w.lower
        if d < 0.0:
            pushes = (w.ke * -d + w.kd * max(-vy, 0.0), 0.0) if w.two else (w.ke * -d + w.kd * max(-vy, 0.0),)
        elif w.two and w.upper - y < 0.0:
            pushes = (0.0, w.ke * (y - w.upper) + w.kd * max(vy, 0.0))
        w.push(*forces)
        w.launch()
        x1, v1, x2, v2 = w.last = w.state()
        return ((x1, v1, x2, v2) if w.finite1 else (None, None, x2, v2)), pushes

    def record(self, scene: Scene, settings: SemiSettings) -> dict[str, Any]:
        """The shared record, and the contact the settings make: w0, zeta, the per-shape ke and kd Newton is given."""
        zeta = settings.zeta(scene.restitution)
        ke, kd = ke_kd(settings.w0, zeta, relative_mass(scene.mass1, scene.mass2))
        return {**super().record(scene, settings), "w0": settings.w0, "zeta": zeta, "ke": ke, "kd": kd}

    def contact_scales(self, scene: Scene, settings: SemiSettings) -> tuple[float, float]:
        """One bounce's duration [s] and the natural frequency w0 [rad/s] of the penalty contact (``penalty.py``)."""
        return contact_duration(settings.zeta(scene.restitution), settings.w0), settings.w0

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms to 10 us; the contact's w0 dt (stiffer: shorter bounces, nearer the explicit limit) and the
        damping's scale on the kd that gives R. Defaults first."""
        base = SemiSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5),
                "newton_semi.w0_dt": (base.w0_dt, 0.01, 0.1, 0.3),
                "newton_semi.kd_scale": (base.kd_scale, 0.5, 2.0)}
