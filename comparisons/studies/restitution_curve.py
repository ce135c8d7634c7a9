"""Effective restitution against impact speed, per engine: single impacts at each speed, at every place in a step.

    >>> from chatterbench.comparisons.studies.restitution_curve import restitution_band, restitution_curve
    >>> from chatterbench.engines.registry import make_settings
    >>> curve = restitution_curve("pybullet", make_settings("pybullet", dt=1e-4), 0.5, [0.1, 1.0])
    >>> len(curve), curve["aim"].round(4).tolist()[:10]   # 2 speeds x (8 places through a step and its 2 ends)
    (20, [0.0625, 0.1875, 0.3125, 0.4375, 0.5625, 0.6875, 0.8125, 0.9375, 0.002, 0.998])
    >>> restitution_band(curve)[["speed", "e_min", "e_max"]].round(6).values.tolist()   # a Newton law: R everywhere
    [[0.1, 0.5, 0.5], [1.0, 0.5, 0.5]]
    >>> curve = restitution_curve("pybullet", make_settings("pybullet", 1e-4, ["pybullet.restitution_velocity_threshold=0.5"]),
    ...                           0.5, [0.1, 1.0])
    >>> curve[["speed", "restitution_effective", "rebound"]].round(6).drop_duplicates().values.tolist()   # cut below 0.5 m/s
    [[0.1, 0.0, False], [1.0, 0.5, True]]

An engine tunes its contact to give Newton's R, but only at the conditions it was tuned
for: MuJoCo's force-only spring-damper gives R exactly at every speed without other forces
(``engines/restitution.py``), but under gravity part of the rebound is spent lifting the
weight during the contact (e ~ 1 - c g / (w0 v)); a Hunt-Crossley contact's losses grow
with the speed (its e climbs as impacts get slower); PyBullet's
``restitution_velocity_threshold`` cuts e to zero below it. And where in a step an impact
falls moves e: a time-stepper meets the contact a fraction of a step after a sample, and a
soft contact of a few steps resolves it differently each time (MuJoCo at w0 dt = 0.3, force-free:
0.455 to 0.537 over the step at any speed; under gravity at 1.03 m/s: 0.449 to 0.532; at w0 dt =
0.1: 0.469 to 0.497), e jumping where the contact's start crosses a sample. ``restitution_curve`` shows all of it, for any engine of the registry
with any settings:

- **single impacts at each speed, at ``STRIKES`` places in a step** (``impact_scene``,
  ``strike``): the scene's bodies (masses, lower wall) with no forces but an optional
  ``gravity`` [m/s^2] pressing body 2 into the lower wall (the ball's case), started
  ``APPROACH_STEPS`` timesteps of free flight and a fraction of a step away, with the velocity
  that makes them strike at exactly ``speed``: ``PHASES`` aimed through the step, (i + 1/2) /
  ``PHASES`` after a sample (``strike_phases``), and two at its ends, ``EDGE`` after a sample and
  before the next, where e jumps (``aim_ends``: aimed through the engine's own drift from the
  exact flight, which moves a strike's place in its step); without gravity this is the contact
  law alone, with it the ball dropped so that it arrives at that speed. Every figure, claim and
  check reports the band over the places (``restitution_band``: min, median, max), never one
  strike: a run's impacts fall anywhere in a step;
- **measured by the judge's rule** (``wall_rebound``): e = -v+ / v- of the strike's first
  impact as the judge finds it (``pipeline/extract.py``), v- where the body reaches the wall's
  surface and v+ where it leaves it again, each from the free flight of two samples' positions
  (``pipeline/surface.py``); a soft contact lets go below the surface and gravity still slows
  the body on its way up, so this, the speed the next flight sees, is less than the speed at
  release; a user's own drop measures the same at each place in a step
  (``tests/.../test_restitution_curve.py``);
- **no rebound is e = 0, not NaN**: a run whose bodies stay together after the impact
  (PyBullet under its threshold, a soft contact under gravity too slow to lift off) ends
  in a contact whose relative speed has stayed below ``REST_FRACTION`` of the impact
  speed over the last quarter of the run. A contact still moving at the end is run again
  ``EXTEND`` times longer (``TRIES`` runs at most: 256 ... 16,384 timesteps after the
  strike); a run that fails or finds no impact keeps its status and a NaN e. The strikes of
  every speed go to the engine as one batch per try (``strike_all``, ``run_engine_batch``: MuJoCo
  rolls them out on one compiled model).

**The contact is the scene's.** An engine whose contact is made from the scene it runs
(Drake: stiffness and dissipation from the scene's first impact, when its settings leave
``calibration_speed`` and ``w0`` at 0) would remake it for every strike and calibrate each
one to R; ``pinned_settings`` fixes such settings at the values a run of the whole scene
recorded (``Trajectory.settings``), so every strike meets the contact that scene gets. The
command line pins them from the run it makes for ``impact_restitutions``.

``impact_restitutions`` is the other view: the restitution of each resolved impact of a
whole scene (the bouncing ball: its k-th impact), from the judge's paired impacts
(``pipeline/impacts.py``), so the drift is seen where the scene meets it; each falls
somewhere in its band.

Speeds: ``default_speeds`` spans two decades below the scene's first impact speed v1 (the
ball's 4.43 m/s down to 0.0443 m/s: its chatter ladder halves the speed at every impact
at R = 0.5, so its first seven impacts) and up to 2 v1 (``ABOVE``: an engine calibrated
at v1 shows which way it goes on both sides), log-spaced. An engine calibrated at one
impact speed names it in its settings as ``calibration_speed`` [m/s] (column
``calibration_speed``, NaN where the settings have none: MuJoCo's law holds at every speed).

Columns of the curve (``CURVE_COLUMNS``): engine, forces ("none", "gravity", or "scene" for
``scene_restitution``'s strikes), impact, t [s] and wall (the scene's impact a strike
repeats; NaN, NaN, "lower" here), speed (the incoming relative speed set [m/s], > 0), phase
(where in its step the engine met the wall's surface, a fraction of a step after a sample [-]),
aim (the phase the strike was started for [-]), restitution
(nominal R), restitution_effective (e = -v+ / v- [-]; 0 when no rebound), restitution_error
(e / R - 1), restitution_uncertainty (``sampling_uncertainty``: what a run's samples would
leave of e at this speed), v_minus and v_plus (the measured relative velocities at the
surface [m/s], y' before and after), rebound (the bodies part after the impact, faster than
``REST_FRACTION`` of the impact speed), gravity [m/s^2], dt [s], calibration_speed [m/s],
status, message.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from chatterbench.engines.registry import run_engine_batch
from chatterbench.engines.sampled_impacts import first_impact, first_root, surface_velocity
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.errors import InputError, check_integer, check_number, is_number
from chatterbench.reference.scene import Scene, load_scene, scene_from_dict
from chatterbench.reference.simulate import simulate

from .limits import ABOVE, DECADES_BELOW, DEFAULT_POINTS, MAX_POINTS  # the speed grid `calibrate --help` shows
from ..pipeline.compare import judge_run
from ..pipeline.extract import free_relative_acceleration
from ..pipeline.impacts import restitution_error
from ..pipeline.solution import ReferenceSolution, solve
from ..pipeline.summary import worst_signed
from ..pipeline.tolerances import Tolerances

CURVE_COLUMNS = ["engine", "forces", "impact", "t", "wall", "speed", "phase", "aim", "restitution", "restitution_effective",
                 "restitution_error", "restitution_uncertainty", "v_minus", "v_plus", "rebound", "gravity", "dt", "calibration_speed", "status", "message"]
BAND_COLUMNS = ["engine", "forces", "impact", "t", "wall", "speed", "restitution", "phases", "e_min", "e_median", "e_max",
                "error_worst", "restitution_uncertainty", "dt"]
IMPACT_COLUMNS = ["engine", "impact", "t", "speed", "ref_speed", "restitution", "restitution_effective",
                  "restitution_error", "restitution_uncertainty", "worst"]
APPROACH_STEPS = 20  # [steps] free flight sampled before the strike (the extraction carries the last free sample to the wall)
PHASES = 8  # [-] strikes per speed at the phases (i + 1/2) / PHASES of a step: where in a step an impact falls moves e
EDGE = 0.002  # [-] of a step: and two at its ends, this far after a sample and before the next (e jumps at a sample)
STRIKES = PHASES + 2  # [-] strikes per speed in every R(v) figure, claim and check
AFTER_STEPS = 256  # [steps] run after the strike at the first try (MuJoCo's default contact lasts ~105)
EXTEND = 4  # [-] each further try runs this many times longer after the strike
TRIES = 4  # [-] runs at most per speed: 256, 1024, 4096, 16384 steps after the strike
REST_FRACTION = 1e-3  # [-] of the strike speed: below it a contact is at rest, a parting is no rebound, a jump no impact


class CalibrationError(InputError):
    """A calibration input out of range (restitution, speeds, points, gravity); the message names it."""


def check_restitution(restitution: Any) -> float:
    """Newton's R to calibrate against, in (0, 1) (e / R needs R > 0)."""
    return check_number("restitution", restitution, lo=0.0, hi=1.0, lo_open=True, hi_open=True, error=CalibrationError)


def log_speeds(lo: float, hi: float, points: int = DEFAULT_POINTS) -> np.ndarray:
    """``points`` impact speeds [m/s] log-spaced from ``lo`` to ``hi`` (0 < lo < hi), ends included; shape (points,)."""
    lo = check_number("speeds LO", lo, lo=0.0, lo_open=True, unit=" [m/s]", error=CalibrationError)
    hi = check_number("speeds HI", hi, lo=lo, lo_open=True, unit=" [m/s] (above LO)", error=CalibrationError)
    check_integer("points", points, lo=2, hi=MAX_POINTS, error=CalibrationError)
    return np.geomspace(lo, hi, points)


def first_impact_speed(scene: Scene) -> float:
    """|y'| of the scene's first strike in the reference [m/s] (Feigin's model; a resting start is no strike);
    CalibrationError when it has none."""
    log = simulate(scene, "feigin").log
    impacts = log[(log["kind"] == "impact") & (log["v_minus"] != 0.0)]
    if impacts.empty:
        raise CalibrationError(f"scene {scene.name!r} has no impact to take the speeds from; give them (--speeds LO,HI)")
    return float(abs(impacts["v_minus"].iloc[0]))


def default_speeds(scene: Scene, points: int = DEFAULT_POINTS) -> np.ndarray:
    """Log-spaced speeds [m/s] from ``DECADES_BELOW`` decades under the scene's first impact speed v1 up to ``ABOVE`` v1."""
    v1 = first_impact_speed(scene)
    return log_speeds(v1 * 10.0**-DECADES_BELOW, ABOVE * v1, points)


def strike_phases(phases: int = PHASES) -> list[float]:
    """Where in a step the strikes are aimed [-], as fractions of a step after a sample: (i + 1/2) / ``phases``, never
    on a sample (where rounding would decide which sample touches first); ``strike`` adds the step's two ends."""
    check_integer("phases", phases, lo=1, hi=MAX_POINTS, error=CalibrationError)
    return [(i + 0.5) / phases for i in range(phases)]


def approach_time(dt: float, phase: float, most: float = math.inf) -> float:
    """(n + ``phase``) dt [s]: ``APPROACH_STEPS`` whole steps of free flight and the phase, or fewer steps where the
    flight before the strike is shorter than that (``most`` [s]: n = floor(most / dt) - 1, the same for every phase,
    so that the strikes of one speed drift alike); ``most`` itself where not even a step fits."""
    n = APPROACH_STEPS if not math.isfinite(most) else min(APPROACH_STEPS, math.floor(most / dt) - 1)
    return (n + phase) * dt if n >= 0 else most


def impact_scene(scene: Scene, restitution: float, speed: float, dt: float, gravity: float = 0.0,
                 after_steps: int = AFTER_STEPS, phase: float = 0.5) -> Scene:
    """One strike of ``scene``'s bodies on its lower wall at relative speed ``speed`` [m/s] (module docstring).

    Body 1 is held still (its prescribed motion and every force dropped); ``gravity`` [m/s^2]
    pulls body 2 alone, so y'' = -g between impacts: the scene's ``gravity`` -g where body 1 is
    infinite (it stays where it is), else a constant force -m2 g on body 2. The strike comes after
    t_a = (``APPROACH_STEPS`` + ``phase``) dt (``approach_time``: ``phase`` of a step after a sample;
    fewer steps when a slow strike under gravity needs it, t_a <= v / g), from y0 = v t_a - g
    t_a^2 / 2 above the wall with y' = -v + g t_a; the run lasts t_a + ``after_steps`` dt.
    """
    speed = check_number("speed", speed, lo=0.0, lo_open=True, unit=" [m/s]", error=CalibrationError)
    gravity = check_number("gravity", gravity, lo=0.0, unit=" [m/s^2]", error=CalibrationError)
    t_a = approach_time(dt, phase, speed / gravity if gravity > 0 else math.inf)
    data = scene.to_dict()
    data.pop("prescribed", None)
    data.update(name=f"{scene.name}-impact", restitution=restitution, gap={"lower": scene.gap.lower},
                gravity=-gravity if gravity > 0 and scene.body1_infinite else 0.0,
                forces=[{"kind": "constant", "on": "body2", "value": -scene.mass2 * gravity}]
                if gravity > 0 and not scene.body1_infinite else [],
                initial={"t": 0.0, "x1": scene.initial.x1 if scene.body1_infinite else 0.0, "v1": 0.0,
                         "y": scene.gap.lower + speed * t_a - 0.5 * gravity * t_a**2, "vy": -speed + gravity * t_a},
                duration=t_a + after_steps * dt,
                description=f"one strike at {speed:g} m/s on the lower wall" + (f" under g = {gravity:g} m/s^2" if gravity else ""))
    return scene_from_dict(data)


def sampling_uncertainty(restitution: float, pressing: float, dt: float, speed: float) -> float:
    """u = (1 + R) |y''| dt / (R v) [-]: what a time-stepper's samples leave of e at speed v (``pipeline/impacts.py``).

    Where it is within the restitution tolerance, the judge holds a run's impact to R (the
    strikes of ``scene_restitution`` that count against a setting); slower, the samples cannot.
    """
    return (1.0 + restitution) * abs(pressing) * dt / (restitution * speed)


def calibration_speed(settings: Any) -> float:
    """The impact speed [m/s] an engine's settings are calibrated at (their ``calibration_speed`` > 0), NaN if none."""
    value = getattr(settings, "calibration_speed", None)
    return float(value) if is_number(value) and value > 0 else math.nan


def pinned_settings(settings: Any, record: Mapping[str, Any]) -> Any:
    """``settings`` with every field that a run resolved from its scene fixed at the value it ran with.

    ``record`` is a run's ``Trajectory.settings``: the settings as run, by field name, and
    what the run resolved from its scene as ``FIELD_used`` (Drake's ``calibration_speed_used``
    and ``w0_used`` for ``calibration_speed`` and ``w0`` at 0: "take it from the scene"). A
    field whose resolved (else recorded) value differs from the one given is set to it, so
    that the strikes of ``restitution_curve`` all meet the contact made for that scene rather
    than one remade for each strike. Fields run as given change nothing (MuJoCo, PyBullet).
    """
    changes = {}
    for f in dataclasses.fields(settings):
        given = getattr(settings, f.name)
        ran = record.get(f"{f.name}_used", record.get(f.name, given))
        ran = float(ran) if isinstance(given, float) and is_number(ran) else ran
        if type(ran) is type(given) and ran != given and (not is_number(ran) or math.isfinite(ran)):
            changes[f.name] = ran
    return dataclasses.replace(settings, **changes) if changes else settings


@dataclass(frozen=True)
class Rebound:
    """One strike measured at the wall's surface: speeds in the wall's normal [m/s], e = v_plus / -v_minus [-]."""

    v_minus: float  # < 0: the incoming speed where the body reaches the wall's surface
    v_plus: float  # >= 0: the speed where it leaves the surface again (0: it never left); NaN: not yet known
    restitution_effective: float  # e = -v_plus / v_minus; NaN: not yet known
    rebound: bool  # the body left the wall faster than REST_FRACTION of the strike
    status: str = "ok"  # "ok", "no impact", "unfinished"
    t: float = math.nan  # [s] when the free flight reached the wall's surface (a rigid engine may stop it past); NaN: none


def wall_rebound(traj: Trajectory, scene: Scene, wall: str, speed: float) -> Rebound:
    """The first strike of ``traj`` on ``wall``, measured by the judge's rule: its first impact on that wall
    (``pipeline/extract.py``'s, as ``engines/sampled_impacts.first_impact`` finds it, to the last bit, without
    the event log a strike does not need), e = -v+ / v- with the speeds where the body crosses the wall's surface on
    its way in and out (``pipeline/surface.py``): what a run's impacts are judged by too.

    In the wall's normal (d = n (y - y_wall), u = n y', a = n y''_free; n = +1 lower, -1 upper). A
    body still in the wall at the end (no rebound speed yet) is held (e = 0) if it has been at rest,
    |u| <= ``REST_FRACTION`` ``speed``, over the last quarter of its samples since the strike, else
    ``unfinished``.
    """
    n = 1.0 if wall == "lower" else -1.0
    t = np.asarray(traj.t, dtype=float)
    d = n * (np.asarray(traj.y, dtype=float) - scene.gap.position(wall))
    u = n * np.asarray(traj.vy, dtype=float)
    a = n * free_relative_acceleration(scene, t, traj.x1, traj.v1, traj.y, traj.vy)
    flag = traj.contact.get(wall) if traj.contact else None
    contact = np.asarray(flag, dtype=bool) if flag is not None and len(flag) == len(t) else d <= 0.0
    force = traj.normal_force.get(wall) if traj.normal_force else None
    force = np.asarray(force, dtype=float) if force is not None and len(force) == len(t) else np.zeros(len(t))
    first = first_impact(t.tolist(), d.tolist(), u.tolist(), a.tolist(), contact.tolist(), force.tolist())
    if first is None or first["first"] == 0:
        return Rebound(math.nan, math.nan, math.nan, False, "no impact")
    v_minus, v_plus = first["v_minus"], first["v_plus"]
    above = np.flatnonzero(d[:first["first"]] > 0.0)  # the free flight's last sample above the surface
    k = int(above[-1]) if len(above) else -1
    # where that flight meets the surface [s]: its parabola through the positions of k - 1 and k (a semi-implicit
    # step's sampled velocity is half a step off the positions' parabola, enough to miss a crossing just before k + 1)
    v_k = surface_velocity(t.tolist(), d.tolist(), u.tolist(), a.tolist(), k, k - 1) if k >= 1 else math.nan
    s_in = first_root(d[k], v_k, a[k], 2.0 * (t[k + 1] - t[k])) if 1 <= k < len(t) - 1 else math.nan
    t_hit = t[k] + s_in if math.isfinite(s_in) else first["t"]
    if math.isfinite(v_plus):
        return Rebound(v_minus, v_plus, v_plus / -v_minus, bool(v_plus > REST_FRACTION * speed), t=t_hit)
    tail = np.abs(u[first["first"]:][-max(2, (len(u) - first["first"]) // 4):])
    if tail.max() <= REST_FRACTION * speed:  # held, at rest: no rebound
        return Rebound(v_minus, 0.0, 0.0, False, t=t_hit)
    return Rebound(v_minus, math.nan, math.nan, False, "unfinished", t=t_hit)


@dataclass(frozen=True)
class Target:
    """What strikes aim at: their scene as a function of (timesteps after the strike, aim), the wall, the speed [m/s]."""

    make_scene: Callable[[int, float], Scene]
    wall: str
    speed: float


def strike(engine: str, settings: Any, make_scene: Callable[[int, float], Scene], wall: str, speed: float,
           phases: Sequence[float] = (0.5,), ends: bool = False) -> list[dict]:
    """Run ``make_scene(after_steps, aim)`` at each aim of ``phases`` and measure its first strike on ``wall``
    (``wall_rebound``), running longer (``EXTEND`` times, ``TRIES`` runs at most) those still in a moving contact
    at the end. ``ends``: two more strikes, aimed so that the engine meets the wall ``EDGE`` of a step after a
    sample and ``EDGE`` before the next (``aim_ends``). ``strike_all`` with one target.

    Returns per strike, in order, the curve's measured columns: phase (where in its step the engine met the
    wall [-]), aim (the phase it was started for [-]), v_minus, v_plus (relative velocities in y [m/s]),
    restitution_effective, rebound, status, message.
    """
    return strike_all(engine, settings, [Target(make_scene, wall, speed)], phases, ends)[0]


def strike_all(engine: str, settings: Any, targets: Sequence[Target], phases: Sequence[float] = (0.5,),
               ends: bool = False) -> list[list[dict]]:
    """``strike`` for each of ``targets`` (per target its rows, in order), the strikes of all of them handed to the
    engine together: one batch per try (``run_engine_batch``: MuJoCo rolls them out as one batch on one compiled
    model, each bit for bit as alone), one for the ends of every target's step and one for their re-aims."""
    rows = _struck(engine, settings, [(target, list(phases)) for target in targets])
    if not ends:
        return rows
    return [r + e for r, e in zip(rows, aim_ends(engine, settings, targets, rows))]


def aim_ends(engine: str, settings: Any, targets: Sequence[Target], rows: Sequence[list[dict]]) -> list[list[dict]]:
    """Per target, strikes at the two ends of a step, where e jumps (the contact starts just after a sample, or just
    before the next): aimed at phases ``EDGE`` and 1 - ``EDGE`` corrected by how far the engine's own free flight
    moved the impacts of its ``rows`` from their aims (a semi-implicit step drifts from the exact flight by
    |y''| dt^2 / 2 a step), aimed once more where one misses by more than ``EDGE`` / 2; [] for a target none of
    whose rows was measured."""
    edges = [EDGE, 1.0 - EDGE]
    aimed: list[tuple[int, list[float]]] = []
    for i, target_rows in enumerate(rows):
        shifts = [_wrapped(r["phase"] - r["aim"]) for r in target_rows if math.isfinite(r["phase"])]
        if shifts:
            shift = float(np.median(shifts))
            aimed.append((i, [(edge - shift) % 1.0 for edge in edges]))
    out: list[list[dict]] = [[] for _ in targets]
    for (i, _), ends in zip(aimed, _struck(engine, settings, [(targets[i], aims) for i, aims in aimed])):
        out[i] = ends
    again = [(i, j, (row["aim"] - _wrapped(row["phase"] - edge)) % 1.0)
             for i, ends in enumerate(out) for j, (edge, row) in enumerate(zip(edges, ends))
             if math.isfinite(row["phase"]) and abs(_wrapped(row["phase"] - edge)) > 0.5 * EDGE]
    for (i, j, _), (row,) in zip(again, _struck(engine, settings, [(targets[i], [aim]) for i, _, aim in again])):
        out[i][j] = row
    return out


def _wrapped(x: float) -> float:
    """``x`` [steps] brought into [-1/2, 1/2): a difference of phases."""
    return (x + 0.5) % 1.0 - 0.5


def _struck(engine: str, settings: Any, jobs: Sequence[tuple[Target, list[float]]]) -> list[list[dict]]:
    """Per (target, aims) of ``jobs``, one strike per aim (``strike``); the strikes of all jobs in one batch per try."""
    rows = [[{"phase": math.nan, "aim": aim, "v_minus": math.nan, "v_plus": math.nan, "restitution_effective": math.nan,
              "rebound": False, "status": "unfinished",
              "message": f"still in a moving contact {AFTER_STEPS * EXTEND**(TRIES - 1)} steps after the strike"}
             for aim in aims] for _, aims in jobs]
    waiting = [(i, j) for i, (_, aims) in enumerate(jobs) for j in range(len(aims))]
    for attempt in range(TRIES):
        if not waiting:
            break
        starts = [jobs[i][0].make_scene(AFTER_STEPS * EXTEND**attempt, jobs[i][1][j]) for i, j in waiting]
        runs = run_engine_batch(engine, [(start, settings) for start in starts])
        still = []
        for (i, j), start, traj in zip(waiting, starts, runs):
            target, row = jobs[i][0], rows[i][j]
            if traj.status != "ok" or len(traj.t) < 2:
                row.update(status=traj.status, message=traj.message)
                continue
            got = wall_rebound(traj, start, target.wall, target.speed)
            if math.isfinite(got.t):
                row["phase"] = ((got.t - start.initial.t) / float(settings.dt)) % 1.0  # samples at t0 + k dt
            n = 1.0 if target.wall == "lower" else -1.0
            if got.status == "no impact":
                row.update(status="no impact", message=f"no impact on the {target.wall} wall in {start.duration:.3g} s")
            elif got.status == "ok":
                row.update(v_minus=n * got.v_minus, v_plus=n * got.v_plus, restitution_effective=got.restitution_effective,
                           rebound=got.rebound, status="ok", message="")
            else:
                still.append((i, j))
        waiting = still
    return rows


def restitution_curve(engine: str, settings: Any, restitution: float, speeds: Sequence[float], scene: Scene | None = None,
                      gravity: float = 0.0, phases: int = PHASES) -> pd.DataFrame:
    """Effective restitution of ``engine`` with ``settings`` at each impact speed, struck at ``phases`` places in a
    step (module docstring).

    Parameters
    ----------
    engine : str
        A registry name (``engines.registry.ENGINE_NAMES``).
    settings : the engine's settings dataclass (``registry.make_settings``); its ``dt`` [s] sets the approach.
    restitution : float
        Newton's R the engine is set up for, in (0, 1).
    speeds : sequence of float
        Incoming relative speeds [m/s], each > 0 (``log_speeds``, ``default_speeds``).
    scene : Scene, optional
        Whose bodies strike (masses, lower wall); default the bouncing ball.
    gravity : float
        [m/s^2] >= 0, pressing body 2 into the wall; 0: the contact law alone.
    phases : int
        Strikes per speed aimed through a step, at ``strike_phases(phases)`` (>= 1; ``PHASES``), and two more at its
        ends (``aim_ends``).

    Returns
    -------
    DataFrame
        ``CURVE_COLUMNS``, one row per speed and strike (``phases`` + 2), speeds in the order given
        (``restitution_band``: per speed).
    """
    restitution = check_restitution(restitution)
    gravity = check_number("gravity", gravity, lo=0.0, unit=" [m/s^2]", error=CalibrationError)
    speeds = [check_number("speed", v, lo=0.0, lo_open=True, unit=" [m/s]", error=CalibrationError) for v in speeds]
    at = strike_phases(phases)
    scene = scene if scene is not None else load_scene("bouncing-ball")
    rows = []
    targets = [Target(lambda steps, phase, v=v: impact_scene(scene, restitution, v, settings.dt, gravity, steps, phase),
                      "lower", v) for v in speeds]
    for v, struck in zip(speeds, strike_all(engine, settings, targets, at, ends=True)):
        for row in struck:
            rows.append({"engine": engine, "forces": "gravity" if gravity > 0 else "none", "impact": math.nan,
                         "t": math.nan, "wall": "lower", "speed": v, "restitution": restitution,
                         "restitution_error": float(restitution_error(np.float64(row["restitution_effective"]), restitution)),
                         "restitution_uncertainty": sampling_uncertainty(restitution, gravity, settings.dt, v),
                         "gravity": gravity, "dt": float(settings.dt), "calibration_speed": calibration_speed(settings), **row})
    return pd.DataFrame(rows, columns=CURVE_COLUMNS)


def restitution_band(curve: pd.DataFrame) -> pd.DataFrame:
    """Per engine, forces and speed (and impact, for the strikes under the scene's forces): e over the phases of a
    step. ``BAND_COLUMNS``: the curve's keys, phases (strikes measured), e_min, e_median, e_max (effective
    restitution [-]), error_worst (the signed e / R - 1 of largest magnitude), restitution_uncertainty; rows in
    the curve's order."""
    keys = ["engine", "forces", "impact", "t", "wall", "speed", "restitution", "restitution_uncertainty", "dt"]
    measured = curve[np.isfinite(curve["restitution_effective"].astype(float))]
    grouped = measured.groupby(keys, sort=False, dropna=False)
    band = grouped["restitution_effective"].agg(phases="count", e_min="min", e_median="median", e_max="max")
    band["error_worst"] = grouped["restitution_error"].agg(worst_signed)
    return band.reset_index()[BAND_COLUMNS]


def impact_restitutions(engine: str, settings: Any, scene: Scene, solution: ReferenceSolution | None = None,
                        tol: Tolerances | None = None, trajectory: Trajectory | None = None) -> pd.DataFrame:
    """Restitution of every resolved impact of ``engine`` on ``scene``, by the judge's pairing (``judge_run``).

    ``trajectory``: a run already made to judge instead of running the engine (the exact
    reference's samples, ``reference_trajectory``, are the known answer: e = R at every impact).

    Returns ``IMPACT_COLUMNS``: impact (1 for the scene's first resolved impact, in time
    order over every visit), t [s], speed (the engine's incoming speed [m/s]), ref_speed (the
    paired reference impact's), restitution (the scene's R), restitution_effective (e),
    restitution_error (e / R - 1) and restitution_uncertainty (what one step's sampling
    leaves undetermined, ``pipeline/impacts.py``) and worst (true for the one impact whose
    error the judge reports as the run's restitution error: per visit the pair of largest
    excess over its uncertainty, then the largest of those in magnitude, the report's
    ``restitution_error_max``). A failed run has no rows.
    """
    ref = solution if solution is not None else solve(scene)
    _, table, pairs = judge_run(ref, engine, settings, tol or Tolerances(), trajectory)
    pairs = pairs.sort_values("t", kind="stable").reset_index(drop=True)
    reported = worst_signed(table["restitution_error"]) if "restitution_error" in table else math.nan
    worst = np.zeros(len(pairs), dtype=bool)
    worst[np.flatnonzero(pairs["restitution_error"].to_numpy(dtype=float) == reported)[:1]] = True
    return pd.DataFrame({"engine": engine, "impact": np.arange(1, len(pairs) + 1), "t": pairs["t"],
                         "speed": pairs["v_minus"], "ref_speed": pairs["ref_v_minus"], "restitution": scene.restitution,
                         "restitution_effective": pairs["restitution"], "restitution_error": pairs["restitution_error"],
                         "restitution_uncertainty": pairs["restitution_uncertainty"], "worst": worst},
                        columns=IMPACT_COLUMNS)
