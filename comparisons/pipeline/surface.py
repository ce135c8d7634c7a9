"""Speeds where a body crosses the wall's undeformed surface, d = 0: what restitution is defined on.

    >>> import numpy as np
    >>> from chatterbench.comparisons.pipeline.surface import surface_speed
    >>> t = np.array([0.0, 0.1]); a = np.full(2, -10.0)           # a free flight under y'' = -10, up through d = 0
    >>> d = -0.05 + 1.5 * t + 0.5 * a * t**2                      # 5 cm below the surface at t = 0, rising at 1.5 m/s
    >>> u = 1.5 + a * t
    >>> round(float(surface_speed(t, d, u, a, 0, 1)), 6), round(float(np.sqrt(1.5**2 - 2 * 10 * 0.05)), 6)
    (1.118034, 1.118034)

Newton's law y'+ = -R y'- is about the flight before and after a contact: for a rigid contact
the speeds just before and after it, for a compliant (soft) one the speeds where the body
reaches the undeformed surface and where it crosses it again on its way out. A soft contact
lets go of the body below the surface (MuJoCo's force falls to zero with the body still in
the wall) and the free motion still slows it on its way up: the speed at release is more than
the one the next flight sees (MuJoCo, ball, dt = 3e-4, w0 dt = 0.1, its 4th impact at
0.52 m/s: e = 0.499 at release, 0.477 at the surface, which is what its bounce heights give).

The speed at the surface is that of the free flight of constant acceleration a through sample
k (position d_k, velocity v_k), carried to d = 0 by energy: v^2 = v_k^2 - 2 a d_k, forwards
(from below the surface) or backwards (from above). v_k is taken from the *positions* of two
free samples k and j (``j`` >= 0: the parabola through them, (d_j - d_k) / h - a h / 2, h =
t_j - t_k) where there are two, else the sample's velocity u_k: a semi-implicit Euler step
(MuJoCo, PyBullet) samples y' half a step away from y (an error |a| h / 2), while its free
positions lie on the parabola the scene's flight then follows. Exact for a constant force; a
time-dependent one moves a by a' h, O(a' h^2) in v. A flight that never reaches the surface
(v_k^2 < 2 a d_k) gives 0. Used by the judge (``extract.py``, every contact's speeds) and the
calibration strikes (``studies/restitution_curve.wall_rebound``), so both measure one e.
"""

from __future__ import annotations

import numpy as np


def surface_speed(t: np.ndarray, d: np.ndarray, u: np.ndarray, a: np.ndarray, k, j) -> np.ndarray:
    """|y'| where the free flight through sample ``k`` meets d = 0 [m/s] (module docstring), elementwise.

    ``t``, ``d``, ``u``, ``a``: per sample, in the wall's normal (distance [m], velocity [m/s], free
    acceleration [m/s^2]); ``k``: the sample(s); ``j``: a free neighbour of each (k +- 1) whose
    position gives the velocity, or -1 (None for a scalar) to use u[k].
    """
    v_k = surface_velocity(t, d, u, a, k, j)
    k = np.asarray(k, dtype=np.int64)
    return np.sqrt(np.maximum(v_k * v_k - 2.0 * a[k] * d[k], 0.0))


def surface_velocity(t: np.ndarray, d: np.ndarray, u: np.ndarray, a: np.ndarray, k, j) -> np.ndarray:
    """The velocity v_k of ``surface_speed`` itself (signed [m/s]): from the positions of k and j, else u[k]."""
    k = np.asarray(k, dtype=np.int64)
    j = np.asarray(-1 if j is None else j, dtype=np.int64)
    jj = np.where(j >= 0, j, k)
    h = t[jj] - t[k]
    with np.errstate(divide="ignore", invalid="ignore"):
        from_positions = (d[jj] - d[k]) / h - 0.25 * (a[k] + a[jj]) * h
    return np.where((j >= 0) & (h != 0.0), from_positions, u[k])
