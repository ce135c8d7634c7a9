"""The scene as a Drake diagram: a MultibodyPlant with two prismatic bodies, walls and a ball, forces as gains and sines.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.drake_engine.model import build
    >>> from chatterbench.engines.drake_engine.settings import DrakeSettings
    >>> model = build(load_scene("feigin-pair"), DrakeSettings())
    >>> model.plant.num_positions(), model.walls, model.plant.time_step()     # continuous: no time step
    (2, ('lower', 'upper'), 0.0)

The plant (point contact, hydroelastic off, no gravity field, friction 0):

- ``body1`` on a prismatic joint ``x1`` along world x; for ``mass1 = inf`` no body: the
  walls are fixed to the world at the body's reference place (its fixed x1, or a prescribed
  motion's offset), and the prescribed motion enters through its inertial force, as in
  the MuJoCo adapter.
- ``body2`` on a prismatic joint ``y`` whose parent is body 1 (or that reference place), so
  the state is (x1, y, v1, vy) and y = x2 - x1 is a coordinate. Drake filters collisions
  between bodies joined by a joint; that filter is turned off
  (``set_adjacent_bodies_collision_filters(False)``).
- The gap as geometry (continuous plants do not enforce joint limits): a sphere of radius
  ``BALL_RADIUS`` on body 2 and a box per wall on body 1, whose faces touch the sphere
  exactly when y reaches ``gap.lower`` (``gap.upper``). Contact parameters: ``contact.py``.

Forces, from the scene's one force model (``reference.forces.ForceModel.body_forces``): the
generalized force on (x1, y) is Q = A (time(t) + gain s), s = (x1, v1, x2, v2) and
A = [[1, 1], [0, 1]] (x2 = x1 + y), fed to the plant's ``applied_generalized_force`` port as a
``MatrixGain`` of the plant state plus a ``MatrixGain`` of a vector ``Sine`` source (constants
are sines of frequency 0 and phase pi/2). All of it is Drake systems: nothing in Python runs
while Drake steps. Drake's clock starts at 0; phases are shifted by omega t0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from chatterbench.reference.forces import ForceModel
from chatterbench.reference.scene import Scene

from .contact import ContactLaw, contact_law
from .settings import DrakeSettings

BALL_RADIUS = 0.01  # [m] radius of body 2's sphere; geometry only, the contact is at y = wall
# Thick, wide walls: an explicit integrator's trial step may land deep inside a wall (the
# ball at 4.4 m/s travels 4.4 cm in a 1e-2 s step); a thin wall would let the sphere pass
# through it, or make a side face the nearest, and the error control would never see the contact
WALL_HALF = 1.0  # [m] half thickness of a wall box along x
WALL_SIDE = 2.0  # [m] half extent of a wall box across x
_APPROXIMATIONS = {"sap": "kSap", "tamsi": "kTamsi", "similar": "kSimilar", "lagged": "kLagged"}


@dataclass(frozen=True)
class Forcing:
    """The scene's forces in Drake's generalized coordinates: Q(t, x) = gain @ x + shape @ sines(t)."""

    gain: np.ndarray  # (nv, 2 nv) [N/m, N s/m], on the plant state (q, v)
    shape: np.ndarray  # (nv, m) [-], each sine's share of each coordinate
    amplitude: np.ndarray  # (m,) [N]
    omega: np.ndarray  # (m,) [rad/s] (0 for a constant)
    phase: np.ndarray  # (m,) [rad], for Drake's clock (t - t0)


@dataclass
class DrakeModel:
    """A built diagram and what reading its trajectory needs."""

    diagram: Any  # pydrake Diagram
    plant: Any  # its MultibodyPlant
    law: ContactLaw
    forcing: Forcing
    walls: tuple[str, ...]
    finite: bool  # does body 1 move (has a joint)?
    lower: float = 0.0  # [m] y of the lower wall
    upper: float = math.inf  # [m] y of the upper wall (inf: none)
    loggers: dict[str, Any] = field(default_factory=dict)  # "state", "contact": VectorLogSinks (discrete runs)

    @property
    def nv(self) -> int:
        """Generalized velocities: 2 (x1, y), or 1 (y) for an infinite body 1."""
        return 2 if self.finite else 1

    def wall_forces(self, y: np.ndarray, vy: np.ndarray) -> dict[str, np.ndarray]:
        """Each wall's Hunt-Crossley push on body 2 [N] (>= 0) at gap y [m], rate vy [m/s]."""
        gap = self.law
        out = {"lower": gap.normal_force(self.lower - y, -vy)}
        if "upper" in self.walls:
            out["upper"] = gap.normal_force(y - self.upper, vy)
        return out


def forcing(scene: Scene, t0: float) -> Forcing:
    """The scene's force model in Drake's coordinates (module docstring), phases for Drake's clock."""
    fm = ForceModel.from_scene(scene)
    time1, time2, gain = fm.body_forces(0.0)
    gain = np.asarray(gain, dtype=float)  # sums of no springs are the integer 0
    # (force on body 1, force on body 2) per unit sine, amplitude [N], omega [rad/s], phase at t = 0 [rad]
    terms = [(vec, a, w, p) for side, vec in ((fm.body1, (1.0, 0.0)), (fm.body2, (0.0, 1.0)), (fm.coupling, (1.0, -1.0)))
             for a, w, p in side.harmonics]
    const = np.array([float(time1), float(time2)]) - sum((np.multiply(vec, a * math.sin(p)) for vec, a, w, p in terms),
                                                         np.zeros(2))
    if scene.body1_infinite:
        # body 2's force sees x1(t), v1(t), and y the inertial force -m2 x1''(t) (body 1 is not a body here)
        g0, g1, g2, g3 = gain[1]
        x_ref = body1_reference(scene)
        const[1] += (g0 + g2) * x_ref
        pr = scene.prescribed
        if pr is not None:  # x1 = offset + A sin(w t + p): v1 = A w sin(. + pi/2), -m2 x1'' = m2 A w^2 sin(.)
            terms += [((0.0, 1.0), (g0 + g2) * pr.amplitude + scene.mass2 * pr.amplitude * pr.omega**2, pr.omega, pr.phase),
                      ((0.0, 1.0), (g1 + g3) * pr.amplitude * pr.omega, pr.omega, pr.phase + math.pi / 2)]
        to_q, state_gain = np.array([[0.0, 1.0]]), np.array([[g2, g3]])
    else:
        to_q = np.array([[1.0, 1.0], [0.0, 1.0]])  # Q_x1 = F1 + F2 (x2 = x1 + y), Q_y = F2
        pick = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [1, 1, 0, 0], [0, 0, 1, 1]], dtype=float)  # (x1,v1,x2,v2) of (x1,y,v1,vy)
        state_gain = to_q @ gain @ pick
    terms.append((tuple(const), 1.0, 0.0, math.pi / 2))  # sin(pi / 2) is exactly 1
    shape = to_q @ np.array([vec for vec, *_ in terms], dtype=float).T
    return Forcing(
        gain=state_gain, shape=shape, amplitude=np.array([a for _, a, _, _ in terms], dtype=float),
        omega=np.array([w for _, _, w, _ in terms], dtype=float),
        phase=np.array([math.fmod(p + w * t0, 2.0 * math.pi) for _, _, w, p in terms], dtype=float),
    )


def body1_reference(scene: Scene) -> float:
    """Where an infinite body 1's walls are fixed [m]: its fixed x1, or the prescribed offset."""
    return scene.prescribed.offset if scene.prescribed is not None else scene.initial.x1


def _properties(stiffness: float, law: ContactLaw) -> Any:
    """Proximity properties of one side of a pair: 2 k, d, tau / 2 (``contact.py``: the pair gets k, d, tau)."""
    from pydrake.geometry import AddContactMaterial, ProximityProperties
    from pydrake.multibody.plant import CoulombFriction

    props = ProximityProperties()
    AddContactMaterial(dissipation=law.dissipation, point_stiffness=stiffness, friction=CoulombFriction(0.0, 0.0),
                       properties=props)
    props.AddProperty("material", "relaxation_time", 0.5 * law.relaxation_time)
    return props


def build(scene: Scene, settings: DrakeSettings | None = None, record: bool = True, law: ContactLaw | None = None) -> DrakeModel:
    """The scene's diagram (module docstring). A discrete model with ``record`` logs the state and
    the generalized contact forces every step (``loggers``); ``law`` skips the calibration."""
    from pydrake.geometry import Box, Sphere
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, ContactModel, DiscreteContactApproximation
    from pydrake.multibody.tree import FixedOffsetFrame, PrismaticJoint, SpatialInertia, UnitInertia
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import Adder, LogVectorOutput, MatrixGain, Sine

    s = settings or DrakeSettings()
    law = law or contact_law(scene, s)
    discrete = s.mode == "discrete"
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, s.dt if discrete else 0.0)
    plant.set_contact_model(ContactModel.kPoint)
    if discrete:
        plant.set_discrete_contact_approximation(getattr(DiscreteContactApproximation, _APPROXIMATIONS[s.solver]))
    plant.set_adjacent_bodies_collision_filters(False)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    axis = np.array([1.0, 0.0, 0.0])

    def inertia(mass: float) -> Any:
        return SpatialInertia(mass, np.zeros(3), UnitInertia(1.0, 1.0, 1.0))

    finite = not scene.body1_infinite
    if finite:
        body1 = plant.AddRigidBody("body1", inertia(scene.mass1))
        plant.AddJoint(PrismaticJoint("x1", plant.world_frame(), body1.body_frame(), axis))
        frame1, holder = body1.body_frame(), body1
    else:
        frame1 = plant.AddFrame(FixedOffsetFrame("body1", plant.world_frame(), RigidTransform(axis * body1_reference(scene))))
        holder = plant.world_body()
    body2 = plant.AddRigidBody("body2", inertia(scene.mass2))
    plant.AddJoint(PrismaticJoint("y", frame1, body2.body_frame(), axis))

    side = _properties(2.0 * law.stiffness, law)
    plant.RegisterCollisionGeometry(body2, RigidTransform(), Sphere(BALL_RADIUS), "ball", side)
    lower, upper = scene.gap.lower, scene.gap.upper
    shift = 0.0 if finite else body1_reference(scene)  # the world holds an infinite body's walls
    faces = {"lower": lower - BALL_RADIUS - WALL_HALF}
    if upper is not None:
        faces["upper"] = upper + BALL_RADIUS + WALL_HALF
    for wall, x in faces.items():
        plant.RegisterCollisionGeometry(holder, RigidTransform(axis * (x + shift)), Box(2 * WALL_HALF, 2 * WALL_SIDE, 2 * WALL_SIDE),
                                        wall, side)
    plant.Finalize()

    push = forcing(scene, scene.initial.t)
    nv = plant.num_velocities()
    if np.any(push.gain) or np.any(push.amplitude * push.shape):
        adder = builder.AddSystem(Adder(2, nv))
        gain = builder.AddSystem(MatrixGain(push.gain))
        builder.Connect(plant.get_state_output_port(), gain.get_input_port())
        sines = builder.AddSystem(Sine(push.amplitude, push.omega, push.phase))
        shape = builder.AddSystem(MatrixGain(push.shape))
        builder.Connect(sines.get_output_port(0), shape.get_input_port())
        builder.Connect(gain.get_output_port(), adder.get_input_port(0))
        builder.Connect(shape.get_output_port(), adder.get_input_port(1))
        builder.Connect(adder.get_output_port(), plant.get_applied_generalized_force_input_port())
    loggers = {}
    if discrete and record:
        loggers["state"] = LogVectorOutput(plant.get_state_output_port(), builder, 0.0)
        loggers["contact"] = LogVectorOutput(plant.get_generalized_contact_forces_output_port(body2.model_instance()),
                                             builder, 0.0)
    diagram = builder.Build()
    return DrakeModel(diagram=diagram, plant=plant, law=law, forcing=push, walls=scene.gap.walls,
                      finite=finite, lower=lower, upper=math.inf if upper is None else upper, loggers=loggers)
