"""Exact propagation of s' = A s by local Taylor expansion of the matrix exponential.

    >>> import numpy as np
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.reference.flow import Flow
    >>> from chatterbench.reference.linear import LinearSystem
    >>> system = LinearSystem.from_scene(load_scene("feigin-pair"))
    >>> flow = Flow(system.free, horizon=2 * np.pi)
    >>> s0 = system.state(t=0.0, x1=0.0, v1=0.0, y=0.0, vy=0.0)
    >>> flow.taylor(s0).shape             # (order + 1, n): s(t0 + h) = sum_k coeffs[k] h^k
    (29, 7)
    >>> s1 = flow.advance(s0, 0.3)        # s(t0 + 0.3): y = -(0.3 - sin 0.3)
    >>> bool(abs(s1[2] + (0.3 - np.sin(0.3))) < 1e-14)
    True

expm(A h) = sum_k (A h)^k / k! is evaluated as a truncated series on steps no longer than
``step``, chosen so that rho * step <= 3/2 with rho an estimate of the growth rate of A
(max of ||A^k||^(1/k) over k in [order/2, order], close to the spectral radius); with ``order`` = 28 the truncated tail is below
(3/2)^29 / 29! ~ 1e-26 of the leading term, far under double precision, and the terms
never exceed e^(3/2) ~ 4.5 times the result, so at most one digit is lost to cancellation. Longer
intervals are walked in whole steps. The Taylor coefficients of the state are also the
exact local expansion used by the root finder: an impact time h after an impact solves
c_1 + c_2 h + ... = 0 (the zero c_0 divided out), which keeps full relative precision
when h shrinks to 1e-12 s and below.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np


class Flow:
    """The exact flow of s' = A s.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        The generator.
    horizon : float
        Longest step ever needed [s] (the scene's time scale); caps ``step`` when A is
        nilpotent (constant forcing only) and rho = 0.
    order : int
        Degree of the truncated series (default 28).
    """

    def __init__(self, A: np.ndarray, horizon: float, order: int = 28) -> None:
        self.A = np.asarray(A, dtype=float)
        self.order = order
        n = self.A.shape[0]
        powers = np.empty((order + 1, n, n))
        powers[0] = np.eye(n)
        with np.errstate(over="ignore", invalid="ignore"):  # absurd scales overflow: caught just below
            for k in range(1, order + 1):
                powers[k] = powers[k - 1] @ self.A / k  # A^k / k!
        self.powers = powers
        self._flat = np.ascontiguousarray(powers.reshape((order + 1) * n, n))  # one GEMV per expansion
        # ||A^k||^(1/k) tends to the spectral radius and does not depend on the units of
        # the state; the high powers are the ones that set the truncation error, so the
        # estimate takes k in [order/2, order] (0 when A is nilpotent: constant forcing)
        growth = 0.0
        for k in range(order // 2, order + 1):
            norm = np.abs(powers[k]).sum(axis=1).max() * math.factorial(k)
            if norm > 0.0:
                growth = max(growth, norm ** (1.0 / k))
        if not np.isfinite(powers).all():  # A^k overflowed (a stiffness of 1e300 N/m, say): the series is
            # unusable; ||A||_inf bounds the spectral radius, so the step it gives is honest and tiny, and
            # the simulator's step budget refuses the run ("stalled") instead of walking NaN states
            growth = max(growth, float(np.abs(self.A).sum(axis=1).max()))
        self.growth = growth  # [1/s]
        self.step = horizon if growth == 0.0 else min(horizon, 1.5 / growth)
        self.step_matrix = self.matrix(self.step)  # expm(A step)

    def matrix(self, h: float) -> np.ndarray:
        """expm(A h) for 0 <= h <= step, shape (n, n)."""
        hp = h ** np.arange(self.order + 1)
        return np.tensordot(hp, self.powers, axes=1)

    def taylor(self, s: np.ndarray) -> np.ndarray:
        """Taylor coefficients of s(t0 + h) in h, shape (order + 1, n): row k is A^k s / k!."""
        return (self._flat @ s).reshape(self.order + 1, -1)

    def advance(self, s: np.ndarray, h: float) -> np.ndarray:
        """s(t0 + h) for any h >= 0 [s], walking whole steps then the remainder."""
        while h > self.step:
            s = self.step_matrix @ s
            h -= self.step
        return evaluate(self.taylor(s), h)


def shared_flow(A: np.ndarray, horizon: float) -> Flow:
    """``Flow(A, horizon)``, built once per generator and horizon and shared (every run and every sampling of a
    scene needs the same two): read it, never change it."""
    a = np.ascontiguousarray(A, dtype=float)
    return _shared(a.tobytes(), a.shape, horizon)


@functools.lru_cache(maxsize=64)
def _shared(generator: bytes, shape: tuple[int, int], horizon: float) -> Flow:
    return Flow(np.frombuffer(generator).reshape(shape), horizon=horizon)


@numba.njit(cache=True)
def evaluate(coeffs: np.ndarray, h: float) -> np.ndarray:
    """sum_k coeffs[k] h^k for Taylor coefficients of shape (order + 1, n) (Horner)."""
    m, n = coeffs.shape
    out = coeffs[m - 1].copy()
    for k in range(m - 2, -1, -1):
        for i in range(n):
            out[i] = out[i] * h + coeffs[k, i]
    return out


@numba.njit(cache=True)
def taylor_into(flat: np.ndarray, s: np.ndarray, coeffs: np.ndarray) -> None:
    """Compiled ``Flow.taylor``: coeffs[k] = A^k s / k! from the stacked powers ``flat``, shape ((order+1) n, n)."""
    m, n = coeffs.shape
    for k in range(m):
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += flat[k * n + i, j] * s[j]
            coeffs[k, i] = acc


@numba.njit(cache=True)
def evaluate_into(coeffs: np.ndarray, h: float, out: np.ndarray) -> None:
    """Compiled ``evaluate``: out = sum_k coeffs[k] h^k (Horner), in place."""
    m, n = coeffs.shape
    for i in range(n):
        acc = coeffs[m - 1, i]
        for k in range(m - 2, -1, -1):
            acc = acc * h + coeffs[k, i]
        out[i] = acc
