"""Durations read from sample times, held against whole steps: ties at the sampling step (issue 43).

    >>> from chatterbench.comparisons.pipeline.sample_grid import more_than_a_step, at_least_steps, shorter
    >>> more_than_a_step(0.05 - 0.03, 0.02), more_than_a_step(0.0201, 0.02), more_than_a_step(0.019, 0.02)
    (False, True, False)
    >>> bool(at_least_steps(0.009999999999999787, 10, 1e-3)), bool(at_least_steps(0.0099, 10, 1e-3))
    (True, False)
    >>> shorter(0.011805999999999983, 0.011806000000000001, 0.00472236), shorter(0.0071, 0.0118, 0.00472236)
    (False, True)

A run carries its timestep dt [s] (``engines/trajectory.py``), but its sample times lie on the grid t = k dt only
to their rounding, a few ulps of t: PyBullet's flights of 0.05 s and 0.03 s at dt 0.02 s differ by
0.020000000000000018 s, and a MuJoCo flight of ten steps of 1e-3 s reads 0.009999999999999787 s. A duration within
``GRID_RTOL`` of a whole number of steps *is* that number of steps: "more than a step" excludes one step, "at least
n steps" includes n, and two flights of the same number of steps are equal, neither shorter. Before the run carried dt, the step was the samples' median spacing, whose own rounding decided
these ties either way from run to run.
"""

from __future__ import annotations

import numpy as np

GRID_RTOL = 1e-9  # [-] a duration within this fraction of whole steps is those steps (sample-time rounding: ~1e-13)


def more_than_a_step(duration: float, dt: float) -> bool:
    """Whether ``duration`` [s], a difference of sample times, is more than one step ``dt`` [s]; one step to the
    rounding of the sample times is not more."""
    return duration > dt * (1.0 + GRID_RTOL)


def at_least_steps(duration, steps: float, dt: float):
    """Whether ``duration`` [s] (a float or an array; NaN: False) lasts at least ``steps`` steps of ``dt`` [s];
    exactly that many to the rounding of the sample times is at least."""
    return np.asarray(duration) >= steps * dt * (1.0 - GRID_RTOL)


def shorter(duration: float, other: float, dt: float) -> bool:
    """Whether ``duration`` [s] is shorter than ``other`` [s], both read from sample times at step ``dt`` [s]: by
    more than their rounding (two flights of the same steps are equal)."""
    return duration < other - dt * GRID_RTOL
