"""Whether a stuck contact stays closed: what the samples show of the contact after the stick, per episode.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import reference_trajectory
    >>> from chatterbench.comparisons.pipeline.extract import extract
    >>> from chatterbench.comparisons.pipeline.persistence import contact_rest
    >>> scene = load_scene("bouncing-ball")
    >>> traj = reference_trajectory(scene, dt=1e-3)                       # or an engine's
    >>> rest = contact_rest(traj, scene, extract(traj, scene, 0.045), "lower", 1.40, 2.0)
    >>> rest.onsets, rest.open_fraction, rest.gap_max                      # the exact answer rests
    (0, 0.0, 0.0)

Feigin's sliding is motion in kinematic constraint (his (1.4)): from the stick to the exit
the bodies move as one and the wall carries the load Q = -m_red y''_free (m_red = m1 m2 /
(m1 + m2), m2 for an infinite body 1; y''_free the free relative acceleration, Feigin (1.2),
pressing into the wall). An engine can stick on time and still not hold that contact: a
rigid solver that bounces at |y''| dt every two steps, a soft contact caught in a limit
cycle, flickering at 17-500 Hz. A force sensor on top of it sees the force swing between 0
and several times Q. That is *persistence*: a stuck contact that stays closed.

The *rest window* of an episode: from the later of the engine's and the reference's
sticking starts plus the sticking tolerance (stick x the chatter; before that the engine's
last bounces may still be settling, within what the timing check allows) to the earlier
of their exits minus the exit tolerance (exit x the sliding; near an exit the load
vanishes and every contact lets go), or to the end of the samples. Over it:

- ``onsets``: contacts that start inside the window (a closed sample after an open one, as below),
  and ``onset_rate`` = onsets / window [1/s];
- ``open_fraction`` [1]: the share of the window's time the wall's contact is open (a sample
  without contact holds its step; a gap within the positions' rounding in the engine's arithmetic,
  ``arithmetic``: float32 for PhysX, is no opening, whatever the engine's flag says; a compact trajectory's left-out samples were clear of the
  wall: open); the persistence check (``Tolerances.persistence``) bounds it;
- ``gap_max`` [m]: the largest distance from the wall's surface (a contact skin moves it);
- ``force_swing`` [1]: max |F - Q| / max Q over the window where the samples carry the
  wall's force (NaN where they do not): 0 for a contact that carries its load, 1 or more
  for one that alternates between nothing and twice the load;
- ``contact_resolution`` [m/s]: the slowest motion off the wall the samples can tell from
  rest. 0 where contact is the engine's own flag (or the file's force column); for contact
  read from the gap alone (``gap_contact.on_wall``: on the wall to the positions' rounding
  and not moving faster than the velocities' rounding), the velocities' rounding. Where it
  exceeds the speed of a one-step flight, |y''| dt / 2, a flicker of a step could pass for
  rest: the check is ``unresolved`` unless the open share already fails it.

Units: seconds, metres, newtons; d > 0 is outside the gap (the body off the wall).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene

from .extract import Extraction, free_relative_acceleration
from .gap_contact import PRECISIONS, rounding
from .solution import reduced_mass

REST_COLUMNS = ["rest_window", "contact_onsets", "onset_rate", "open_fraction", "gap_max", "force_swing",
                "contact_resolution"]


@dataclass(frozen=True)
class ContactRest:
    """What the samples show of one wall's contact over a rest window (module docstring); NaN: no window."""

    window: float  # [s] the rest window's length (0: none)
    onsets: int  # contacts starting inside the window
    onset_rate: float  # [1/s]
    open_fraction: float  # [1] share of the window's time the contact is open
    gap_max: float  # [m] largest distance from the wall's surface, >= 0
    force_swing: float  # [1] max |F - Q| / max Q; NaN without force samples
    contact_resolution: float  # [m/s] the slowest motion off the wall the samples tell from rest (0: a flag, a force)
    speed_step: float  # [m/s] the speed of a one-step flight, |y''| dt / 2, at the window's largest |y''|

    @property
    def resolved(self) -> bool:
        """Whether the samples could show a flicker of one step (``contact_resolution`` within ``speed_step``)."""
        return not self.contact_resolution > self.speed_step

    def columns(self) -> dict[str, float]:
        """The judged table's ``REST_COLUMNS``."""
        return {"rest_window": self.window, "contact_onsets": self.onsets, "onset_rate": self.onset_rate,
                "open_fraction": self.open_fraction, "gap_max": self.gap_max, "force_swing": self.force_swing,
                "contact_resolution": self.contact_resolution}


NO_REST = ContactRest(0.0, 0, math.nan, math.nan, math.nan, math.nan, 0.0, math.nan)


def rest_window(t_stick: float, ref_t_stick: float, stick_limit: float, t_exit: float, ref_t_exit: float,
                exit_limit: float, t_end: float) -> tuple[float, float]:
    """The rest window (t0, t1) [s] of an episode (module docstring): empty (t1 <= t0) where there is none."""
    t0 = max(t_stick, ref_t_stick) + (stick_limit if stick_limit > 0 else 0.0)
    exits = [e for e in (t_exit, ref_t_exit) if not math.isnan(e)]
    t1 = min(exits) - (exit_limit if exit_limit > 0 else 0.0) if exits else t_end
    return t0, min(t1, t_end)


def arithmetic(traj: Trajectory) -> str:
    """The floating-point type the positions are in: the file's (``trajectory_file`` records it), else the engine's
    (``EngineAdapter.precision``: PhysX and MuJoCo Warp step in float32), else float64."""
    precision = (traj.settings or {}).get("precision")
    if precision in PRECISIONS:
        return precision
    from chatterbench.engines.registry import ENGINE_NAMES, adapter

    return adapter(traj.engine).precision if traj.engine in ENGINE_NAMES else "float64"


def reference_rest_windows(solution, tol) -> list[tuple[float, float, str]]:
    """The reference's rest windows (t0 [s], t1 [s], wall), one per episode that sticks: from its stick plus the
    sticking tolerance to its exit less the exit tolerance, or the end of the scene (what the exported scripts
    report on: they have no engine stick of their own to start from)."""
    out = []
    end = solution.scene.initial.t + solution.scene.duration
    for r in solution.episodes.itertuples():
        t0, t1 = rest_window(r.t_stick, r.t_stick, tol.stick * r.stick_scale, r.t_exit, r.t_exit,
                             tol.exit * r.sliding_duration, end)
        if t1 > t0:
            out.append((float(t0), float(t1), str(r.wall)))
    return out


def contact_rest(traj: Trajectory, scene: Scene, found: Extraction, wall: str, t0: float, t1: float) -> ContactRest:
    """The contact of ``wall`` over [t0, t1] [s] (module docstring); ``NO_REST`` where the window holds < 2 samples."""
    t = np.asarray(traj.t, dtype=float)
    if not (t1 > t0) or math.isnan(t0) or math.isnan(t1):
        return NO_REST
    k0, k1 = int(np.searchsorted(t, t0, "left")), int(np.searchsorted(t, t1, "right"))
    if k1 - k0 < 2:
        return NO_REST
    part = slice(k0, k1)
    ts = t[part]
    nrm = 1.0 if wall == "lower" else -1.0
    x1, x2 = np.asarray(traj.x1[part], float), np.asarray(traj.x2[part], float)
    v1, v2 = np.asarray(traj.v1[part], float), np.asarray(traj.v2[part], float)
    d = nrm * (x2 - x1 - scene.gap.position(wall)) - found.offsets.get(wall, 0.0)
    flag = traj.contact.get(wall) if traj.contact else None
    precision = arithmetic(traj)
    slack = rounding(precision, x1, x2, scene.gap.position(wall))  # the positions' rounding [m]
    if flag is not None and len(flag) == len(t):  # the engine's flag; a gap within the rounding is no opening
        closed = np.asarray(flag[part], dtype=bool) | (d <= slack)
    else:  # from the gap (``gap_contact.on_wall``): on the wall to the rounding and not moving faster than it
        closed = (d < -slack) | ((d <= slack) & ~(np.abs(v2 - v1) > rounding(precision, v1, v2)))
    steps = np.diff(ts)
    gaps = np.diff(traj.index[part]) > 1 if traj.index is not None else np.zeros(len(steps), bool)
    open_time = float(np.sum(steps[~closed[:-1] | gaps]))
    span = float(ts[-1] - ts[0])
    onsets = int(np.sum(closed[1:] & (~closed[:-1] | gaps)))  # a contact starting: open (or left out) the sample before
    acc = nrm * free_relative_acceleration(scene, ts, x1, v1, x2 - x1, v2 - v1)
    load = reduced_mass(scene) * np.maximum(-acc, 0.0)  # Q [N]: what the wall carries in the constrained motion
    force = traj.normal_force.get(wall) if traj.normal_force else None
    has_force = force is not None and len(force) == len(t)
    swing = math.nan
    if has_force and load.max() > 0:
        swing = float(np.max(np.abs(np.asarray(force[part], float) - load)) / load.max())
    # contact read from the gap alone (a file without this wall's force column: ``trajectory_file``, which records
    # the positions' precision) tells motion from rest to the velocities' rounding; an engine's flag shows every opening
    known = (traj.settings or {}).get("precision") is not None
    resolution = 0.0 if has_force or not known else float(np.max(rounding(precision, v1, v2)))
    dt = float(np.median(steps)) if len(steps) else math.nan
    return ContactRest(window=span, onsets=onsets, onset_rate=onsets / span if span > 0 else math.nan,
                       open_fraction=open_time / span if span > 0 else math.nan,
                       gap_max=max(0.0, float(np.max(d - slack))), force_swing=swing, contact_resolution=resolution,
                       speed_step=float(np.max(np.abs(acc))) * dt / 2.0)
