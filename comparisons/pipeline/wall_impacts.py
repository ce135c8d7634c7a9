"""Every impact on one wall found in a trajectory's samples: contact onsets and velocity jumps between free samples,
each with its speeds, release, flight and bounds (``extract``'s rules 1 and 2).

    >>> import numpy as np
    >>> from chatterbench.comparisons.pipeline.wall_impacts import contact_runs
    >>> contact_runs(np.array([False, True, True, False, True]))       # runs 1..2 and 4..4 (the data end in it)
    (array([1, 4]), array([3, 5]))

The rules, the speeds' and times' error bounds and the units are ``extract``'s module docstring;
``impacts_on_wall`` works in the wall's normal coordinates (d, u, a: positive apart), ``extract``
turns its arrays into the ``IMPACT_COLUMNS`` and the event log.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene

from .extract_options import ExtractionOptions
from .free_flight import first_root
from .surface import surface_speed, surface_velocity

_STEP_BLOCK = 1 << 16  # steps examined at once for impacts between samples (memory, not results)


def contact_runs(contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Runs of contact samples: run i covers starts[i] .. stops[i] - 1; stops[i] is the first
    free sample after it, or n when the data end in contact. Arrays of int, shape (m,)."""
    edges = np.diff(np.concatenate(([0], np.asarray(contact, dtype=np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _release_times(t: np.ndarray, force: np.ndarray | None, starts: np.ndarray,
                   stops: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """When each contact run's force fell to zero [s] (NaN for a run the data end in), and how far that may be off [s].

    The zero of the line through the last two force samples, where the force decays towards it within the
    step after them (a pulling force, negative, decays the same way), else the middle of that step. Its bound:
    how far a quadratic through the last three force samples puts the zero from the line's, where both fall
    in the step; else the step itself from the estimate (the release is somewhere in it).
    """
    n = len(t)
    out, bound = np.full(len(starts), np.nan), np.full(len(starts), np.nan)
    done = stops < n
    last = stops[done] - 1
    t_last, t_next = t[last], t[stops[done]]
    rel = t_last + 0.5 * (t_next - t_last)
    if force is not None:
        prev, prev2 = np.maximum(last - 1, 0), np.maximum(last - 2, 0)
        f1, f0, f2 = np.abs(force[last]), np.abs(force[prev]), np.abs(force[prev2])
        ok = (last - 1 >= starts[done]) & (f1 > 0) & (f0 > f1) & (np.sign(force[last]) == np.sign(force[prev]))
        with np.errstate(divide="ignore", invalid="ignore"):
            zero = t_last + f1 / (f0 - f1) * (t_last - t[prev])
            inside = ok & (zero >= t_last) & (zero <= t_next)
            # the quadratic through the last three: f1 + c1 s + c2 s (s - sb), s = t - t_last
            sb, sa = t[prev] - t_last, t[prev2] - t_last
            c1 = (f0 - f1) / sb
            c2 = ((f2 - f0) / (sa - sb) - c1) / sa
            s_q = first_root(f1, c1 - c2 * sb, 2.0 * c2, t_next - t_last)
        rel = np.where(ok, np.clip(zero, t_last, t_next), rel)
        smooth = inside & (last - 2 >= starts[done]) & ~np.isnan(s_q)
        near = np.where(smooth, np.abs(t_last + np.nan_to_num(s_q) - rel), np.inf)
    else:
        near = np.full(len(last), np.inf)
    bound[done] = np.minimum(near, np.maximum(rel - t_last, t_next - rel))
    out[done] = rel
    return out, bound


def impacts_on_wall(traj: Trajectory, y: np.ndarray, vy: np.ndarray, scene: Scene, wall: str, acc: np.ndarray,
                    options: ExtractionOptions, offsets: Mapping[str, float] | None = None) -> dict:
    """Every impact on one wall, by time: arrays of the per-impact quantities (normal coordinates); ``y``, ``vy``
    the trajectory's gap and relative velocity, computed once by the caller."""
    t, n_s = traj.t, len(traj.t)
    nrm = 1.0 if wall == "lower" else -1.0
    # a contact skin (``offsets``): the body rests this far from the wall, so its surface is there
    d = nrm * (y - scene.gap.position(wall)) - (offsets or {}).get(wall, 0.0)
    u = nrm * vy
    a = nrm * acc
    flag = traj.contact.get(wall) if traj.contact else None
    contact = np.asarray(flag, dtype=bool) if flag is not None and len(flag) == n_s else d <= 0.0
    force = traj.normal_force.get(wall) if traj.normal_force else None
    force = np.asarray(force, dtype=float) if force is not None and len(force) == n_s else None
    starts, stops = contact_runs(contact)

    # (i) contact onsets: the last free sample before, carried forwards to the wall
    k = np.maximum(starts - 1, 0)
    s_in = first_root(d[k], u[k], a[k], t[starts] - t[k])
    t_in = np.where(np.isnan(s_in), t[starts], t[k] + np.nan_to_num(s_in))
    t_in_bound = np.where(np.isnan(s_in), t[starts] - t[k], 0.0)  # the parabola misses: somewhere in the step
    # the speeds where the body crosses the undeformed surface (surface.py): a soft contact lets go below it
    j_in = _free_neighbour(t, u, a, contact, k, -1, options)
    v_in = np.where(surface_velocity(t, d, u, a, k, j_in) < 0.0, -surface_speed(t, d, u, a, k, j_in),
                    u[k] + a[k] * (t_in - t[k]))
    at_start = starts == 0
    t_in, v_in = np.where(at_start, t[0], t_in), np.where(at_start, u[0], v_in)
    # the landing speed of the flight the last free sample is in, from that sample's own state (energy under the
    # pressing y'': sqrt(u^2 + 2 |a| d)); two samples' positions would span any bounce too short to see between them
    with np.errstate(invalid="ignore"):
        land = np.where((a[k] < 0.0) & ~at_start & ~contact[k], np.sqrt(u[k] ** 2 - 2.0 * a[k] * np.maximum(d[k], 0.0)), np.nan)
    released = stops < n_s
    e = np.minimum(stops, n_s - 1)  # the first free sample after, carried to where it crosses the surface
    j_out = _free_neighbour(t, u, a, contact, e, 1, options)
    s_out = first_root(d[e], -u[e], a[e], t[e] - t[np.maximum(e - 1, 0)])
    # a rebound (the free motion presses); at an exit (a >= 0) the free motion pulls the body out of a
    # resting penetration: no rebound to measure, its speed at release
    rebound = (surface_velocity(t, d, u, a, e, j_out) > 0.0) & (a[e] < 0.0)
    v_out = np.where(rebound, surface_speed(t, d, u, a, e, j_out), u[e] - a[e] * np.nan_to_num(s_out))
    v_out = np.where(released, v_out, np.nan)
    # a contact takes an unknown part of the steps it starts and ends in: each speed is known to |a| h there
    err = np.maximum(_speed_error(t, a, k, starts, np.full(len(starts), np.nan)),
                     _speed_error(t, a, np.maximum(e - 1, 0), e, np.full(len(starts), np.nan)))
    t_release, release_bound = _release_times(t, force, starts, stops)
    onset = {"t": t_in, "v_minus": v_in, "v_plus": v_out, "t_release": t_release, "first": starts,
             "begin": np.where(released, stops, n_s), "contact": np.ones(len(starts), bool),
             "v_error": np.where(at_start, np.nan, err), "t_bound": np.where(at_start, 0.0, t_in_bound),
             "release_bound": release_bound, "land_speed": land}

    # (ii) impacts between two free samples: a velocity jump the free motion cannot make
    ks = np.concatenate([np.empty(0, dtype=np.int64),
                         *(_jump_steps(t, d, u, a, contact, traj.index, options, lo)
                           for lo in range(0, n_s - 1, _STEP_BLOCK))])
    h = t[ks + 1] - t[ks] if len(ks) else np.empty(0)
    s_fwd = first_root(d[ks], u[ks], a[ks], h)
    # an impact needs the body to come to the wall: moving towards it, or carried there by the free motion
    # within the step; a body rising from the wall all through the step is lifting off, whatever its jump
    # (a file whose forcing runs ahead of the scene's leaves while the scene's y'' still presses)
    arrives = (u[ks] < 0.0) | ~np.isnan(s_fwd)
    ks, h, s_fwd = ks[arrives], h[arrives], s_fwd[arrives]
    s_bwd = first_root(d[ks + 1], -u[ks + 1], a[ks + 1], h)
    t_j = np.where(~np.isnan(s_fwd), t[ks] + s_fwd, np.where(~np.isnan(s_bwd), t[ks + 1] - s_bwd, t[ks + 1]))
    between = {"t": t_j, "v_minus": u[ks] + a[ks] * (t_j - t[ks]), "v_plus": u[ks + 1] - a[ks + 1] * (t[ks + 1] - t_j),
               "t_release": t_j, "first": ks + 1, "begin": ks + 1, "contact": np.zeros(len(ks), bool),
               "v_error": _speed_error(t, a, ks, ks + 1, s_fwd) + _speed_error(t, a, ks, ks + 1, s_bwd)}
    if options.position_rounding > 0:  # rounded positions move the parabola's root by 2 rounding / |u|, its speeds by |a| x that
        with np.errstate(divide="ignore"):
            between["v_error"] = between["v_error"] + 2.0 * options.position_rounding * np.maximum(
                np.abs(a[ks]), np.abs(a[ks + 1])) / np.maximum(np.abs(between["v_minus"]), np.abs(between["v_plus"]))
    between["t_bound"] = np.where(np.isnan(s_fwd) & np.isnan(s_bwd), h, 0.0)
    between["release_bound"] = between["t_bound"]
    between["land_speed"] = np.full(len(ks), np.nan)  # a landing the samples see: its own v_minus

    imp = {key: np.concatenate((onset[key], between[key])) for key in onset}
    order = np.argsort(imp["first"], kind="stable")
    imp = {key: v[order] for key, v in imp.items()}
    m = len(order)
    begin = imp["begin"]
    # the flight after each impact: from its first free sample up to the next impact's first sample
    nxt = np.append(imp["first"][1:], n_s)
    apex = np.full(m, -np.inf)
    has = begin < nxt
    if has.any():
        idx = begin[has]
        apex[has] = _segment_max(d, idx, nxt[has])
    a_rel = a[np.minimum(begin, n_s - 1)]
    flight = np.append(imp["t"][1:], np.nan) - imp["t_release"]  # to the next impact on this wall
    # the flight as its two ends see it: the rebound speed and the next impact's incoming speed each
    # imply a free flight of 2 |v| / |a|; a "flight" spanning bounces the samples cannot see is shorter
    with np.errstate(invalid="ignore", divide="ignore"):
        press = np.where(a_rel < 0.0, -a_rel, np.nan)
        seen = np.fmin(2.0 * imp["v_plus"] / press, 2.0 * np.abs(np.append(imp["v_minus"][1:], np.nan)) / press)
    flight_seen = np.where(np.isnan(press), flight, np.fmin(flight, seen))
    imp.update(apex=apex, a_release=a_rel, flight=flight, flight_seen=np.where(np.isnan(flight), np.nan, flight_seen), a_onset=a[np.maximum(imp["first"] - 1, 0)],
               n_samples=n_s, u_last=u[n_s - 1], next_first=nxt)  # not d, a, u: per sample, they are the memory
    return imp


def _free_neighbour(t, u, a, contact, k: np.ndarray, step: int, options: ExtractionOptions) -> np.ndarray:
    """k + ``step`` where that sample is free and the step between it and k is free flight (no velocity
    jump, rule 2's threshold), so that the two positions give the velocity (``surface.py``); else -1."""
    j = k + step
    ok = (j >= 0) & (j < len(t))
    jj = np.where(ok, j, k)
    h = np.abs(t[jj] - t[k])
    jump = np.abs(u[jj] - u[k] - 0.5 * (a[k] + a[jj]) * (t[jj] - t[k]))
    a_max = np.maximum(np.abs(a[k]), np.abs(a[jj]))
    limit = np.maximum(options.jump_atol, min(options.jump_factor, options.floor_steps) * a_max * h)
    fine = 2.0 * options.position_rounding <= 0.5 * a_max * h * h  # rounded positions would blur the velocity
    return np.where(ok & ~contact[jj] & ~contact[k] & (jj != k) & (jump <= limit) & fine, jj, -1)


def _speed_error(t: np.ndarray, a: np.ndarray, k: np.ndarray, k1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Bound on the error of a speed carried from sample ``k`` (or back from ``k1``) to the wall over ``s``
    [m/s]: the change of y'' over the step times the step, |a[k1] - a[k]| h, where the free parabola
    reaches the wall (``s`` finite), else |a| h (the impact is somewhere in the step)."""
    k, k1 = np.asarray(k, dtype=np.int64), np.asarray(k1, dtype=np.int64)
    h = t[k1] - t[k]
    return np.where(np.isnan(s), np.maximum(np.abs(a[k]), np.abs(a[k1])), np.abs(a[k1] - a[k])) * h


def _jump_steps(t, d, u, a, contact, index, options: ExtractionOptions, lo: int) -> np.ndarray:
    """Steps k in [lo, lo + _STEP_BLOCK) between two free samples with a velocity jump the free motion cannot
    make, near the wall (rule 2; a block at a time: the temporaries stay small however long the run)."""
    hi = min(len(t) - 1, lo + _STEP_BLOCK)
    k, k1 = slice(lo, hi), slice(lo + 1, hi + 1)
    dt = t[k1] - t[k]
    free_step = ~contact[k] & ~contact[k1]
    if index is not None:  # a compact trajectory: only steps between neighbouring samples
        free_step &= index[k1] - index[k] == 1
    jump = u[k1] - u[k] - 0.5 * (a[k] + a[k1]) * dt
    a_max = np.maximum(np.abs(a[k]), np.abs(a[k1]))
    # a jump of k |a| dt is a flight of k steps: one the samples resolve (floor_steps) is never hidden
    threshold = np.maximum(options.jump_atol, min(options.jump_factor, options.floor_steps) * a_max * dt)
    reach = np.maximum(np.abs(u[k]), np.abs(u[k1])) * dt + a_max * dt * dt
    near = np.minimum(d[k], d[k1]) <= reach
    return lo + np.flatnonzero(free_step & (jump > threshold) & near)


def _segment_max(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """max(values[lo[i]:hi[i]]) for non-empty segments in increasing, non-overlapping order.

    One ``reduceat`` over the interleaved bounds (lo0, hi0, lo1, hi1, ...): the even
    entries are the segments, the odd ones the gaps between them (a sentinel closes the last).
    """
    padded = np.append(values, -np.inf)
    return np.maximum.reduceat(padded, np.column_stack((lo, hi)).ravel())[::2]
