"""Evaluate a scene's force terms on a state: the F1, F2, F12 of Feigin (1967), (1.1).

    >>> from chatterbench.reference.forces import evaluate_forces
    >>> f1, f2, f12 = evaluate_forces(scene, t=0.5, x1=0.0, v1=0.0, y=0.05, vy=0.0)
    >>> relative_acceleration(scene, 0.5, 0.0, 0.0, 0.05, 0.0)   # y'' of the free motion

Units: N for forces, m/s^2 for accelerations. Sign conventions are those of ``scene.py``:
body 1 feels F1 + F12, body 2 feels F2 - F12. Works elementwise on numpy arrays too,
which is how the engine adapters apply forces at every step.
"""

from __future__ import annotations

import numpy as np

from .scene import Scene


def evaluate_forces(scene: Scene, t, x1, v1, y, vy):
    """Return (F1, F2, F12) [N] at time t [s] for the state (x1, v1, y, vy) [m, m/s].

    For ``mass1 = inf`` F1 is 0 (body 1 is kinematic; see ``body1_acceleration``).
    """
    x2 = x1 + y
    v2 = v1 + vy
    f = {"body1": 0.0, "body2": 0.0, "coupling": 0.0}
    for term in scene.forces:
        if term.kind == "constant":
            value = term.value
        elif term.kind == "harmonic":
            value = term.amplitude * np.sin(term.omega * t + term.phase)
        elif term.kind == "spring":
            if term.on == "coupling":
                value = term.stiffness * (y - term.rest)
            else:
                value = -term.stiffness * ((x1 if term.on == "body1" else x2) - term.rest)
        else:  # damper
            if term.on == "coupling":
                value = term.damping * vy
            else:
                value = -term.damping * (v1 if term.on == "body1" else v2)
        f[term.on] = f[term.on] + value
    return f["body1"], f["body2"], f["coupling"]


def body1_acceleration(scene: Scene, t, x1, v1, y, vy):
    """x1'' of the free motion [m/s^2]: (F1 + F12) / m1, or the prescribed x1''(t)."""
    if scene.body1_infinite:
        return 0.0 * np.asarray(t) if scene.prescribed is None else scene.prescribed.acceleration(t)
    f1, _, f12 = evaluate_forces(scene, t, x1, v1, y, vy)
    return (f1 + f12) / scene.mass1


def relative_acceleration(scene: Scene, t, x1, v1, y, vy):
    """y'' of the free motion [m/s^2], Feigin (1.2) in SI: F2/m2 - x1'' - F12/m2.

    At a wall this is the sign that decides sticking, (1.4)/(3.1): negative pushes y
    towards the lower wall, positive towards the upper wall.
    """
    _, f2, f12 = evaluate_forces(scene, t, x1, v1, y, vy)
    return (f2 - f12) / scene.mass2 - body1_acceleration(scene, t, x1, v1, y, vy)
