"""Recover the reference's events (impacts, sticking, exits) from any sampled trajectory.

    >>> traj = run(scene, MujocoSettings(dt=1e-4))          # or reference_trajectory(...)
    >>> log = extract_events(traj, scene)                   # event log, ``log.py`` format
    >>> extract_episodes(traj, scene)[["wall", "t_stick", "t_exit"]]

The extracted log speaks the vocabulary of ``reference/log.py`` (``impact``, ``stick``,
``exit``; never ``plate_entry``: an engine cannot know Feigin's plate), so
``episodes(extract_events(traj, scene))`` is derived exactly as the reference's episodes
are. Everything is measured from the samples; the scene is used only for the wall
positions and for y'' of the free motion (Feigin (1.2)), which extrapolates the sampled
velocity to an impact instant.

Per wall, with n = +1 (lower) or -1 (upper), the wall-normal distance d = n (y - y_wall),
velocity u = n y' and free acceleration a = n y''_free at every sample:

- **contact** at a sample: the trajectory's contact flag, or d <= ``wall_tolerance``
  (on or past the wall). Contact intervals are runs of contact samples, with free gaps of
  at most ``bridge_steps`` samples bridged (``contact_intervals``): such a flight is an
  unresolved micro-bounce, e.g. a rigid engine resting on a wall alternates one contact
  step with one or two free ones.
- **impact**: (i) the onset of a contact interval, or (ii) a step k -> k+1 with both samples
  free whose velocity jump J = u[k+1] - u[k] - (a[k] + a[k+1]) dt / 2 exceeds
  max(``jump_atol``, ``jump_factor`` |a| dt) while the wall is within one step's travel
  (an impact that happened between two samples, as in the exact reference, or in an
  engine whose contact flag missed it). Sub-step chatter whose bounces are slower than
  about ``jump_factor`` |a| dt is not resolved as separate impacts.
- **stick**: a contact interval that lasts longer than ``stick_threshold(traj, options)``,
  by default max(20 dt, 5 x the engine's contact time) (the one definition); logged at
  the interval's onset, after that onset's impact (v_plus = 0), with rule ``contact``.
  Shorter intervals are the bounces: impacts. This is the final contact of a chatter
  sequence that persists beyond the contact's own time scale.
- **exit**: the first free sample after a stick interval (contact flag down and y off the
  wall).

Estimators and their errors (exact samples, step dt; an engine adds its own O(dt)):

- impact time: the smallest root in the step of the free parabola from the last free
  sample, d + u s + a s^2 / 2 = 0; error O(|a'| dt^3 / |u|). When the parabola does not
  reach the wall in that step (e.g. a contact flag raised by a margin before touching),
  the onset sample's time: error <= dt.
- v_minus: the last free sample's velocity carried to the impact instant with the free
  acceleration, u + a s; error O(|a'| dt^2) (a single free sample suffices, which matters
  inside chatter). v_plus: the same from the first free sample after the contact, carried
  back to where its backward parabola leaves the wall.
- stick time: the onset impact's time (<= dt from the first contact sample). Exit time:
  the first free sample, 0 to dt after the true separation.

Promises: the log is sorted by time (at one time: exit, impact, stick); every stick is
followed by an exit unless the data end in contact; the work is vectorised over samples,
with Python loops only over events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.forces import evaluate_forces, relative_acceleration
from chatterbench.reference.log import episodes, log_frame
from chatterbench.reference.scene import Scene, SceneError

STICK_RULE = "contact"  # the ``rule`` of an extracted stick: a contact that persisted
_KIND_ORDER = {"exit": 0, "impact": 1, "stick": 2}  # at one time: leave, strike, then stick


@dataclass(frozen=True)
class ExtractionOptions:
    """Tolerances of the event extraction (see the module docstring for their role)."""

    stick_min_duration: float | None = None  # [s] contact longer than this is sticking; None: stick_threshold's default
    stick_min_steps: int = 20  # [samples] the default threshold is at least this many steps
    stick_contact_factor: float = 5.0  # [-] ... and at least this many engine contact durations
    wall_tolerance: float = 0.0  # [m] a sample with y within this of a wall (or past it) is in contact
    bridge_steps: int = 3  # [samples] free gaps this short between contacts are unresolved micro-bounces
    jump_factor: float = 2.0  # [-] a free step hides an impact if its velocity jump exceeds this times |y''| dt
    jump_atol: float = 1e-9  # [m/s] ... and this absolute floor (for |y''| = 0)

    def __post_init__(self) -> None:
        d = self.stick_min_duration
        if d is not None and not (isinstance(d, (int, float)) and math.isfinite(d) and d > 0):
            raise SceneError(f"stick_min_duration = {d!r}: must be a finite number > 0 [s], or None for the default")
        if isinstance(self.stick_min_steps, bool) or not isinstance(self.stick_min_steps, int) or self.stick_min_steps < 1:
            raise SceneError(f"stick_min_steps = {self.stick_min_steps!r}: must be an integer >= 1")
        if isinstance(self.bridge_steps, bool) or not isinstance(self.bridge_steps, int) or self.bridge_steps < 0:
            raise SceneError(f"bridge_steps = {self.bridge_steps!r}: must be an integer >= 0")
        for name in ("stick_contact_factor", "wall_tolerance", "jump_factor", "jump_atol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise SceneError(f"{name} = {v!r}: must be a finite number >= 0")


def engine_contact_time(traj: Trajectory) -> float:
    """Duration of one engine contact [s] from ``traj.settings`` (0 for rigid contacts).

    Read from ``contact_time``, else ``contact_duration`` (the MuJoCo adapter's name).
    """
    for key in ("contact_time", "contact_duration"):
        value = traj.settings.get(key)
        if value is not None and math.isfinite(float(value)):
            return float(value)
    return 0.0


def stick_threshold(traj: Trajectory, options: ExtractionOptions | None = None) -> float:
    """The one definition of sticking: a contact interval longer than this [s] is a stick.

    Default: max(``stick_min_steps`` dt, ``stick_contact_factor`` * contact time), i.e. a
    contact that outlasts both the sampling and the engine's own contact time scale (a
    soft-contact bounce lasts about one contact time; a rigid one, one or two steps).
    ``options.stick_min_duration`` overrides it.
    """
    options = options or ExtractionOptions()
    if options.stick_min_duration is not None:
        return float(options.stick_min_duration)
    dt = traj.dt if len(traj.t) > 1 else 0.0
    return max(options.stick_min_steps * dt, options.stick_contact_factor * engine_contact_time(traj))


def free_relative_acceleration(scene: Scene, t, x1, v1, y, vy) -> np.ndarray:
    """y'' of the free motion [m/s^2] at every sample, Feigin (1.2); arrays of shape (n,).

    ``reference.forces.relative_acceleration`` vectorised, also for a prescribed body 1
    (whose ``Prescribed.acceleration`` takes scalars only).
    """
    t = np.asarray(t, dtype=float)
    if scene.body1_infinite and scene.prescribed is not None:
        _, f2, f12 = evaluate_forces(scene, t, x1, v1, y, vy)
        p = scene.prescribed
        x1dd = -p.amplitude * p.omega**2 * np.sin(p.omega * t + p.phase)
        return np.broadcast_to((f2 - f12) / scene.mass2 - x1dd, t.shape).astype(float)
    return np.broadcast_to(np.asarray(relative_acceleration(scene, t, x1, v1, y, vy), dtype=float), t.shape).astype(float)


def _first_root(d, u, a, h):
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
    out = np.where(d <= 0.0, 0.0, out)  # already on or past the wall
    return out


def contact_intervals(contact: np.ndarray, bridge_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Runs of contact samples, with free gaps of at most ``bridge_steps`` samples bridged.

    Parameters
    ----------
    contact : ndarray of bool, shape (n,)
    bridge_steps : int
        A flight of this few free samples cannot show its parabola (rise, apex, fall), so
        it is an unresolved micro-bounce of a resting contact (a rigid engine resting on a
        wall alternates one contact step and one or two free steps), not a separation.

    Returns
    -------
    starts, stops : ndarray of int, shape (m,)
        Interval i covers samples starts[i] .. stops[i] - 1; stops[i] is the first free
        sample after it, or n when the data end in contact.
    """
    edges = np.diff(np.concatenate(([0], contact.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    if bridge_steps > 0 and len(starts) > 1:
        keep = (starts[1:] - stops[:-1]) > bridge_steps  # gap before interval i + 1 is a real flight
        starts = starts[np.concatenate(([True], keep))]
        stops = stops[np.concatenate((keep, [True]))]
    if len(stops) and len(contact) - stops[-1] <= bridge_steps:
        stops[-1] = len(contact)  # the data end inside an unresolved flight: still in contact
    return starts, stops


def _wall_events(traj: Trajectory, scene: Scene, wall: str, acc: np.ndarray, options: ExtractionOptions, t_stick_min: float) -> list:
    """Event rows (t, kind, wall, v_minus, v_plus, x1, v1, rule) of one wall, unsorted."""
    t, y, vy, x1, v1 = traj.t, traj.y, traj.vy, traj.x1, traj.v1
    n_s = len(t)
    nrm = 1.0 if wall == "lower" else -1.0
    d = nrm * (y - scene.gap.position(wall))
    u = nrm * vy
    a = nrm * acc
    contact = d <= options.wall_tolerance
    flag = traj.contact.get(wall) if traj.contact else None
    if flag is not None and len(flag) == n_s:
        contact = contact | np.asarray(flag, dtype=bool)
    starts, stops = contact_intervals(contact, options.bridge_steps)
    in_contact = np.zeros(n_s + 1, dtype=np.int64)  # bridged mask, by a cumulative sum of +1/-1 edges
    np.add.at(in_contact, starts, 1)
    np.add.at(in_contact, stops, -1)
    contact = np.cumsum(in_contact[:-1]) > 0

    rows = []
    # (i) contact onsets: the last free sample before, extrapolated forwards to the wall
    if len(starts):
        k = np.maximum(starts - 1, 0)
        h = t[starts] - t[k]
        s_in = _first_root(d[k], u[k], a[k], h)
        t_imp = np.where(np.isnan(s_in), t[starts], t[k] + np.nan_to_num(s_in))
        v_minus = nrm * (u[k] + a[k] * (t_imp - t[k]))
        first = starts == 0  # starting in contact: nothing before it to measure
        t_imp = np.where(first, t[0], t_imp)
        v_minus = np.where(first, vy[0], v_minus)
        last = np.minimum(stops, n_s - 1)
        stuck = (t[last] - t[starts]) > t_stick_min
        # the first free sample after, extrapolated backwards to where it left the wall
        e = np.minimum(stops, n_s - 1)
        h = t[e] - t[np.maximum(e - 1, 0)]
        s_out = np.nan_to_num(_first_root(d[e], -u[e], a[e], h))
        v_plus = np.where(stops < n_s, nrm * (u[e] - a[e] * s_out), np.nan)
        x1_after = x1[e] - v1[e] * s_out
        for i in range(len(starts)):
            j, stop = int(starts[i]), int(stops[i])
            if stuck[i]:
                rows.append((float(t_imp[i]), "impact", wall, float(v_minus[i]), 0.0, float(x1[j]), float(v1[j]), ""))
                rows.append((float(t_imp[i]), "stick", wall, float(vy[j]), float(vy[j]), float(x1[j]), float(v1[j]), STICK_RULE))
                if stop < n_s:
                    rows.append((float(t[stop]), "exit", wall, float(vy[stop]), float(vy[stop]), float(x1[stop]), float(v1[stop]), ""))
            else:
                rows.append((float(t_imp[i]), "impact", wall, float(v_minus[i]), float(v_plus[i]), float(x1_after[i]), float(v1[e[i]]), ""))

    # (ii) impacts between two free samples: a velocity jump the free motion cannot make
    if n_s > 1:
        dt = np.diff(t)
        free_step = ~contact[:-1] & ~contact[1:]
        jump = u[1:] - u[:-1] - 0.5 * (a[:-1] + a[1:]) * dt
        a_max = np.maximum(np.abs(a[:-1]), np.abs(a[1:]))
        threshold = np.maximum(options.jump_atol, options.jump_factor * a_max * dt)
        reach = np.maximum(np.abs(u[:-1]), np.abs(u[1:])) * dt + a_max * dt * dt + options.wall_tolerance
        near = np.minimum(d[:-1], d[1:]) <= reach
        ks = np.flatnonzero(free_step & (jump > threshold) & near)
        if len(ks):
            h = dt[ks]
            s_fwd = _first_root(d[ks], u[ks], a[ks], h)
            s_bwd = _first_root(d[ks + 1], -u[ks + 1], a[ks + 1], h)
            t_imp = np.where(~np.isnan(s_fwd), t[ks] + s_fwd, np.where(~np.isnan(s_bwd), t[ks + 1] - s_bwd, t[ks + 1]))
            v_minus = nrm * (u[ks] + a[ks] * (t_imp - t[ks]))
            back = t[ks + 1] - t_imp
            v_plus = nrm * (u[ks + 1] - a[ks + 1] * back)
            x1_after = x1[ks + 1] - v1[ks + 1] * back
            for row in zip(t_imp.tolist(), v_minus.tolist(), v_plus.tolist(), x1_after.tolist(), v1[ks + 1].tolist()):
                rows.append((row[0], "impact", wall, row[1], row[2], row[3], row[4], ""))
    return rows


def extract_events(traj: Trajectory, scene: Scene, options: ExtractionOptions | None = None) -> pd.DataFrame:
    """The event log of a sampled trajectory, in the format of ``reference/log.py``.

    Parameters
    ----------
    traj : Trajectory
        Engine or reference samples; arrays of shape (n,), times increasing.
    scene : Scene
        The scene it ran (wall positions and the free relative acceleration).
    options : ExtractionOptions, optional
        Tolerances; defaults as documented there.

    Returns
    -------
    DataFrame
        Columns ``LOG_COLUMNS``: ``impact``, ``stick`` (rule ``contact``) and ``exit`` rows,
        sorted by time; no ``plate_entry``.
    """
    options = options or ExtractionOptions()
    t = np.asarray(traj.t, dtype=float)
    if t.ndim != 1 or any(np.shape(getattr(traj, f)) != t.shape for f in ("x1", "x2", "v1", "v2")):
        raise ValueError("trajectory arrays t, x1, x2, v1, v2 must all have the same shape (n,)")
    if len(t) > 1 and not (np.diff(t) > 0).all():
        raise ValueError("trajectory times must increase strictly")
    if len(t) == 0:
        return log_frame([])
    acc = free_relative_acceleration(scene, t, traj.x1, traj.v1, traj.y, traj.vy)
    t_stick_min = stick_threshold(traj, options)
    rows = []
    for wall in scene.gap.walls:
        rows.extend(_wall_events(traj, scene, wall, acc, options, t_stick_min))
    rows.sort(key=lambda r: (r[0], _KIND_ORDER[r[1]]))
    return log_frame(rows)


def extract_episodes(traj: Trajectory, scene: Scene, options: ExtractionOptions | None = None) -> pd.DataFrame:
    """Episodes (``EPISODE_COLUMNS`` of ``reference/log.py``) of a sampled trajectory."""
    return episodes(extract_events(traj, scene, options))
