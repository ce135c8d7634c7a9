"""Newton's impact law between the two masses, Feigin (1967), (1.3), in SI units.

    >>> from chatterbench.reference.impact import impact
    >>> impact(vy=-1.0, v1=0.0, restitution=0.5, mass1=1.0, mass2=1.0)
    Impact(vy=0.5, v1=-0.75)

y'+ = -R y'-;  x1'+ = x1'- + m2 (1 + R) / (m1 + m2) * y'-   (so m1 x1' + m2 x2' is conserved).
With m1 = inf body 1 keeps its (fixed or prescribed) velocity. R = 0 is the perfectly
inelastic impact that starts motion in kinematic constraint (1.4).
"""

from __future__ import annotations

import math
from typing import NamedTuple


class Impact(NamedTuple):
    """Velocities just after an impact [m/s]."""

    vy: float  # relative velocity y' after the impact
    v1: float  # body 1 velocity after the impact


def impact(vy: float, v1: float, restitution: float, mass1: float, mass2: float) -> Impact:
    """Apply (1.3) to the incoming relative velocity ``vy`` and body 1 velocity ``v1``.

    Parameters
    ----------
    vy, v1 : float
        Velocities just before the impact [m/s].
    restitution : float
        Newton's R, 0 <= R < 1 (0: perfectly inelastic).
    mass1, mass2 : float
        Masses [kg]; mass1 may be math.inf.
    """
    # Feigin 1967, (1.3): y'+ = -R y'-, x1'+ = x1'- + mu (1 + R) / (1 + mu) y'-
    share = 0.0 if math.isinf(mass1) else mass2 / (mass1 + mass2)
    return Impact(vy=-restitution * vy, v1=v1 + share * (1.0 + restitution) * vy)
