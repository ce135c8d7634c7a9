"""The scene's force model, written once: F1, F2, F12 of Feigin (1967), (1.1), as stiffness, damping and time terms.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.reference.forces import ForceModel, evaluate_forces
    >>> model = ForceModel.from_scene(load_scene("impact-damper"))
    >>> model.body1.stiffness, model.body1.damping           # the primary's spring and damper
    (100.0, 0.4)
    >>> f1, f2, f12 = evaluate_forces(load_scene("impact-damper"), t=0.5, x1=0.01, v1=0.0, y=0.0, vy=0.0)

Every catalogue force is affine in the state: per target (``body1``, ``body2``, the
``coupling``) the springs sum to a stiffness K with a mean rest r (sum k_i r_i / K), the
dampers to a damping C, the constant and harmonic terms and the weight m g of the scene's
``gravity`` (body 2's, and body 1's when its mass is finite; ``weight``) to a function of time alone:

    body1:    F1  = -K1 (x1 - r1) - C1 x1' + T1(t)
    body2:    F2  = -K2 (x2 - r2) - C2 x2' + T2(t)
    coupling: F12 =  K12 (y - r12) + C12 y' + T12(t)

Units: N, N/m, N s/m, m. Sign conventions are those of ``scene.py``: body 1 feels F1 + F12,
body 2 feels F2 - F12. The reference's linear system (``linear.py``), the sampled free
acceleration of the judge and both engine adapters take their forces from this one model
(MuJoCo as joint and tendon springs and motors, PyBullet as an affine map applied every
step, ``body_forces``). Everything works elementwise on numpy arrays too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scene import Scene


@dataclass(frozen=True)
class Terms:
    """The forces on one target: springs, dampers and time terms (module docstring)."""

    stiffness: float = 0.0  # K, sum of the spring constants [N/m]
    rest: float = 0.0  # r, the springs' mean rest (sum k r / K; 0 without springs) [m]
    damping: float = 0.0  # C, sum of the damper coefficients [N s/m]
    constant: float = 0.0  # sum of the constant forces and the weight m g (``weight``) [N]
    harmonics: tuple[tuple[float, float, float], ...] = ()  # (amplitude [N], omega [rad/s], phase [rad])

    def time_part(self, t):
        """T(t) = constant + sum A sin(w t + phi) [N]; t a float or an array [s]."""
        out = self.constant + 0.0 * np.asarray(t, dtype=float)
        for amplitude, omega, phase in self.harmonics:
            out = out + amplitude * np.sin(omega * t + phase)
        return out

    @property
    def spring_force(self) -> float:
        """K r [N]: the springs' force at zero displacement, up to the target's sign."""
        return self.stiffness * self.rest


def weight(scene: Scene, on: str) -> float:
    """m g [N] on ``on`` from the scene's ``gravity``: body 2's, body 1's when its mass is finite (an infinite body 1
    is kinematic: nothing moves it), none on the coupling (the weights pull both bodies, not their separation)."""
    if on == "body2":
        return scene.mass2 * scene.gravity
    if on == "body1" and not scene.body1_infinite:
        return scene.mass1 * scene.gravity
    return 0.0


def _terms(scene: Scene, on: str) -> Terms:
    forces = [f for f in scene.forces if f.on == on]
    k = sum(f.stiffness for f in forces if f.kind == "spring")
    kr = sum(f.stiffness * f.rest for f in forces if f.kind == "spring")
    return Terms(
        stiffness=k, rest=kr / k if k > 0 else 0.0,
        damping=sum(f.damping for f in forces if f.kind == "damper"),
        constant=sum(f.value for f in forces if f.kind == "constant") + weight(scene, on),
        harmonics=tuple((f.amplitude, f.omega, f.phase) for f in forces if f.kind == "harmonic"),
    )


@dataclass(frozen=True)
class ForceModel:
    """The scene's forces per target (module docstring)."""

    body1: Terms
    body2: Terms
    coupling: Terms

    @classmethod
    def from_scene(cls, scene: Scene) -> "ForceModel":
        return cls(body1=_terms(scene, "body1"), body2=_terms(scene, "body2"), coupling=_terms(scene, "coupling"))

    def forces(self, t, x1, v1, y, vy):
        """(F1, F2, F12) [N] at time t for the state (x1, v1, y, vy) [m, m/s]."""
        b1, b2, c = self.body1, self.body2, self.coupling
        f1 = -b1.stiffness * (x1 - b1.rest) - b1.damping * v1 + b1.time_part(t)
        f2 = -b2.stiffness * (x1 + y - b2.rest) - b2.damping * (v1 + vy) + b2.time_part(t)
        f12 = c.stiffness * (y - c.rest) + c.damping * vy + c.time_part(t)
        return f1, f2, f12

    def body_forces(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The forces on the two bodies as an affine map of the state (x1, v1, x2, v2).

        Returns (time1, time2, gain): body 1 feels F1 + F12 = time1(t) + gain[0] . s, body 2
        feels F2 - F12 = time2(t) + gain[1] . s, with s = (x1, v1, x2, v2); time1, time2 have
        the shape of ``t`` [N], gain is (2, 4) [N/m, N s/m].
        """
        b1, b2, c = self.body1, self.body2, self.coupling
        time1 = b1.spring_force + b1.time_part(t) - c.spring_force + c.time_part(t)
        time2 = b2.spring_force + b2.time_part(t) + c.spring_force - c.time_part(t)
        # F12 = K12 (x2 - x1) + C12 (v2 - v1) + ...
        gain = np.array([
            [-b1.stiffness - c.stiffness, -b1.damping - c.damping, c.stiffness, c.damping],
            [c.stiffness, c.damping, -b2.stiffness - c.stiffness, -b2.damping - c.damping],
        ])
        return np.asarray(time1, dtype=float), np.asarray(time2, dtype=float), gain


def evaluate_forces(scene: Scene, t, x1, v1, y, vy):
    """Return (F1, F2, F12) [N] at time t [s] for the state (x1, v1, y, vy) [m, m/s].

    For ``mass1 = inf`` F1 is still evaluated but moves nothing (body 1 is kinematic; see
    ``body1_acceleration``).
    """
    return ForceModel.from_scene(scene).forces(t, x1, v1, y, vy)


def body1_acceleration(scene: Scene, t, x1, v1, y, vy):
    """x1'' of the free motion [m/s^2]: (F1 + F12) / m1, or the prescribed x1''(t)."""
    if scene.body1_infinite:
        return _body1_acceleration(scene, t, None, None)
    f1, _, f12 = evaluate_forces(scene, t, x1, v1, y, vy)
    return _body1_acceleration(scene, t, f1, f12)


def _body1_acceleration(scene: Scene, t, f1, f12):
    """x1'' [m/s^2] from F1 and F12 [N] (not read for an infinite body 1: rest, or its prescribed x1''(t))."""
    if scene.body1_infinite:
        return 0.0 * np.asarray(t, dtype=float) if scene.prescribed is None else scene.prescribed.acceleration(t)
    return (f1 + f12) / scene.mass1


def relative_acceleration(scene: Scene, t, x1, v1, y, vy):
    """y'' of the free motion [m/s^2], Feigin (1.2) in SI: F2/m2 - x1'' - F12/m2.

    At a wall this is the sign that decides sticking, (1.4)/(3.1): negative pushes y
    towards the lower wall, positive towards the upper wall.
    """
    f1, f2, f12 = evaluate_forces(scene, t, x1, v1, y, vy)  # once: body 1's x'' reads the same F1, F12
    return (f2 - f12) / scene.mass2 - _body1_acceleration(scene, t, f1, f12)
