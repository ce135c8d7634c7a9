"""The scene as a homogeneous linear system on an augmented state, for free and constrained motion.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.reference.linear import LinearSystem
    >>> system = LinearSystem.from_scene(load_scene("feigin-pair"))
    >>> s0 = system.state(t=0.0, x1=0.0, v1=0.0, y=0.0, vy=0.0)
    >>> system.free.shape, system.stuck.shape        # (n, n) matrices with s' = A s
    ((7, 7), (7, 7))

Every catalogue force is linear in (x1, v1, y, vy) or a constant/harmonic function of
time, so augmenting the state with the forcing generators makes the motion homogeneous:

    s = [x1, v1, y, vy, 1, sin(w_1 t), cos(w_1 t), ..., sin(w_m t), cos(w_m t)],   s' = A s

and the closed-form solution is s(t0 + h) = expm(A h) s(t0) (matrix exponential plus the
harmonic/constant particular solution in one). Rows of ``A`` follow Feigin (1967):

- free motion (1.1)-(1.2): m1 x1'' = F1 + F12 (or the prescribed x1''), y'' = (F2 - F12)/m2 - x1'';
- motion in kinematic constraint at a wall (1.4): (m1 + m2) x1'' = F1 + F2, y' = y'' = 0
  (y'' = 0 is kept by vy' = 0 with vy = 0 on entry).

``accel_row`` is the row r with y''_free = r . s: the free relative acceleration
F2/m2 - F1/m1 - F12 (1/m1 + 1/m2) of (3.1) in SI, whose sign decides sticking and exit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .forces import ForceModel, Terms
from .scene import Scene

X1, V1, Y, VY, ONE = 0, 1, 2, 3, 4  # indices into the augmented state


@dataclass(frozen=True)
class LinearSystem:
    """Free and constrained motion of a scene as s' = A s on the augmented state.

    Attributes
    ----------
    free, stuck : ndarray, shape (n, n)
        Generators of the free flight and of the motion in kinematic constraint.
    accel_row : ndarray, shape (n,)
        y'' of the free motion as a linear function of the state [m/s^2].
    omegas : tuple of float
        Forcing angular frequencies [rad/s]; state 5 + 2j, 6 + 2j are sin, cos of omegas[j] t.
    """

    free: np.ndarray
    stuck: np.ndarray
    accel_row: np.ndarray
    omegas: tuple[float, ...]
    mass1: float
    mass2: float

    @property
    def size(self) -> int:
        """Length n of the augmented state."""
        return self.free.shape[0]

    def forcing(self, t: float) -> np.ndarray:
        """The forcing part of the state at time t: [1, sin(w_1 t), cos(w_1 t), ...]."""
        out = np.empty(1 + 2 * len(self.omegas))
        out[0] = 1.0
        for j, w in enumerate(self.omegas):
            out[1 + 2 * j] = math.sin(w * t)
            out[2 + 2 * j] = math.cos(w * t)
        return out

    def reseed(self, s: np.ndarray, t: float) -> None:
        """Put the forcing generators of state ``s`` back on their exact values at time t (in place)."""
        for j, w in enumerate(self.omegas):
            s[5 + 2 * j] = math.sin(w * t)
            s[6 + 2 * j] = math.cos(w * t)

    def state(self, t: float, x1: float, v1: float, y: float, vy: float) -> np.ndarray:
        """The augmented state at time t [s] for (x1, v1, y, vy) [m, m/s]."""
        return np.concatenate(([x1, v1, y, vy], self.forcing(t)))

    @classmethod
    def from_scene(cls, scene: Scene) -> "LinearSystem":
        """Assemble the generators of ``scene`` (see the module docstring)."""
        omegas = scene.forcing_omegas
        n = 5 + 2 * len(omegas)

        def harmonic_row(amplitude: float, omega: float, phase: float) -> np.ndarray:
            # A sin(w t + phi) = A cos(phi) sin(w t) + A sin(phi) cos(w t)
            row = np.zeros(n)
            j = omegas.index(omega)
            row[5 + 2 * j] = amplitude * math.cos(phase)
            row[6 + 2 * j] = amplitude * math.sin(phase)
            return row

        def row(terms: Terms, position: tuple[int, ...], velocity: tuple[int, ...], sign: float) -> np.ndarray:
            # sign (K (q - r) + C q') + T(t), q the sum of the ``position`` states: forces.py's model
            out = np.zeros(n)
            for i in position:
                out[i] += sign * terms.stiffness
            for i in velocity:
                out[i] += sign * terms.damping
            out[ONE] = -sign * terms.spring_force + terms.constant
            for amplitude, omega, phase in terms.harmonics:
                out = out + harmonic_row(amplitude, omega, phase)
            return out

        model = ForceModel.from_scene(scene)
        rows = {"body1": row(model.body1, (X1,), (V1,), -1.0), "body2": row(model.body2, (X1, Y), (V1, VY), -1.0),
                "coupling": row(model.coupling, (Y,), (VY,), 1.0)}
        f1, f2, f12 = rows["body1"], rows["body2"], rows["coupling"]
        m1, m2 = scene.mass1, scene.mass2

        if scene.body1_infinite:
            body1_acc = np.zeros(n)
            if scene.prescribed is not None:  # x1'' = -A w^2 sin(w t + phi)
                p = scene.prescribed
                body1_acc = harmonic_row(-p.amplitude * p.omega**2, p.omega, p.phase)
            stuck_acc = body1_acc
        else:
            body1_acc = (f1 + f12) / m1
            stuck_acc = (f1 + f2) / (m1 + m2)  # (1.4)
        accel_row = (f2 - f12) / m2 - body1_acc  # (1.2)

        free = np.zeros((n, n))
        free[X1, V1] = 1.0
        free[V1] = body1_acc
        free[Y, VY] = 1.0
        free[VY] = accel_row
        stuck = np.zeros((n, n))
        stuck[X1, V1] = 1.0
        stuck[V1] = stuck_acc
        stuck[Y, VY] = 1.0  # vy = 0 in constraint, so y stays on the wall
        for A in (free, stuck):
            for j, w in enumerate(omegas):
                A[5 + 2 * j, 6 + 2 * j] = w  # (sin wt)' = w cos wt
                A[6 + 2 * j, 5 + 2 * j] = -w  # (cos wt)' = -w sin wt
        return cls(free=free, stuck=stuck, accel_row=accel_row, omegas=omegas, mass1=m1, mass2=m2)
