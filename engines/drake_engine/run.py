"""Running Drake: the adapter, one ``Simulator.AdvanceTo`` over the whole run, the samples read from its steps.

    >>> import numpy as np
    >>> from chatterbench.engines.drake_engine import DrakeEngine, DrakeSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = DrakeEngine().run(load_scene("bouncing-ball", ["duration=0.6"]), DrakeSettings(dt=1e-3))
    >>> traj.status, round(float(traj.t[np.argmax(traj.contact["lower"])]), 3)      # first impact: sqrt(2/g)
    ('ok', 0.452)

Drake's integrator chooses its own steps (continuous mode) and its plant holds the scene's
forces, so the adapter runs whole runs (``samples``, a generator the base drives, times and
records: ``wholerun.py``; the diagram built and the simulator initialized are its set-up). Sampling, at
``base.sample_times(scene, dt)`` in both modes:

- **discrete**: the plant steps at dt; two ``VectorLogSink``s (C++, per-step publishing) log
  the state and the plant's generalized contact forces every step. Sample k is the state after k steps; its
  contact force is the one of the step that ended there (Drake's sampled output ports; 0
  at sample 0). On y that force is the wall's push on body 2: > 0 the lower wall, < 0 the
  upper one.
- **continuous**: the integrator takes the steps its ``accuracy`` needs (logging at dt
  would force a step end at every sample: 20x the cost on the bouncing ball). A monitor
  keeps each step's end state and the samples are interpolated between step ends
  (``hermite``). Drake's own dense output is not used: 1.51.1 aborts the process in
  ``PiecewisePolynomial::ConcatenateInTime`` with its implicit integrators, and it doubled
  the cost of RK3 on the bouncing ball (the monitor costs nothing measurable). The contact
  force at a sample is Drake's Hunt-Crossley law at the sampled state
  (``contact.ContactLaw.normal_force``; the tests check it against Drake's contact port).

Promises: the samples go to the base in ``window.CHUNK`` slices (a long run comes back
compact, as every engine's does), and the base classifies the run: Drake's own
exception is ``"error"`` with the samples before it, a non-finite state ``"diverged"``; the
settings are checked when made, the contact calibrated as the model is built.
"""

from __future__ import annotations

from typing import Any, Generator, Iterator

import numpy as np

from chatterbench.reference.scene import Scene

from ..api import EngineAdapter, Recording, Samples
from ..base import sample_times
from ..window import CHUNK
from .contact import contact_law
from .model import DrakeModel, build
from .settings import DrakeSettings


class DrakeError(RuntimeError):
    """Drake stopped the run (its exception's message, the samples before it kept)."""


def _simulator(model: DrakeModel, scene: Scene, s: DrakeSettings) -> Any:
    """A Simulator on the model, at the scene's initial state, Drake time 0 = scene time t0."""
    from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig

    sim = Simulator(model.diagram)
    plant_context = model.plant.GetMyMutableContextFromRoot(sim.get_mutable_context())
    ini = scene.initial
    model.plant.SetPositions(plant_context, [ini.x1, ini.y] if model.finite else [ini.y])
    model.plant.SetVelocities(plant_context, [ini.v1, ini.vy] if model.finite else [ini.vy])
    ApplySimulatorConfig(SimulatorConfig(integration_scheme=s.integrator, accuracy=s.accuracy, max_step_size=s.max_step,
                                         use_error_control=True, target_realtime_rate=0.0, publish_every_time_step=False),
                         sim)
    return sim


def _advance(sim: Any, t_end: float) -> str:
    """``sim.AdvanceTo(t_end)``; Drake's exception message, or "" when it got there."""
    try:
        sim.AdvanceTo(t_end)
    except RuntimeError as exc:
        return str(exc).splitlines()[0]
    return ""


def hermite(ts: np.ndarray, xs: np.ndarray, t: np.ndarray, nv: int) -> np.ndarray:
    """States at times ``t`` (k,) from step ends ``ts`` (m,) and states ``xs`` (m, 2 nv) = (q, v):
    q the cubic Hermite interpolant of (q, v) at the two ends, v its derivative; shape (k, 2 nv).

    v = dq/dt keeps the pair consistent and bounded by the step's own q and v, so a long
    implicit step over a stiff contact (CENIC, Radau at a loose accuracy) is not overshot as
    an interpolant using the end accelerations would (error O(h^3) where the motion is smooth).
    Each step's cubic q0 + v0 r + c2 r^2 + c3 r^3 in r = t - t_j is built once and evaluated by
    Horner's rule (c2, c3 carry 1 / h^2, 1 / h^3; the powers of r undo it, so a tiny step loses
    no digits at its samples).
    """
    if len(ts) == 1:
        return np.repeat(xs[:1], len(t), axis=0)
    # coordinate-major (rows of length m or k): 1-D gathers and arithmetic, ~8x faster than (k, nv) broadcasts
    x = xs.T
    h = np.diff(ts)
    q0, v0 = x[:nv, :-1], x[nv:, :-1]
    slope = np.diff(x[:nv], axis=1) / h
    c2 = (3.0 * slope - 2.0 * v0 - x[nv:, 1:]) / h
    c3 = (v0 + x[nv:, 1:] - 2.0 * slope) / (h * h)
    i = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2)
    coef = np.take(np.concatenate([q0, v0, c2, c3]), i, axis=1)  # (4 nv, k)
    r = t - ts[i]
    out = np.empty((2 * nv, len(t)))
    for c in range(nv):
        q, v, a2, a3 = coef[c], coef[nv + c], coef[2 * nv + c], coef[3 * nv + c]
        out[c] = q + r * (v + r * (a2 + r * a3))
        out[nv + c] = v + r * (2.0 * a2 + 3.0 * r * a3)
    return out.T


Stepped = Generator[None, Any, tuple[np.ndarray, dict, str, int]]  # set up (one None), then stepped: the results


def _continuous(model: DrakeModel, scene: Scene, s: DrakeSettings, t: np.ndarray) -> Stepped:
    """Set up (yields None once), then step: states at the sample times (k, 2 nv), wall forces, Drake's error
    message and the integrator's steps taken (the cost the user's ``accuracy`` buys; tune ranks by it)."""
    from pydrake.systems.framework import EventStatus

    sim = _simulator(model, scene, s)
    context = sim.get_mutable_context()
    ts: list[float] = []
    xs: list[np.ndarray] = []
    ok, clock, state = EventStatus.Succeeded(), context.get_time, context.get_continuous_state_vector().CopyToVector
    keep_t, keep_x = ts.append, xs.append

    def monitor(_):
        keep_t(clock())
        keep_x(state())
        return ok

    sim.set_monitor(monitor)
    sim.Initialize()
    yield
    message = _advance(sim, float(t[-1] - t[0]))
    steps_t, steps_x = np.array(ts), np.array(xs)
    finite = np.isfinite(steps_x).all(axis=1)
    if not finite.all():
        steps_t, steps_x = steps_t[: np.argmin(finite)], steps_x[: np.argmin(finite)]
    later = np.diff(steps_t, prepend=-np.inf) > 0.0  # a zero-length step would be a 0 / 0 cubic
    steps_t, steps_x = steps_t[later], steps_x[later]
    reached = t - t[0] <= steps_t[-1] * (1.0 + 1e-12) if len(steps_t) else np.zeros(len(t), bool)
    drake_t = (t - t[0])[reached]
    x = hermite(steps_t, steps_x, drake_t, model.nv)
    forces = model.wall_forces(x[:, model.nv - 1], x[:, -1])
    if not finite.all() and len(x) < len(t):  # the sample after the last finite step: non-finite ("diverged")
        x = np.vstack([x, np.full((1, x.shape[1]), np.nan)])
        forces = {w: np.append(f, 0.0) for w, f in forces.items()}
    return x, forces, message, sim.get_integrator().get_num_steps_taken()


def _discrete(model: DrakeModel, scene: Scene, s: DrakeSettings, t: np.ndarray) -> Stepped:
    """As ``_continuous``, from the loggers of a discrete plant."""
    sim = _simulator(model, scene, s)
    sim.Initialize()
    yield
    message = _advance(sim, float(t[-1] - t[0]))
    context = sim.get_context()
    state, contact = (model.loggers[k].FindLog(context) for k in ("state", "contact"))
    # one row per simulator step: a plant update, but for a sliver of a step that Drake may take to
    # reach t_end when its update times and n dt differ in the last bit (kept: the first of the two)
    keep = np.concatenate([[True], np.diff(state.sample_times()) > 0.5 * s.dt])
    x = state.data().T[keep][: len(t)]
    push = contact.data()[-1][keep][: len(x)]
    off = np.abs(state.sample_times()[keep][: len(x)] - (t[: len(x)] - t[0]))
    if len(off) and off.max() > 0.25 * s.dt and not message:  # a step that was not a plant update
        message = f"a logged sample is {off.max():.3g} s off the sample grid"
    forces = {"lower": np.maximum(push, 0.0)}
    if "upper" in model.walls:
        forces["upper"] = np.maximum(-push, 0.0)
    return x, forces, message, len(x) - 1


def snippet(scene: Scene, settings: DrakeSettings | None = None) -> str:
    """The contact and the time stepping these settings give ``scene``, as Python for the user's own plant."""
    s = settings or DrakeSettings()
    law = contact_law(scene, s)
    time_step = s.dt if s.mode == "discrete" else 0.0
    lines = [
        f"# Drake contact for scene {scene.name!r}: w0 = {law.w0:.6g} rad/s over reduced mass {law.mass:.6g} kg,",
        f"# calibrated for R = {law.restitution:g} at {law.calibration_speed:.6g} m/s ({law.law}).",
        "# Every wall-ball pair has k, d, tau: each of the two geometries gets 2 k, d and tau / 2.",
        "from pydrake.geometry import AddContactMaterial, ProximityProperties",
        "from pydrake.multibody.plant import CoulombFriction, MultibodyPlantConfig",
        "from pydrake.systems.analysis import SimulatorConfig",
        "",
        "props = ProximityProperties()",
        f"AddContactMaterial(dissipation={law.dissipation!r}, point_stiffness={2.0 * law.stiffness!r},",
        "                   friction=CoulombFriction(0.0, 0.0), properties=props)",
        f"props.AddProperty(\"material\", \"relaxation_time\", {0.5 * law.relaxation_time!r})",
        f"plant_config = MultibodyPlantConfig(time_step={time_step!r}, contact_model=\"point\",",
        f"                                    discrete_contact_approximation=\"{s.solver if time_step else ''}\",",
        "                                    adjacent_bodies_collision_filters=False)",
    ]
    if s.mode == "continuous":
        lines += [f"simulator_config = SimulatorConfig(integration_scheme=\"{s.integrator}\", accuracy={s.accuracy!r},",
                  f"                                   max_step_size={s.max_step!r}, use_error_control=True)"]
    return "\n".join(lines) + "\n"


class DrakeEngine(EngineAdapter):
    """Drake behind the engine contract (``base.EngineAdapter``): compliant Hunt-Crossley contact, float64."""

    name = "drake"
    package = "drake"
    settings_type = DrakeSettings
    compliant = True
    bytes_per_step = 250.0  # measured peak growth per sample, feigin-pair: 181 B (continuous, 4e5) and 214 B (discrete, 1e5)

    def samples(self, run: Recording) -> Iterator[Samples | None]:
        """Build the diagram (calibrating the contact) and the simulator (set up), advance it over the run, yield the
        samples in ``window.CHUNK`` slices; ``DrakeError`` with Drake's message when it stopped."""
        scene, s = run.scene, run.settings
        t = sample_times(scene, s.dt)
        model = build(scene, s)
        law = model.law
        run.record.update(stiffness=law.stiffness, dissipation=law.dissipation, relaxation_time=law.relaxation_time,
                          w0_used=law.w0, calibrated_restitution=law.restitution, calibration_speed_used=law.calibration_speed)
        run.contact_time, run.contact_frequency = law.contact_time, law.w0
        x, forces, message, run.record["steps_taken"] = yield from (
            _continuous if s.mode == "continuous" else _discrete)(model, scene, s, t)
        nv = model.nv
        for k0 in range(0, len(x), CHUNK):
            rows = x[k0:k0 + CHUNK]
            body1 = {"x1": rows[:, 0], "v1": rows[:, nv]} if model.finite else {}
            chunk = Samples(t[k0:k0 + len(rows)], {w: forces[w][k0:k0 + len(rows)] for w in model.walls},
                            y=rows[:, nv - 1], vy=rows[:, -1], **body1)
            if (yield chunk) is False:
                break
        if message:
            raise DrakeError(message)

    def record(self, scene: Scene, settings: DrakeSettings) -> dict[str, Any]:
        """The cost lever and the contact law's name (the run adds the calibrated contact and the steps taken)."""
        return {"cost_lever": settings.cost_lever, "law": settings.law}

    def snippet(self, scene: Scene, settings: DrakeSettings | None = None) -> str:
        """The contact properties and configs, as Python (``snippet``)."""
        return snippet(scene, settings)

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us (the sampling in continuous mode, the step in discrete mode); both
        modes; the integrator's accuracy; a softer and a stiffer contact. Defaults first."""
        base = DrakeSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5), "drake.mode": (base.mode, "discrete"),
                "drake.accuracy": (base.accuracy, 1e-4, 1e-8), "drake.contact_time_ratio": (base.contact_time_ratio, 0.001, 0.01)}

    def cost_lever(self, settings: DrakeSettings) -> str:
        """``"accuracy"`` in continuous mode, ``"dt"`` in discrete mode."""
        return settings.cost_lever

    def unread_fields(self, settings: DrakeSettings) -> frozenset[str]:
        """Discrete mode reads neither the integrator nor its ``accuracy`` and ``max_step`` (the plant steps at dt, the
        simulator integrates nothing); continuous mode reads no discrete ``solver``."""
        return settings.unread
