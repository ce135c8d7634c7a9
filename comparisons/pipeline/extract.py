"""Recover impacts, sticking and exits from any sampled trajectory, by one rule for every engine.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.extract import extract
    >>> from chatterbench.comparisons import reference_trajectory
    >>> scene = load_scene("bouncing-ball")
    >>> found = extract(reference_trajectory(scene, dt=1e-3), scene, stick_tolerance=0.045)   # or an engine's
    >>> found.episodes[["wall", "t_stick"]].round(4).values.tolist()       # the Zeno point: 1.3546 s
    [['lower', 1.3546]]
    >>> found.impacts[["t", "v_minus", "v_plus"]].iloc[0].round(4).tolist()  # sqrt(2/g), -sqrt(2 g), R sqrt(2 g)
    [0.4515, -4.4294, 2.2147]

The log speaks the vocabulary of ``reference/log.py`` (``impact``, ``stick``, ``exit``;
never ``plate_entry``: an engine cannot know Feigin's plate), so ``episodes(log)`` is
derived exactly as the reference's episodes are. Only the samples and the scene are used:
the wall positions, R, and y'' of the free motion (Feigin (1.2)); never an engine's
declared contact time or stiffness, never a count of samples as the thing that decides.

Per wall, with n = +1 (lower) or -1 (upper): the distance d = n (y - y_wall) [m], the
velocity u = n y' and the free acceleration a = n y''_free; a < 0 presses into the wall.

1. **Contact** at a sample: the trajectory's contact flag (the wall's force is on), or
   d <= 0 where a trajectory carries no flag. A contact is a run of contact samples. A
   contact skin (``offsets``: the body rests that far off the wall) moves d's zero there.
2. **Impacts**: the onset of each contact, and every step between two free samples whose
   velocity jump J = u[k+1] - u[k] - (a[k] + a[k+1]) dt / 2 exceeds
   max(``jump_atol``, min(``jump_factor``, ``floor_steps``) |a| dt) (a jump of k |a| dt is a
   flight of k steps: one the samples resolve is never hidden) with the wall within one step's travel (an
   impact between two samples, as the exact reference has them), where the body comes to the
   wall: moving towards it (u[k] < 0), or carried there within the step by the free motion.
   A body rising from the wall all through the step is lifting off, whatever its jump: where
   the file's forcing runs ahead of the scene's, the scene's y'' still presses while the body
   leaves, and those jumps are no impacts (issue 34: they once pulled early exits towards the
   reference's). Each impact has its
   incoming and rebound speeds (``v_minus``, ``v_plus``; for a contact, where the body
   crosses the wall's undeformed surface, d = 0, on its way in and out: the free flight of
   the last free sample before and the first after, from two samples' positions where the
   step between them is free, carried to d = 0 (``surface.py``); a soft contact lets go
   below the surface and the free motion still slows the body before it crosses, so the
   speed at release is optimistic; where the free motion does not press at the release, an
   exit pulling the body out of a resting penetration, the speed at release), its release (the contact force's zero, interpolated linearly from the
   last two force samples, else the middle of the step after the last contact sample; the
   impact time itself for an impact between samples) and the highest point of the flight
   after it, ``apex`` [m], the largest sampled d until the next impact on the wall, and
   ``t_bound`` [s], how far its time may be off (0 where the free parabola reaches the wall,
   else the step it lies in). Its
   ``flight`` runs from the release to the next impact on the wall; ``flight_seen`` is that
   flight as both its ends see it, no longer than the free flight the rebound speed and the
   next impact's incoming speed each imply (2 |v| / |a| while a < 0): a "flight" that spans
   bounces the samples cannot see is short. ``v_error`` [m/s] bounds the error of its speeds:
   |a[k+1] - a[k]| dt where the free parabola carries a sample to the wall, |a| dt where it
   cannot and for a contact (which takes an unknown part of the steps it starts and ends in,
   and may hold the body above the surface there: a margin).
3. **Sticking is where bounces stop mattering.** A bounce matters when the chatter it can
   still make is long against the sticking tolerance: with Feigin's geometric ladder, a
   rebound whose flight lasts f is followed by f / (1 - R) of chatter, so bounces whose
   flights are shorter than f_min = max(``band`` x stick tolerance x (1 - R),
   ``floor_steps`` dt) do not matter (the second term: a flight of a few steps is below
   what the sampling resolves; a rigid engine resting on a wall makes such micro-bounces).
   An impact is *slow* when the free motion presses (a < 0 at release) and its flight stays
   within the band h = |a| f_min^2 / 8 (the apex of a flight of f_min). The engine is stuck
   from a slow impact as long as every following flight stays within the band (which
   never shrinks below the onset's: near an exit |a| -> 0 but the bodies have not moved
   apart), until the release of the first contact whose flight leaves it (the bodies
   separate). A single contact that starts pressing (a < 0) and is released where the
   free motion no longer presses (a >= 0), slower than a flight of f_min (v+ <= |a| f_min
   / 2 with the onset's a), is a stick too: perfectly inelastic, or a soft contact that
   never rebounds. So is a contact the data start in. What the end of the data cuts short (a
   flight, a contact) continues a stuck stretch but starts one only where the bodies are
   already at rest in a contact (|y'| <= |a| f_min / 2). A stretch whose bodies part less
   than f_min after its sticking start (rule 4) is no stick: they never came to rest, its
   impacts are bounces (an engine that keeps kicking off after each Zeno point chatters).
4. **Times** (``sticking.py``, with how far the samples let each be off: ``sticks``).
   The sticking start comes from the engine's own ladder (``sticking_start``):
   from the onset, the bounces (a contact shorter than the flight after it) whose flights
   keep shrinking, i .. K, down to the last the samples see (flights of about two steps:
   rule 2's jump); when they shrank by more than a step, their mean ratio rho =
   (f_K / f_i)^(1 / (K - i)) extrapolates the rest: t_release[K] + f_K / (1 - rho). This is
   exact for a geometric ladder under constant a, whatever its ratio (an engine whose slow
   bounces are nearly elastic is seen to stick late); for one that is not, it is off by at
   most f_K rho / (1 - rho) (the extrapolated part) plus the chatter of bounces too short
   to see. Otherwise (one bounce, or flights that did not shrink by a step) the onset's
   rebound is extrapolated with Feigin's ladder, 2 v+ / ((1 - R) |a|) (0 for a single
   contact): exact for a trajectory that follows R, off by at most f_min / (1 - R) for one
   that does not. The samples at rest overrule both: a stretch that ends in a contact lasting
   to its exit or to the end of the data sticks no later than that contact's first sample
   (where the ladder says later, at that contact's onset). The exit is the release of the
   last contact of the stuck stretch.

Estimator errors (exact samples, step dt; an engine adds its own): impact time
O(|a'| dt^3 / |u|) (the smallest root of the free parabola from the last free sample;
the onset sample's time, error <= dt, when the parabola does not reach the wall); speeds
O(|a'| dt^2); exit O(dt^2) where the force decays linearly, else <= dt; sticking start
O(f_min^2 |a'| / |a|) from the ladder's changing |a|. Positions rounded to
``position_rounding`` (a float32 file's) move an impact between samples by up to
2 rounding / |u|, which ``v_error`` takes in, and blur a velocity taken from two positions,
which is then taken from the samples' own velocity.

Promises: the log is sorted by time (at one time: exit, impact, stick); every stick is
followed by an exit on its own wall, f_min or more later, unless the data end stuck; impacts inside a stuck stretch (the
unresolved micro-bounces) are in ``impacts`` (``stuck`` true) but not in the log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import pandas as pd

from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.forces import evaluate_forces, relative_acceleration
from chatterbench.reference.log import episodes, log_frame
from chatterbench.reference.scene import Scene

from .extract_options import ExtractionOptions
from .sticking import Stick, at_rest, last_landing, stick_frame, stick_rows, sticking_start, stuck_stretches
from .wall_impacts import impacts_on_wall

STICK_RULE = "contact"  # the ``rule`` of an extracted stick
_KIND_ORDER = {"exit": 0, "impact": 1, "stick": 2}  # at one time: leave, strike, then stick
IMPACT_COLUMNS = ["t", "wall", "v_minus", "v_plus", "t_release", "flight", "flight_seen", "apex", "pressing", "v_error",
                  "t_bound", "slow", "stuck", "onset", "exits", "x1", "v1"]


@dataclass(frozen=True)
class Extraction:
    """What the samples say: every impact (``IMPACT_COLUMNS``), the event log and the episodes.

    ``impacts``: t [s], wall, v_minus and v_plus (y' before and after [m/s]), t_release [s],
    flight (release to the next impact, on the same wall [s]; NaN when the next is on the
    other wall, there is none, or the release is an exit), flight_seen [s] (rule 2), apex
    [m], pressing (-n y''_free at the release [m/s^2], > 0 into the wall), v_error [m/s]
    (rule 2), slow, stuck (a micro-bounce inside a stuck
    stretch), onset (the impact a stuck stretch starts with), exits (its release ends a stuck
    stretch), x1 [m], v1 [m/s] after it.
    """

    impacts: pd.DataFrame  # one row per impact, all walls, by time
    log: pd.DataFrame  # LOG_COLUMNS of reference/log.py
    episodes: pd.DataFrame  # EPISODE_COLUMNS of reference/log.py
    flight_min: float  # [s] f_min of the module docstring
    sticks: pd.DataFrame = field(default_factory=lambda: stick_frame([]))  # sticking.STICK_COLUMNS: each time's bound
    offsets: dict = field(default_factory=dict)  # [m] the contact skin taken per wall (``extract``'s ``offsets``)


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


def flight_floor(dt: float, restitution: float, stick_tolerance: float = math.nan,
                 options: ExtractionOptions | None = None) -> float:
    """f_min [s], the shortest flight that matters (rule 3): ``floor_steps`` samples of ``dt`` [s], or ``band`` of the
    chatter left within ``stick_tolerance`` [s] (NaN: the floor alone); all ``extract`` reads of the stick tolerance."""
    options = options or ExtractionOptions()
    f_min = options.floor_steps * dt
    if math.isfinite(stick_tolerance) and stick_tolerance > 0:
        f_min = max(f_min, options.band * stick_tolerance * (1.0 - restitution))
    return f_min


def extract(traj: Trajectory, scene: Scene, stick_tolerance: float = math.nan,
            options: ExtractionOptions | None = None, offsets: Mapping[str, float] | None = None,
            walls: dict | None = None) -> Extraction:
    """Impacts, event log and episodes of a sampled trajectory (module docstring).

    Parameters
    ----------
    traj : Trajectory
        Engine or reference samples; arrays of shape (n,), times increasing.
    scene : Scene
        The scene it ran: wall positions, R, the free relative acceleration.
    stick_tolerance : float
        [s] the tightest sticking tolerance of the scene's visits (``ReferenceSolution.
        stick_tolerance``); NaN: only the sampling floor decides which bounces matter.
    options : ExtractionOptions, optional
    offsets : mapping wall -> float, optional
        [m] a contact skin per wall: the body rests this far from the wall (> 0: outside the gap), so
        the wall's surface is taken there (``trajectory_file.resting_offsets`` measures it in a file).
    walls : dict, optional
        A cache kept by the caller across extractions of one ``traj`` (same options and offsets) at other sticking
        tolerances (tune's ladder): each wall's impacts, which the tolerance does not move, found once.
    """
    options = options or ExtractionOptions()
    t = np.asarray(traj.t, dtype=float)
    if t.ndim != 1 or any(np.shape(getattr(traj, f)) != t.shape for f in ("x1", "x2", "v1", "v2")):
        raise ValueError("trajectory arrays t, x1, x2, v1, v2 must all have the same shape (n,)")
    if len(t) > 1 and not (np.diff(t) > 0).all():
        raise ValueError("trajectory times must increase strictly")
    if len(t) < 2:
        return Extraction(pd.DataFrame(columns=IMPACT_COLUMNS), log_frame([]), episodes(log_frame([])), math.nan,
                          stick_frame([]), dict(offsets or {}))
    dt = traj.dt  # the run's dt as recorded (a file's samples: their median spacing)
    R = scene.restitution
    f_min = flight_floor(dt, R, stick_tolerance, options)
    y, vy = traj.y, traj.vy  # each a new array per read: read once
    walls = {} if walls is None else walls
    acc = walls.get("acc")
    if acc is None:
        acc = walls["acc"] = free_relative_acceleration(scene, t, traj.x1, traj.v1, y, vy)
    x1, v1 = np.asarray(traj.x1, float), np.asarray(traj.v1, float)
    rows, impact_rows, sticks = [], [], []
    for wall in scene.gap.walls:
        imp = walls.get(wall)
        if imp is None:
            imp = walls[wall] = impacts_on_wall(traj, y, vy, scene, wall, acc, options, offsets)
        nrm = 1.0 if wall == "lower" else -1.0
        pressing = imp["a_release"] < 0.0
        band = np.where(pressing, -imp["a_release"], 0.0) * f_min**2 / 8.0
        held = imp["begin"] >= len(t)  # the data end in this contact
        slow = (pressing & (imp["apex"] <= band)) | held
        stretches = []
        for i, j, released in stuck_stretches(imp, band, held, f_min):
            end = float(imp["t_release"][j]) if released else float(t[-1])
            stick = at_rest(sticking_start(imp, i, j, R, dt), imp, i, j, t, held, released)
            if released and end - stick.t < f_min:
                continue  # the bodies part before they could have come to rest: bounces, not a stick
            stick = last_landing(stick, imp, i, j, t, held, released)
            stretches.append((i, j, released, Stick(min(stick.t, end), stick.bound, stick.source), end))
        sticks += stick_rows(wall, stretches, imp)
        stuck = np.zeros(len(slow), bool)
        onset = np.zeros(len(slow), bool)
        exits = np.zeros(len(slow), bool)
        for i, j, released, _, _ in stretches:
            stuck[i:j + 1] = True
            onset[i] = True
            exits[j] = released
        after = np.minimum(imp["begin"], len(t) - 1)
        # the IMPACT_COLUMNS as columns (a row of Python objects per impact would be ~0.4 kB each)
        impact_rows.append({"t": imp["t"], "wall": np.full(len(slow), wall, dtype=object), "v_minus": nrm * imp["v_minus"],
                            "v_plus": nrm * imp["v_plus"], "t_release": imp["t_release"], "flight": imp["flight"],
                            "flight_seen": imp["flight_seen"], "apex": imp["apex"], "pressing": -imp["a_release"],
                            "v_error": imp["v_error"], "t_bound": imp["t_bound"], "slow": slow, "stuck": stuck & ~onset,
                            "onset": onset, "exits": exits, "x1": x1[after], "v1": v1[after]})
        for i in np.flatnonzero(~stuck | onset):
                rows.append((float(imp["t"][i]), "impact", wall, nrm * float(imp["v_minus"][i]), nrm * float(imp["v_plus"][i]),
                             float(x1[after[i]]), float(v1[after[i]]), ""))
        for i, j, released, stick, end in stretches:
            k = int(min(imp["first"][i], len(t) - 1))
            rows.append((stick.t, "stick", wall, float(vy[k]), float(vy[k]),
                         float(x1[k]), float(v1[k]), STICK_RULE))
            if released:
                kk = int(min(imp["begin"][j], len(t) - 1))
                rows.append((end, "exit", wall, float(vy[kk]), float(vy[kk]), float(x1[kk]), float(v1[kk]), ""))
    rows.sort(key=lambda r: (r[0], _KIND_ORDER[r[1]]))
    log = log_frame(rows)
    impacts = impact_table(impact_rows)
    return Extraction(impacts=impacts, log=log, episodes=episodes(log), flight_min=f_min, sticks=stick_frame(sticks),
                      offsets=dict(offsets or {}))


def impact_table(walls: list[dict[str, np.ndarray]]) -> pd.DataFrame:
    """The impacts of every wall (``IMPACT_COLUMNS``, one dict of columns per wall) as one table by time (stable:
    a tie keeps the walls' order), with no bounce's flight where a flight ends on the other wall or an exit starts it.
    Built as arrays and made a DataFrame once (a ladder extracts a run at each f_min: pandas' sort and masked
    assignment cost more than the rest of the table)."""
    n = sum(len(w["t"]) for w in walls)
    if not n:
        return pd.DataFrame([], columns=IMPACT_COLUMNS).reset_index(drop=True)
    order = np.argsort(np.concatenate([w["t"] for w in walls]), kind="stable")
    columns = {c: np.concatenate([w[c] for w in walls])[order] for c in IMPACT_COLUMNS}
    wall = columns["wall"]
    crossing = np.zeros(n, dtype=bool)
    crossing[:-1] = wall[:-1] != wall[1:]
    no_flight = crossing | columns["exits"].astype(bool)
    for c in ("flight", "flight_seen"):
        columns[c] = np.where(no_flight, np.nan, columns[c].astype(float))
    return pd.DataFrame(columns, columns=IMPACT_COLUMNS)


def extract_events(traj: Trajectory, scene: Scene, stick_tolerance: float = math.nan,
                   options: ExtractionOptions | None = None) -> pd.DataFrame:
    """The event log of a sampled trajectory (``LOG_COLUMNS``; see ``extract``)."""
    return extract(traj, scene, stick_tolerance, options).log


def extract_episodes(traj: Trajectory, scene: Scene, stick_tolerance: float = math.nan,
                     options: ExtractionOptions | None = None) -> pd.DataFrame:
    """Episodes (``EPISODE_COLUMNS`` of ``reference/log.py``) of a sampled trajectory (see ``extract``)."""
    return extract(traj, scene, stick_tolerance, options).episodes
