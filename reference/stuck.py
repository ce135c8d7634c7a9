"""Motion in kinematic constraint (1.4) until the exit, compiled: the sliding stretch's end.

    >>> import numpy as np
    >>> from chatterbench.reference.flow import Flow
    >>> from chatterbench.reference.linear import LinearSystem
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.reference.stuck import EXITED, walk
    >>> scene = load_scene("feigin-pair")                      # stuck on the lower wall at t = 2
    >>> system = LinearSystem.from_scene(scene)
    >>> stuck = Flow(system.stuck, horizon=scene.time_scale / 4)
    >>> flat = np.ascontiguousarray(stuck.powers.reshape(-1, system.size))
    >>> s = system.state(t=2.0, x1=0.0, v1=0.0, y=-0.1, vy=0.0)
    >>> code, t_exit, jmin, jmax = walk(flat, stuck.order, system.size, system.accel_row, s, 2.0, scene.t_end,
    ...                                 -0.1, 1.0, stuck.step, np.asarray(system.omegas), False, 0, 10**7)
    >>> code == EXITED, t_exit == np.pi                         # y'' = -sin t turns at pi
    (True, True)

Walks the constrained flow step by step from state ``s`` (updated in place) and finds the
first time the free relative acceleration (3.1), lambda = accel_row . s, reaches zero and
turns away from the wall (normal * lambda >= 0), as a root of its Taylor polynomial
(``roots.first_root_kernel``). With ``bounds`` it also returns the extremes of
normal * lambda' over the walk (Y*, Y of the plate conditions, ``plate.jerk_bounds``) and
stops early once Y* <= 0 (the strike cannot be in the plate). Same arithmetic as the
event loop's Python path it replaces, in one call per stretch.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .flow import evaluate_into, taylor_into
from .plate import jerk_bounds
from .roots import first_root_kernel

EXITED, RUN_END, BOUNDS_FAILED, STALLED = 0, 1, 2, 3


@numba.njit(cache=True)
def walk(flat, order, n, accel_row, s, t, t_end, wall_y, normal, step, omegas, bounds, deflate, max_steps):
    """Returns (code, t, Y*, Y): EXITED (s, t at the exit), RUN_END (at t_end; an exit within the
    roots' precision, 1e-14 relative, of t_end is the end of the run, so that both chatter modes
    agree on a tie), BOUNDS_FAILED,
    or STALLED (after ``max_steps`` steps, or when a step no longer advances t or leaves the
    state finite: absurd scene values such as a force of 1e100 N; s, t where it stopped).

    ``deflate``: leading coefficients of lambda to treat as zero on the first step (those
    the stick decision found to be rounding, ``simulate._Simulator._rest``).
    """
    m = order + 1
    coeffs = np.empty((m, n))
    lam = np.empty(m)
    jerk = np.empty(m - 1)
    jmin = math.inf
    jmax = -math.inf
    first = True
    steps = 0
    while True:
        steps += 1
        if steps > max_steps:
            return STALLED, t, jmin, jmax
        hl = min(step, t_end - t)
        if hl <= 0.0:
            return RUN_END, t, jmin, jmax
        taylor_into(flat, s, coeffs)  # A^k s / k!
        for k in range(m):
            acc_k = 0.0
            for i in range(n):
                acc_k += accel_row[i] * coeffs[k, i]
            lam[k] = -normal * acc_k  # positive while pressed into the wall
        skip = deflate if first else 0
        first = False
        zero = True
        for k in range(skip, m):
            zero = zero and lam[k] == 0.0
        # (3.1) is zero to rounding all along the step: no force pulls away, the contact stays
        r = math.nan if zero else first_root_kernel(lam, hl, skip, 1e-14)
        if r == r and t + r >= t_end - 1e-14 * max(1.0, abs(t_end)):
            r = math.nan  # an exit at the run's end, to the roots' precision: the run ends stuck
        span = hl if r != r else r
        if bounds and span > 0.0:
            for k in range(1, m):
                jerk[k - 1] = -lam[k] * k  # normal * lambda'
            lo, hi = jerk_bounds(jerk, span)
            jmin = min(jmin, lo)
            jmax = max(jmax, hi)
            if jmin <= 0.0:
                return BOUNDS_FAILED, t, jmin, jmax
        h = hl if r != r else r
        evaluate_into(coeffs, h, s)
        s[2] = wall_y
        s[3] = 0.0
        t_next = t + h
        finite = t_next - t_next == 0.0
        for i in range(n):
            finite = finite and s[i] - s[i] == 0.0
        if not finite or (t_next == t and r != r):
            return STALLED, t, jmin, jmax
        t = t_next
        if r == r:
            for j in range(len(omegas)):
                s[5 + 2 * j] = math.sin(omegas[j] * t)
                s[6 + 2 * j] = math.cos(omegas[j] * t)
            return EXITED, t, jmin, jmax
