"""The built-in scenes, as plain data in the TOML layout of ``scene.py``.

    >>> from chatterbench.reference.catalogue import CATALOGUE
    >>> sorted(CATALOGUE)
    ['bouncing-ball', 'feigin-pair', 'impact-damper', 'spring-pair']

Each scene models no more than it needs: 1-D motion, no friction, gravity only where the
scene has it. Values are SI. ``describe(name)`` gives the one-line summary.
"""

from __future__ import annotations

import math

G = 9.81  # [m/s^2]

CATALOGUE: dict[str, dict] = {
    "bouncing-ball": {
        "name": "bouncing-ball",
        "description": "1 kg ball dropped from 1 m on a fixed floor under gravity; Zeno point t1 (1+R)/(1-R)",
        "mass1": "inf",
        "mass2": 1.0,
        "restitution": 0.5,
        "gap": {"lower": 0.0},
        "gravity": -G,  # an acceleration: the ball falls at g whatever its mass
        "initial": {"t": 0.0, "x1": 0.0, "v1": 0.0, "y": 1.0, "vy": 0.0},
        "duration": 2.0,
    },
    "feigin-pair": {
        "name": "feigin-pair",
        "description": "Feigin 1967 section 4: P sin t on body 1 (P = m1, omega = 1), |y| <= d, y'' = -sin t",
        "mass1": 1.0,
        "mass2": 1.0,
        "restitution": 0.5,
        "gap": {"lower": -0.1, "upper": 0.1},
        "forces": [{"kind": "harmonic", "on": "body1", "amplitude": 1.0, "omega": 1.0, "phase": 0.0}],
        "initial": {"t": 0.0, "x1": 0.0, "v1": 0.0, "y": 0.0, "vy": 0.0},
        "duration": 6.4 * 2.0 * math.pi,  # ends stuck on the lower wall, away from any event
    },
    "impact-damper": {
        "name": "impact-damper",
        "description": "primary 1 kg on a 100 N/m spring (zeta 0.02) forced at resonance, 0.1 kg free mass in a +-20 mm cavity",
        "mass1": 1.0,
        "mass2": 0.1,
        "restitution": 0.6,
        "gap": {"lower": -0.02, "upper": 0.02},
        "forces": [
            {"kind": "spring", "on": "body1", "stiffness": 100.0, "rest": 0.0},
            {"kind": "damper", "on": "body1", "damping": 0.4},
            {"kind": "harmonic", "on": "body1", "amplitude": 5.0, "omega": 10.0, "phase": 0.0},
        ],
        "initial": {"t": 0.0, "x1": 0.0, "v1": 0.0, "y": 0.0, "vy": 0.0},
        "duration": 6.0 * 2.0 * math.pi / 10.0,
    },
    "spring-pair": {
        "name": "spring-pair",
        "description": "one-sided gap; a preloaded coupling spring pulls the pair together, a harmonic force on body 2 pushes it apart",
        "mass1": 1.0,
        "mass2": 0.5,
        "restitution": 0.5,
        "gap": {"lower": 0.0},
        "forces": [
            {"kind": "spring", "on": "coupling", "stiffness": 50.0, "rest": -0.05},
            {"kind": "harmonic", "on": "body2", "amplitude": 5.0, "omega": 3.0, "phase": 0.0},
        ],
        "initial": {"t": 0.0, "x1": 0.0, "v1": 0.0, "y": 0.0, "vy": 0.0},
        "duration": 6.0 * 2.0 * math.pi / 3.0,
    },
}


def describe(name: str) -> str:
    """One-line description of a built-in scene."""
    return CATALOGUE[name]["description"]
