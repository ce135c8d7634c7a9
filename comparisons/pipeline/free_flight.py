"""The first time a free flight reaches a wall: the gap d under constant acceleration, solved without cancellation.

    >>> from chatterbench.comparisons.pipeline.free_flight import first_root
    >>> float(first_root(1.0, 0.0, -2.0, 5.0))     # d = 1 m, at rest, pulled at 2 m/s^2: 1 s
    1.0

Units: d [m] (positive: apart), u [m/s] and a [m/s^2] its rate and acceleration (negative: closing), h [s]
the step searched.
"""

from __future__ import annotations

import numpy as np


def first_root(d, u, a, h):
    """Smallest s in [0, h] with d + u s + a s^2 / 2 = 0, elementwise; NaN where none.

    Uses the cancellation-free pair of quadratic roots (q = -(u + sign(u) sqrt(disc)) / 2,
    roots q / (a/2) and d / q) so that tiny d keeps full relative precision.
    """
    d, u, a, h = (np.asarray(v, dtype=float) for v in np.broadcast_arrays(d, u, a, h))
    half = 0.5 * a
    disc = u * u - 4.0 * half * d
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        q = -0.5 * (u + np.where(u >= 0.0, sq, -sq))
        r1 = np.where(half != 0.0, q / half, np.nan)
        r2 = np.where(q != 0.0, d / q, np.where(d == 0.0, 0.0, np.nan))
    out = np.full(d.shape, np.nan)
    for r in (r1, r2):
        ok = (r >= 0.0) & (r <= h) & ~(out <= r)
        out = np.where(ok, r, out)
    return np.where(d <= 0.0, 0.0, out)  # already on or past the wall
