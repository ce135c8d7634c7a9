"""Follow one strike's impact sequence to its end, compiled: does it slide or leave?

    >>> import numpy as np
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.reference.chatter import strike_fates
    >>> fate = strike_fates(load_scene("feigin-pair"), "lower", t=np.array([2.0, 2.5]), v=np.array([-0.05, -0.05]))
    >>> fate.slides, fate.t_stick.round(4), fate.n_impacts
    (array([ True,  True]), array([2.1121, 2.6831]), array([26, 26]))

This is the exhaustive chatter model of ``simulate.py`` (every impact by (1.3), the
accumulation point summed in closed form once dt* = 2 v+ / ((1 - R) |a|) drops below
``accumulation_time``) for many strikes at once, in one numba kernel, so that the true
sliding region of Feigin's plate can be mapped over strike phase and incoming speed
(100,000 strikes in seconds). A strike's sequence ends in one of four ways:

- ``SLIDES``: the impacts accumulate (the Zeno point) while y'' still presses into the wall;
- ``LEAVES``: a flight ends on the other wall, lasts longer than ``max_flight``, or an
  impact finds y'' pointing away from the wall with nothing left to accumulate;
- ``OPEN``: ``max_impacts`` impacts or the time limit were reached first (undecided).

Same flow, same root finder, same impact law as the event loop: a strike fed to both
gives the same Zeno time to rounding (tested).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .flow import Flow, evaluate_into, taylor_into
from .linear import LinearSystem
from .roots import first_root_kernel
from .scene import Scene, SceneError

SLIDES, LEAVES, OPEN = 1, 0, -1


class StrikeFates(NamedTuple):
    """Outcome of each strike; arrays of the strikes' shape."""

    slides: np.ndarray  # bool: the sequence accumulated into sliding on the struck wall
    outcome: np.ndarray  # int: SLIDES, LEAVES or OPEN
    t_stick: np.ndarray  # [s] Zeno point (NaN unless it slides)
    n_impacts: np.ndarray  # impacts followed, the strike included


@numba.njit(cache=True)
def _follow(flat, order, n, accel_row, s0, t0, wall, normal, other, has_other, R, share, acc_time,
            rtol, step, max_flight, t_max, max_impacts, omegas):
    s = s0.copy()
    t = t0
    count = 0
    m = order + 1
    coeffs = np.empty((m, n))
    yc = np.empty(m)
    while count < max_impacts:
        # impact (1.3) on the struck wall
        vy = s[3]
        acc = 0.0
        for i in range(n):
            acc += accel_row[i] * s[i]
        acc *= normal
        vplus = -R * vy
        s[1] = s[1] + share * (1.0 + R) * vy
        s[3] = vplus
        count += 1
        if acc < 0.0:
            dt_star = 2.0 * normal * vplus / ((1.0 - R) * -acc)
            if dt_star <= acc_time:
                return SLIDES, t + dt_star, count
        elif normal * vplus <= 0.0:
            return LEAVES, math.nan, count
        # free flight to the next strike, on either wall
        flown = 0.0
        deflate = 1
        hit = False
        while not hit:
            if t >= t_max or flown >= max_flight:
                return (OPEN if t >= t_max else LEAVES), math.nan, count
            hl = min(step, t_max - t, max_flight - flown)
            taylor_into(flat, s, coeffs)  # A^k s / k!
            for k in range(m):
                yc[k] = normal * coeffs[k, 2]
            yc[0] = normal * (s[2] - wall)
            h = first_root_kernel(yc, hl, deflate, rtol)
            h_other = math.nan
            if has_other:
                for k in range(m):
                    yc[k] = -normal * coeffs[k, 2]
                yc[0] = -normal * (s[2] - other)
                h_other = first_root_kernel(yc, hl, 0, rtol)
            if h_other == h_other and (h != h or h_other < h):
                return LEAVES, math.nan, count
            hh = hl if h != h else h
            # evaluate the state at hh (Horner over the Taylor rows)
            evaluate_into(coeffs, hh, s)
            t += hh
            flown += hh
            for j in range(len(omegas)):
                s[5 + 2 * j] = math.sin(omegas[j] * t)
                s[6 + 2 * j] = math.cos(omegas[j] * t)
            deflate = 0
            if h == h:
                s[2] = wall
                hit = True
    return OPEN, math.nan, count


@numba.njit(cache=True)
def _follow_many(flat, order, n, accel_row, states, times, wall, normal, other, has_other, R, share,
                 acc_time, rtol, step, max_flight, t_max_rel, max_impacts, omegas, outcome, t_stick, n_imp):
    for i in range(len(times)):
        o, ts, c = _follow(flat, order, n, accel_row, states[i], times[i], wall, normal, other, has_other, R,
                           share, acc_time, rtol, step, max_flight, times[i] + t_max_rel, max_impacts, omegas)
        outcome[i] = o
        t_stick[i] = ts
        n_imp[i] = c


def strike_fates(
    scene: Scene,
    wall: str,
    t,
    v,
    x1=0.0,
    v1=0.0,
    accumulation_time: float | None = None,
    max_flight: float | None = None,
    horizon: float | None = None,
    max_impacts: int = 100_000,
) -> StrikeFates:
    """Follow strikes on ``wall`` at times ``t`` [s] with incoming relative speed ``v`` [m/s].

    Parameters
    ----------
    t, v : array_like
        Strike times and incoming relative velocities y' (into the wall: v < 0 on the lower
        wall, v > 0 on the upper), broadcast together.
    x1, v1 : float or array_like
        Body 1 position [m] and velocity [m/s] at the strike (matter only when forces
        depend on them).
    accumulation_time : float, optional
        dt* below which the sequence is summed [s]; default 1e-9 * scene.time_scale.
    max_flight : float, optional
        A flight longer than this counts as leaving [s]; default half the time scale.
    horizon : float, optional
        Time after the strike by which the sequence must end [s]; default the time scale.
    """
    if wall not in scene.gap.walls:
        raise SceneError(f"wall = {wall!r}: must be one of {', '.join(scene.gap.walls)}")
    t, v, x1, v1 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (t, v, x1, v1)))
    shape = t.shape
    t, v, x1, v1 = (a.ravel() for a in (t, v, x1, v1))
    system = LinearSystem.from_scene(scene)
    flow = Flow(system.free, horizon=scene.time_scale / 4.0)
    n = system.size
    y_wall = scene.gap.position(wall)
    normal = 1.0 if wall == "lower" else -1.0
    other_name = "upper" if wall == "lower" else "lower"
    has_other = other_name in scene.gap.walls
    other = scene.gap.position(other_name) if has_other else 0.0
    states = np.empty((len(t), n))
    for i in range(len(t)):
        states[i] = system.state(t[i], x1[i], v1[i], y_wall, v[i])
    share = 0.0 if scene.body1_infinite else scene.mass2 / (scene.mass1 + scene.mass2)
    outcome = np.empty(len(t), dtype=np.int64)
    t_stick = np.empty(len(t))
    n_imp = np.empty(len(t), dtype=np.int64)
    _follow_many(
        np.ascontiguousarray(flow.powers.reshape(-1, n)), flow.order, n, system.accel_row, states, t,
        y_wall, normal, other, has_other, scene.restitution, share,
        accumulation_time or 1e-9 * scene.time_scale, 1e-14, flow.step,
        max_flight or 0.5 * scene.time_scale, horizon or scene.time_scale, max_impacts,
        np.asarray(system.omegas, dtype=float), outcome, t_stick, n_imp,
    )
    return StrikeFates(
        slides=(outcome == SLIDES).reshape(shape), outcome=outcome.reshape(shape),
        t_stick=t_stick.reshape(shape), n_impacts=n_imp.reshape(shape),
    )


# codes returned by ``chase``
CHASE_LEFT, CHASE_STRIKE, CHASE_ACCUMULATED = 0, 1, 2


@numba.njit(cache=True)
def chase(flat, order, n, accel_row, jerk_row, s, t, t_end, wall, normal, other, has_other, R, share,
          acc_time, rtol, step, omegas, check_plate, out):
    """Follow a chatter sequence on one wall from just after an impact, logging every impact.

    ``s`` (the state just after an impact at time ``t``, y exactly on ``wall``) is updated
    in place. Impacts go into ``out`` (rows: t, v_minus, v_plus, x1, v1). Stops and returns
    (code, impacts logged, t):

    - ``CHASE_LEFT``: the next strike on this wall is not within one flow step, or the other
      wall comes first: ``s``, ``t`` are still just after the last logged impact;
    - ``CHASE_STRIKE``: a strike the caller must resolve itself (y'' not into the wall, or,
      with ``check_plate``, a strike that ``plate.quick_reject`` does not rule out):
      ``s``, ``t`` are at that strike, before its impact;
    - ``CHASE_ACCUMULATED``: after the last logged impact dt* <= acc_time: ``s``, ``t`` are
      just after it, and the caller sums the rest.
    """
    m = order + 1
    coeffs = np.empty((m, n))
    yc = np.empty(m)
    count = 0
    while count < out.shape[0]:
        hl = min(step, t_end - t)
        if hl <= 0.0:
            return CHASE_LEFT, count, t
        taylor_into(flat, s, coeffs)  # A^k s / k!
        for k in range(m):
            yc[k] = normal * coeffs[k, 2]
        yc[0] = 0.0
        h = first_root_kernel(yc, hl, 1, rtol)
        if h != h:
            return CHASE_LEFT, count, t
        if has_other:
            for k in range(m):
                yc[k] = -normal * coeffs[k, 2]
            yc[0] = -normal * (s[2] - other)
            h_other = first_root_kernel(yc, hl, 0, rtol)
            if h_other == h_other and h_other < h:
                return CHASE_LEFT, count, t
        # the strike: state at t + h, y exactly on the wall, forcing re-seeded
        evaluate_into(coeffs, h, s)
        s[2] = wall
        t_hit = t + h
        for j in range(len(omegas)):
            s[5 + 2 * j] = math.sin(omegas[j] * t_hit)
            s[6 + 2 * j] = math.cos(omegas[j] * t_hit)
        vy = s[3]
        acc = 0.0
        jerk = 0.0
        for i in range(n):
            acc += accel_row[i] * s[i]
            jerk += jerk_row[i] * s[i]
        acc *= normal
        jerk *= normal
        v = normal * vy
        if acc >= 0.0 or v >= 0.0 or R == 0.0:
            return CHASE_STRIKE, count, t_hit
        if check_plate and jerk > 0.0 and -v < 5.0 * (1.0 - R) / (24.0 * R * jerk) * acc * acc:
            return CHASE_STRIKE, count, t_hit  # a plate candidate: the caller runs the full test
        # impact (1.3)
        vplus = -R * vy
        s[1] = s[1] + share * (1.0 + R) * vy
        s[3] = vplus
        out[count, 0] = t_hit
        out[count, 1] = vy
        out[count, 2] = vplus
        out[count, 3] = s[0]
        out[count, 4] = s[1]
        count += 1
        t = t_hit
        dt_star = 2.0 * normal * vplus / ((1.0 - R) * -acc)
        if dt_star <= acc_time:
            return CHASE_ACCUMULATED, count, t
    return CHASE_LEFT, count, t
