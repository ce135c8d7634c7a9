"""The first root of a local Taylor polynomial on a step: where the next impact or exit happens.

    >>> from chatterbench.reference.roots import first_root
    >>> h = first_root([0.0, 0.2, -4.905], deflate=1, hmax=1.0)   # y = 0.2 h - g/2 h^2
    >>> round(h, 12)
    0.040774719674

The polynomial q(h) = sum_k c[k] h^(k - deflate) (the ``deflate`` leading coefficients are
treated as zero and divided out, and so are exact leading zeros, so a root at h ~ 1e-12
keeps full relative precision) is positive just after h = 0; ``first_root`` returns the
smallest h in (0, hmax] with q(h) <= 0, or ``None``. It samples q on a grid of ``GRID``
points, checks every local minimum between samples (so a grazing dip is not stepped
over), and polishes the bracket with safeguarded Newton iterations to ``rtol`` relative
precision (default 1e-14). The returned h always has q(h) <= 0: an event is never placed
before its root. The kernels are compiled with numba (``cache=True``): the event loop
calls them thousands of times per simulated second.
"""

from __future__ import annotations

import math

import numba
import numpy as np

GRID = 16  # samples per step


@numba.njit(cache=True)
def _horner(c, n, h):
    """Value and derivative of sum_{k<n} c[k] h^k."""
    p = 0.0
    dp = 0.0
    for k in range(n - 1, -1, -1):
        dp = dp * h + p
        p = p * h + c[k]
    return p, dp


@numba.njit(cache=True)
def _significant(c, h):
    """Number of leading coefficients that matter for |x| <= h in double precision."""
    big = 0.0
    x = 1.0
    for k in range(len(c)):
        m = abs(c[k]) * x
        if m > big:
            big = m
        x *= h
    n = 1
    x = 1.0
    for k in range(len(c)):
        if abs(c[k]) * x > 1e-18 * big:
            n = k + 1
        x *= h
    return n


@numba.njit(cache=True)
def _polish(c, a, b, guess, rtol):
    """Root of q in [a, b] with q(a) > 0 >= q(b): safeguarded Newton, ending on the q <= 0 side."""
    n = _significant(c, b)
    h = guess if a < guess < b else 0.5 * (a + b)
    for _ in range(200):
        q, dq = _horner(c, n, h)
        if q > 0.0:
            a = h
        else:
            b = h
        nxt = h - q / dq if dq != 0.0 else 0.5 * (a + b)
        if not a < nxt < b:
            nxt = 0.5 * (a + b)
        done = abs(nxt - h) <= rtol * abs(nxt) or b - a <= rtol * b
        h = nxt
        if done:
            break
    q, _ = _horner(c, n, h)
    if q <= 0.0:
        return h
    # converged from the positive side: widen a step until q <= 0, then bisect it
    d = max(rtol * abs(h), 1e-300)
    while h + d < b and _horner(c, n, h + d)[0] > 0.0:
        h += d
        d *= 2.0
    hi = min(h + d, b)
    for _ in range(60):
        mid = 0.5 * (h + hi)
        if not h < mid < hi:
            break
        if _horner(c, n, mid)[0] > 0.0:
            h = mid
        else:
            hi = mid
    return hi


@numba.njit(cache=True)
def first_root_kernel(c, hmax, deflate, rtol):
    """Compiled core of ``first_root``; returns NaN for 'no root' (see ``first_root``)."""
    start = deflate
    while start < len(c) and c[start] == 0.0:
        start += 1
    if start == len(c) or c[start] < 0.0:
        return 0.0
    m = len(c) - start
    q = np.empty(m)
    x = 1.0
    for k in range(m):  # scale to u = h / hmax in (0, 1]
        q[k] = c[start + k] * x
        x *= hmax
    prev_u = 0.0
    prev_d = 0.0  # q's slope just after u = 0: the sign of its first coefficient after q[0] that is not zero (a
    for k in range(1, m):  # start at rest, q[1] = 0, still dips when q[2] < 0: its minimum is looked for too)
        if q[k] != 0.0:
            prev_d = q[k]
            break
    for i in range(1, GRID + 1):
        u = i / GRID
        val, der = _horner(q, m, u)
        if val <= 0.0:
            guess = -1.0
            if m > 1 and q[1] < 0.0 and i == 1:
                # leading-order estimate near u = 0 (linear, with a quadratic correction)
                g = -q[0] / q[1]
                if m > 2 and q[2] != 0.0:
                    disc = q[1] * q[1] - 4.0 * q[2] * q[0]
                    if disc >= 0.0:
                        g = 2.0 * q[0] / (-q[1] + math.sqrt(disc))
                guess = g
            return hmax * _polish(q, prev_u, u, guess, rtol)
        if prev_d < 0.0 <= der:
            # a local minimum in (prev_u, u): find it by bisection on q' and test its sign
            lo, hi = prev_u, u
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if _horner(q, m, mid)[1] < 0.0:
                    lo = mid
                else:
                    hi = mid
                if hi - lo <= 1e-16:
                    break
            umin = 0.5 * (lo + hi)
            if _horner(q, m, umin)[0] <= 0.0:
                return hmax * _polish(q, prev_u, umin, -1.0, rtol)
        prev_u, prev_d = u, der
    return math.nan


def first_root(c, hmax: float, deflate: int = 0, rtol: float = 1e-14) -> float | None:
    """Smallest h in (0, hmax] where q(h) = sum_k c[k + deflate] h^k reaches <= 0.

    Parameters
    ----------
    c : sequence of float
        Taylor coefficients of the function (units of the function per s^k).
    hmax : float
        End of the search interval [s].
    deflate : int
        Number of leading coefficients to treat as zero whatever their value (after an
        exit, y'' = 0 up to rounding); exact leading zeros are divided out anyway.
    rtol : float
        Relative precision of the returned root.

    Returns
    -------
    float or None
        The root, 0.0 when q is not positive at h = 0+, or None when q > 0 on (0, hmax].
    """
    r = first_root_kernel(np.asarray(c, dtype=float), float(hmax), int(deflate), float(rtol))
    return None if math.isnan(r) else r


@numba.njit(cache=True)
def first_wall_root(ycoef, y, walls, normals, deflate, hmax, rtol):
    """First strike on any wall within (0, hmax]: returns (h, wall index), or (NaN, -1).

    ``ycoef`` are the Taylor coefficients of y(t0 + h); wall j is at ``walls[j]`` [m] with
    wall-normal sign ``normals[j]`` (+1 lower, -1 upper) and ``deflate[j]`` coefficients
    of its gap function known to vanish (see ``first_root``).
    """
    best = math.nan
    best_j = -1
    p = np.empty(len(ycoef))
    for j in range(len(walls)):
        n = normals[j]
        for k in range(len(ycoef)):
            p[k] = n * ycoef[k]
        p[0] = n * (y - walls[j])
        r = first_root_kernel(p, hmax, deflate[j], rtol)
        if r == r and (best_j < 0 or r < best):
            best = r
            best_j = j
    return best, best_j
