"""Effective restitution against impact speed, per engine: one single impact per speed, measured from the engine's samples.

    >>> from chatterbench.engines.registry import make_settings
    >>> curve = restitution_curve("pybullet", make_settings("pybullet", dt=1e-4), 0.5, [0.1, 1.0])
    >>> curve[["speed", "restitution_effective", "rebound"]].round(6).values.tolist()   # a Newton law: R at every speed
    [[0.1, 0.5, True], [1.0, 0.5, True]]
    >>> curve = restitution_curve("pybullet", make_settings("pybullet", 1e-4, ["pybullet.restitution_velocity_threshold=0.5"]),
    ...                           0.5, [0.1, 1.0])
    >>> curve[["speed", "restitution_effective", "rebound"]].round(6).values.tolist()   # cut to zero below 0.5 m/s
    [[0.1, 0.0, False], [1.0, 0.5, True]]

An engine tunes its contact to give Newton's R, but only at the conditions it was tuned
for: MuJoCo's force-only spring-damper gives R exactly at every speed without other forces
(``engines/restitution.py``), but under gravity part of the rebound is spent lifting the
weight during the contact (e ~ 1 - c g / (w0 v)); a Hunt-Crossley contact's losses grow
with the speed (its e climbs as impacts get slower); PyBullet's
``restitution_velocity_threshold`` cuts e to zero below it. ``restitution_curve`` shows
where, for any engine of the registry with any settings:

- **one impact per speed** (``impact_scene``): the scene's bodies (masses, lower wall) with
  no forces but an optional ``gravity`` [m/s^2] pressing body 2 into the lower wall (the
  ball's case), started ``APPROACH_STEPS`` timesteps of free flight away with the velocity
  that makes them strike at exactly ``speed``; without gravity this is the contact law
  alone, with it the ball dropped so that it arrives at that speed;
- **measured by the judge's own extraction** (``pipeline/extract.py``): the first impact on
  the lower wall, e = -v+ / v- (for a soft contact, at contact exit over contact entry); a
  velocity jump between free samples is an impact only above ``REST_FRACTION`` of the
  strike speed (the extraction's ``jump_atol``: with no force its floor of 1e-9 m/s would
  take an integrator's interpolation for an impact);
- **no rebound is e = 0, not NaN**: a run whose bodies stay together after the impact
  (PyBullet under its threshold, a soft contact under gravity too slow to lift off) ends
  in a contact whose relative speed has stayed below ``REST_FRACTION`` of the impact
  speed over the last quarter of the run. A contact still moving at the end is run again
  ``EXTEND`` times longer (``TRIES`` runs at most: 256 ... 16,384 timesteps after the
  strike); a run that fails or finds no impact keeps its status and a NaN e.

**The contact is the scene's.** An engine whose contact is made from the scene it runs
(Drake: stiffness and dissipation from the scene's first impact, when its settings leave
``calibration_speed`` and ``w0`` at 0) would remake it for every strike and calibrate each
one to R; ``pinned_settings`` fixes such settings at the values a run of the whole scene
recorded (``Trajectory.settings``), so every strike meets the contact that scene gets. The
command line pins them from the run it makes for ``impact_restitutions``.

``impact_restitutions`` is the other view: the restitution of each resolved impact of a
whole scene (the bouncing ball: its k-th impact), from the judge's paired impacts
(``pipeline/impacts.py``), so the drift is seen where the scene meets it.

Speeds: ``default_speeds`` spans two decades below the scene's first impact speed v1 (the
ball's 4.43 m/s down to 0.0443 m/s: its chatter ladder halves the speed at every impact
at R = 0.5, so its first seven impacts) and up to 2 v1 (``ABOVE``: an engine calibrated
at v1 shows which way it goes on both sides), log-spaced. An engine calibrated at one
impact speed names it in its settings as ``calibration_speed`` [m/s] (column
``calibration_speed``, NaN where the settings have none: MuJoCo's law holds at every speed).

Columns of the curve (``CURVE_COLUMNS``): engine, speed (the incoming relative speed set
[m/s], > 0), restitution (nominal R), restitution_effective (e = -v+ / v- [-]; 0 when no
rebound), restitution_error (e / R - 1), v_minus and v_plus (the measured relative
velocities before and after [m/s], the wall's normal pointing out of it), rebound (the
bodies part after the impact, faster than ``REST_FRACTION`` of the impact speed), gravity
[m/s^2], dt [s], calibration_speed [m/s], status, message.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from chatterbench.engines.registry import run_engine
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.errors import InputError, check_integer, check_number, is_number
from chatterbench.reference.scene import Scene, load_scene, scene_from_dict
from chatterbench.reference.simulate import simulate

from ..pipeline.compare import judge_run
from ..pipeline.extract import ExtractionOptions, extract
from ..pipeline.impacts import restitution_error
from ..pipeline.solution import ReferenceSolution, solve
from ..pipeline.tolerances import Tolerances

CURVE_COLUMNS = ["engine", "speed", "restitution", "restitution_effective", "restitution_error", "v_minus", "v_plus",
                 "rebound", "gravity", "dt", "calibration_speed", "status", "message"]
IMPACT_COLUMNS = ["engine", "impact", "t", "speed", "ref_speed", "restitution", "restitution_effective",
                  "restitution_error", "restitution_uncertainty"]
APPROACH_STEPS = 20  # [steps] free flight sampled before the strike (the extraction carries the last free sample to the wall)
AFTER_STEPS = 256  # [steps] run after the strike at the first try (MuJoCo's default contact lasts ~105)
EXTEND = 4  # [-] each further try runs this many times longer after the strike
TRIES = 4  # [-] runs at most per speed: 256, 1024, 4096, 16384 steps after the strike
REST_FRACTION = 1e-3  # [-] of the strike speed: below it a contact is at rest, a parting is no rebound, a jump no impact
DECADES_BELOW = 2.0  # the default speeds span this many decades below the scene's first impact speed ...
ABOVE = 2.0  # ... up to this many times it
DEFAULT_POINTS = 13  # about five speeds a decade over the default 2.3 decades, ends included
MAX_POINTS = 200  # speeds per engine at most: each is one engine run


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


def impact_scene(scene: Scene, restitution: float, speed: float, dt: float, gravity: float = 0.0,
                 after_steps: int = AFTER_STEPS) -> Scene:
    """One strike of ``scene``'s bodies on its lower wall at relative speed ``speed`` [m/s] (module docstring).

    Body 1 is held still (its prescribed motion and every force dropped); ``gravity`` [m/s^2]
    is a constant force -m2 g on body 2, so y'' = -g between impacts. The strike comes after
    t_a = (``APPROACH_STEPS`` + 1/2) dt, halfway through a step so that no rounding decides which
    sample touches first (shorter when a slow strike under gravity needs it: t_a <= v / g),
    from y0 = v t_a - g t_a^2 / 2 above the wall with y' = -v + g t_a; the run lasts
    t_a + ``after_steps`` dt.
    """
    speed = check_number("speed", speed, lo=0.0, lo_open=True, unit=" [m/s]", error=CalibrationError)
    gravity = check_number("gravity", gravity, lo=0.0, unit=" [m/s^2]", error=CalibrationError)
    t_a = (APPROACH_STEPS + 0.5) * dt  # mid-step: which sample first touches never hangs on rounding
    t_a = t_a if gravity == 0.0 else min(t_a, speed / gravity)
    data = scene.to_dict()
    data.pop("prescribed", None)
    data.update(name=f"{scene.name}-impact", restitution=restitution, gap={"lower": scene.gap.lower},
                forces=[{"kind": "constant", "on": "body2", "value": -scene.mass2 * gravity}] if gravity > 0 else [],
                initial={"t": 0.0, "x1": scene.initial.x1 if scene.body1_infinite else 0.0, "v1": 0.0,
                         "y": scene.gap.lower + speed * t_a - 0.5 * gravity * t_a**2, "vy": -speed + gravity * t_a},
                duration=t_a + after_steps * dt,
                description=f"one strike at {speed:g} m/s on the lower wall" + (f" under g = {gravity:g} m/s^2" if gravity else ""))
    return scene_from_dict(data)


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


def _one_impact(engine: str, settings: Any, scene: Scene, restitution: float, speed: float, gravity: float) -> dict:
    """Strike once at ``speed``, running longer while the contact is still moving at the end (module docstring)."""
    row = {"v_minus": math.nan, "v_plus": math.nan, "restitution_effective": math.nan, "rebound": False,
           "status": "ok", "message": ""}
    for attempt in range(TRIES):
        start = impact_scene(scene, restitution, speed, settings.dt, gravity, AFTER_STEPS * EXTEND**attempt)
        traj = run_engine(engine, start, settings)
        if traj.status != "ok" or len(traj.t) < 2:
            return {**row, "status": traj.status, "message": traj.message}
        # with no force, any velocity jump between two free samples over jump_atol would count as an impact:
        # a jump must be REST_FRACTION of the strike to be one (an integrator's interpolation makes 1e-7 m/s)
        impacts = extract(traj, start, options=ExtractionOptions(jump_atol=REST_FRACTION * speed)).impacts
        impacts = impacts[impacts["wall"] == "lower"]
        if impacts.empty:
            return {**row, "status": "no impact", "message": f"no impact on the lower wall in {start.duration:.3g} s"}
        first = impacts.iloc[0]
        row.update(v_minus=float(first["v_minus"]), v_plus=float(first["v_plus"]))
        if np.isfinite(first["v_plus"]):  # the contact let go: e = -v+ / v-
            return {**row, "restitution_effective": -float(first["v_plus"]) / float(first["v_minus"]),
                    "rebound": bool(first["v_plus"] > REST_FRACTION * speed)}
        tail = np.abs(np.asarray(traj.vy[-max(2, AFTER_STEPS * EXTEND**attempt // 4):], dtype=float))
        if tail.max() <= REST_FRACTION * speed:  # held, at rest over the last quarter of the run: no rebound
            return {**row, "restitution_effective": 0.0}
    return {**row, "status": "unfinished",
            "message": f"still in a moving contact {AFTER_STEPS * EXTEND**(TRIES - 1)} steps after the strike"}


def restitution_curve(engine: str, settings: Any, restitution: float, speeds: Sequence[float], scene: Scene | None = None,
                      gravity: float = 0.0) -> pd.DataFrame:
    """Effective restitution of ``engine`` with ``settings`` at each impact speed (module docstring).

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

    Returns
    -------
    DataFrame
        ``CURVE_COLUMNS``, one row per speed, in the order given.
    """
    restitution = check_restitution(restitution)
    gravity = check_number("gravity", gravity, lo=0.0, unit=" [m/s^2]", error=CalibrationError)
    speeds = [check_number("speed", v, lo=0.0, lo_open=True, unit=" [m/s]", error=CalibrationError) for v in speeds]
    scene = scene if scene is not None else load_scene("bouncing-ball")
    rows = []
    for v in speeds:
        row = _one_impact(engine, settings, scene, restitution, v, gravity)
        rows.append({"engine": engine, "speed": v, "restitution": restitution,
                     "restitution_error": float(restitution_error(np.float64(row["restitution_effective"]), restitution)),
                     "gravity": gravity, "dt": float(settings.dt), "calibration_speed": calibration_speed(settings), **row})
    return pd.DataFrame(rows, columns=CURVE_COLUMNS)


def impact_restitutions(engine: str, settings: Any, scene: Scene, solution: ReferenceSolution | None = None,
                        tol: Tolerances | None = None, trajectory: Trajectory | None = None) -> pd.DataFrame:
    """Restitution of every resolved impact of ``engine`` on ``scene``, by the judge's pairing (``judge_run``).

    ``trajectory``: a run already made to judge instead of running the engine (the exact
    reference's samples, ``reference_trajectory``, are the known answer: e = R at every impact).

    Returns ``IMPACT_COLUMNS``: impact (1 for the scene's first resolved impact, in time
    order over every visit), t [s], speed (the engine's incoming speed [m/s]), ref_speed (the
    paired reference impact's), restitution (the scene's R), restitution_effective (e),
    restitution_error (e / R - 1) and restitution_uncertainty (what one step's sampling
    leaves undetermined, ``pipeline/impacts.py``). A failed run has no rows.
    """
    ref = solution if solution is not None else solve(scene)
    _, _, pairs = judge_run(ref, engine, settings, tol or Tolerances(), trajectory)
    pairs = pairs.sort_values("t", kind="stable").reset_index(drop=True)
    return pd.DataFrame({"engine": engine, "impact": np.arange(1, len(pairs) + 1), "t": pairs["t"],
                         "speed": pairs["v_minus"], "ref_speed": pairs["ref_v_minus"], "restitution": scene.restitution,
                         "restitution_effective": pairs["restitution"], "restitution_error": pairs["restitution_error"],
                         "restitution_uncertainty": pairs["restitution_uncertainty"]}, columns=IMPACT_COLUMNS)
