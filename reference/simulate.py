"""The event-driven reference: exact free flight, impacts, sliding by Feigin's model, exits.

    >>> from chatterbench.reference import load_scene, simulate
    >>> result = simulate(load_scene("feigin-pair"), chatter="feigin")
    >>> result.status, len(result.episodes), round(float(result.episodes["t_exit"].iloc[0]), 6)
    ('ok', 13, 3.141593)

Between events the motion is the closed-form flow of ``linear.py``. Events:

- ``impact``: y reaches a wall; Newton's law (1.3) with restitution R.
- ``plate_entry``: the strike lies in Feigin's sliding plate Pi_2 ((2.1)-(2.2), ``plate.py``).
  In ``feigin`` mode the strike is made perfectly inelastic and the masses move in
  kinematic constraint (1.4) at once; in ``exhaustive`` mode it is only recorded and every
  impact of the chatter sequence is followed.
- ``stick``: motion in kinematic constraint starts. Besides the plate, a chatter sequence is
  caught by the accumulation test: after an impact with rebound speed v+ and relative
  acceleration a into the wall, the remaining flights sum to dt* = 2 v+ / ((1 - R) |a|)
  (= 2 R v / ((1 - R) |a|) for an incoming speed v); once dt* is below
  ``accumulation_time`` the sequence is summed in closed form and sticking starts at its
  accumulation (Zeno) point t + dt*. The error of that sum is O(|a'| / |a| dt*^2).
- ``exit``: the free relative acceleration (3.1) along the constrained motion reaches zero
  and turns away from the wall, found as a root of its closed form.

Promises: events strictly increase in time (an impact, its plate entry and its stick share
one time); y is put exactly on the wall at every impact; momentum m1 v1 + m2 v2 is
conserved by every impact to rounding; the result is bit-identical for the same inputs.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .chatter import CHASE_LEFT, CHASE_STRIKE, chase
from .flow import evaluate, shared_flow
from .impact import impact
from .linear import V1, VY, X1, Y, LinearSystem
from .log import EventLog, episodes
from .plate import plate_conditions, quick_reject
from .roots import first_wall_root
from .stuck import BOUNDS_FAILED, RUN_END, STALLED, walk
from .scene import Scene, SceneError

CHATTER_MODES = ("feigin", "exhaustive")
# a Taylor coefficient of (3.1) this small against the largest (in units of the flow step)
# is rounding, not a sign (see ``_Simulator._rest``)
NEGLIGIBLE = 1e-14
# [m per m of |wall position|, at least 1 m] a start this close to a wall is on it: below what positions resolve (a root
# of the flight this close to its start lies under the resolution of t, and the impact would go unseen)
ON_WALL = 1e-15


@dataclass(frozen=True)
class Options:
    """How the reference resolves chatter, and its tolerances."""

    chatter: str = "feigin"  # "feigin": plate entry -> inelastic impact; "exhaustive": every impact
    accumulation_time: float | None = None  # [s] dt* below which chatter is summed; default 1e-9 * time scale
    root_rtol: float = 1e-14  # relative precision of event times
    max_events: int = 5_000_000  # guard against an endless event sequence
    max_steps: int = 1_000_000  # guard against a run that cannot finish: flow steps [1] the run may need

    def __post_init__(self) -> None:
        if self.chatter not in CHATTER_MODES:
            raise SceneError(f"chatter = {self.chatter!r}: must be one of {', '.join(CHATTER_MODES)}")
        if self.accumulation_time is not None and not (math.isfinite(self.accumulation_time) and self.accumulation_time > 0):
            raise SceneError(f"accumulation_time = {self.accumulation_time!r}: must be a finite number > 0 [s]")
        if not 0 < self.root_rtol < 1e-6:
            raise SceneError(f"root_rtol = {self.root_rtol!r}: must be in (0, 1e-6)")
        if not self.max_events > 0:
            raise SceneError(f"max_events = {self.max_events!r}: must be > 0")
        if not self.max_steps > 0:
            raise SceneError(f"max_steps = {self.max_steps!r}: must be > 0")


@dataclass(frozen=True)
class Result:
    """A reference run: the event log, its episodes and the final state.

    ``log`` and ``episodes`` are DataFrames documented in ``log.py``; ``final`` is
    (t, x1, v1, y, vy) at the end of the run [s, m, m/s, m, m/s]; ``status`` is ``"ok"``,
    ``"max_events"`` (the event guard stopped the run) or ``"stalled"`` (the run stopped
    making progress: a flight or a stuck stretch past ``max_steps`` flow steps, a step
    below the resolution of t, a non-finite state; absurd scene values such as a forcing
    frequency of 1e300 rad/s). Either way the log up to there is kept.
    """

    scene: Scene
    options: Options
    log: pd.DataFrame
    episodes: pd.DataFrame
    final: tuple[float, float, float, float, float]
    status: str = "ok"
    message: str = ""
    wall_time: float = 0.0  # [s] of wall clock
    stats: dict = field(default_factory=dict)

    @property
    def n_impacts(self) -> int:
        """Number of impact events in the log."""
        return int((self.log["kind"] == "impact").sum())


def _normal(wall: str) -> float:
    """+1 for the lower wall (gap opens upwards), -1 for the upper wall."""
    return 1.0 if wall == "lower" else -1.0


class _Simulator:
    """The event loop; one instance per run (holds the flows and the log)."""

    def __init__(self, scene: Scene, options: Options) -> None:
        self.scene = scene
        self.options = options
        self.system = LinearSystem.from_scene(scene)
        horizon = scene.time_scale / 4.0
        self.free = shared_flow(self.system.free, horizon)  # shared by every run of the scene: read only
        self.stuck = shared_flow(self.system.stuck, horizon)
        self.accel_row = self.system.accel_row
        self.jerk_row = self.accel_row @ self.system.free  # y''' of the free motion
        self.walls = scene.gap.walls
        self.wall_y = {w: scene.gap.position(w) for w in self.walls}
        self.R = scene.restitution
        self.m1, self.m2 = scene.mass1, scene.mass2
        self.t_end = scene.t_end
        self.acc_time = options.accumulation_time or 1e-9 * scene.time_scale
        self.exhaustive = options.chatter == "exhaustive"
        self.log = EventLog()
        self._pw = np.arange(self.free.order + 1)
        self.stats = {"steps": 0, "plate_tests": 0}
        self._known_exit = None  # (t_exit, state) found by a plate test, reused by _stay
        self._lead = 0  # negligible leading coefficients of (3.1) at the last resting strike (_rest)
        self._flat = np.ascontiguousarray(self.free.powers.reshape(-1, self.system.size))
        self._flat_stuck = np.ascontiguousarray(self.stuck.powers.reshape(-1, self.system.size))
        self._share = 0.0 if scene.body1_infinite else scene.mass2 / (scene.mass1 + scene.mass2)
        self._omegas = np.asarray(self.system.omegas, dtype=float)
        self._chase_buf = np.empty((4096, 5))  # impacts logged per compiled chase

    # -- helpers ---------------------------------------------------------------------
    def _powers(self, h: float) -> np.ndarray:
        return h**self._pw

    def _reseed(self, s: np.ndarray, t: float) -> None:
        """Put the forcing generators back on their exact values at time t."""
        self.system.reseed(s, t)

    def _event(self, t: float, kind: str, wall: str, v_minus: float, v_plus: float, s: np.ndarray, rule: str = "") -> None:
        self.log.add(t, kind, wall, v_minus, v_plus, float(s[X1]), float(s[V1]), rule)
        if len(self.log) > self.options.max_events:
            raise _EventLimit

    def _constrained(self, s: np.ndarray, t: float, wall: str, bounds: bool, deflate: int = 0):
        """Walk the constrained motion from (s, t) until the exit or the end of the run.

        Returns (t_exit or None, state at t_exit or t_end, Y*, Y) where Y*, Y bound the
        wall-normal derivative of the free relative acceleration over the walk (only when
        ``bounds``; the walk stops early once Y* <= 0, returning t_exit = nan). ``deflate``
        leading coefficients of (3.1) are rounding (see ``_rest``).
        """
        s = s.copy()
        code, t, jmin, jmax = walk(self._flat_stuck, self.stuck.order, self.system.size, self.accel_row, s, t,
                                   self.t_end, self.wall_y[wall], _normal(wall), self.stuck.step, self._omegas, bounds,
                                   deflate, self.options.max_steps)
        if code == STALLED:
            raise _Stalled(f"the constrained motion on the {wall} wall stopped making progress at t = {float(t)!r} s "
                           f"(non-finite state, a step below the resolution of t, or over {self.options.max_steps} steps)")
        if code == BOUNDS_FAILED:
            return math.nan, s, jmin, jmax
        if code == RUN_END:
            return None, s, jmin, jmax
        return t, s, jmin, jmax

    def _rest(self, s: np.ndarray, wall: str) -> tuple[bool, int]:
        """Is a state resting on ``wall`` (vy = 0) pressed into it from now on? And how many
        leading Taylor coefficients of (3.1) are rounding?

        The sign of the free relative acceleration (3.1) along the constrained motion just
        after now is the sign of its first non-negligible Taylor coefficient, so that y'' = 0
        with the jerk into the wall (feigin-pair at rest on the lower wall at t = 0) counts
        as pressed. Negligible: |c_k| tau^k <= NEGLIGIBLE max_j |c_j| tau^j, tau the
        constrained flow's step [s] (a unit-consistent comparison; at t = 2 pi, sin t =
        -2.4e-16 is negligible). Whatever follows, the stuck walk (pressed) or the free
        flight (not), skips the same leading coefficients, so the two decisions agree; a
        function that is negligible throughout (no force at all) counts as pressed.
        """
        lam = _normal(wall) * (self.stuck.taylor(s) @ self.accel_row)
        scaled = np.abs(lam) * self.stuck.step ** np.arange(len(lam))
        big = np.flatnonzero(scaled > NEGLIGIBLE * scaled.max())
        if not len(big):
            return True, len(lam)
        lead = int(big[0])
        return bool(lam[lead] < 0.0), lead

    def _after_strike(self) -> int:
        """Coefficients of the gap function known to vanish after a strike that did not stick.

        y = wall exactly: c0 = 0. After a resting contact that lets go (y' = 0), also c1 = 0
        and the leading coefficients of y'' that ``_rest`` found to be rounding.
        """
        return 1 if self._lead == 0 else 2 + self._lead

    def _stuck_state(self, s: np.ndarray) -> np.ndarray:
        """The state after a perfectly inelastic impact (R = 0 in (1.3))."""
        out = s.copy()
        out[VY], out[V1] = impact(s[VY], s[V1], 0.0, self.m1, self.m2)
        return out

    # -- the loop --------------------------------------------------------------------
    def run(self) -> tuple[float, np.ndarray]:
        sc = self.scene
        t = sc.initial.t
        s = self.system.state(t, sc.initial.x1, sc.initial.v1, sc.initial.y, sc.initial.vy)
        deflate = {w: 0 for w in self.walls}
        plate_seen = False  # a plate entry was logged in the current visit (exhaustive mode)
        visit_wall = None
        # a state starting on a wall, moving into it or resting, is handled as a strike; "on" to within ON_WALL (a start
        # closer than positions resolve: from y = 5e-85 m at rest, pressed in, the impact's time is below t's resolution)
        for w in self.walls:
            if abs(s[Y] - self.wall_y[w]) <= ON_WALL * max(1.0, abs(self.wall_y[w])) and _normal(w) * s[VY] <= 0.0:
                s[Y] = self.wall_y[w]
                outcome = self._strike(t, s, w, plate_seen)
                t, s, stuck_wall, plate_seen = outcome
                visit_wall = w
                if stuck_wall is not None:
                    t, s = self._stay(t, s, stuck_wall)
                    if t is None:
                        return self.t_end, s
                    deflate = {x: 0 for x in self.walls}
                    deflate[stuck_wall] = 3
                    visit_wall, plate_seen = None, False
                else:
                    deflate[w] = self._after_strike()
                break
        walls_y = np.array([self.wall_y[w] for w in self.walls])
        normals = np.array([_normal(w) for w in self.walls])
        deflate = np.array([deflate[w] for w in self.walls], dtype=np.int64)
        rtol = self.options.root_rtol
        flight_steps = 0
        while t < self.t_end:
            hl = min(self.free.step, self.t_end - t)
            coeff_state = self.free.taylor(s)
            best, j = first_wall_root(coeff_state[:, Y], s[Y], walls_y, normals, deflate, hl, rtol)
            deflate[:] = 0
            if j < 0:
                s = evaluate(coeff_state, hl)
                flight_steps += 1
                if not (t + hl > t and np.isfinite(s).all()) or flight_steps > self.options.max_steps:
                    raise _Stalled(f"the free flight stopped making progress at t = {float(t)!r} s (non-finite state, a step "
                                   f"of {hl:.3g} s below the resolution of t, or over {self.options.max_steps} steps)")
                t = t + hl
                self.stats["steps"] += 1
                continue
            flight_steps = 0
            best_wall = self.walls[j]
            s = evaluate(coeff_state, best)
            t = t + best
            s[Y] = self.wall_y[best_wall]
            self._reseed(s, t)
            if visit_wall != best_wall:
                plate_seen, visit_wall = False, best_wall
            t, s, stuck_wall, plate_seen = self._strike(t, s, best_wall, plate_seen)
            if stuck_wall is None:
                deflate[j] = self._after_strike()
                continue
            t, s = self._stay(t, s, stuck_wall)
            if t is None:
                return self.t_end, s
            deflate[self.walls.index(stuck_wall)] = 3  # y = y' = y'' = 0 at an exit: three coefficients vanish
            visit_wall, plate_seen = None, False
        return t, s

    def _stay(self, t: float, s: np.ndarray, wall: str):
        """Constrained motion from a stick to the exit; logs the exit. (None, s) at the run's end."""
        if self._known_exit is not None:
            (t_exit, s), self._known_exit = self._known_exit, None
        else:
            t_exit, s, _, _ = self._constrained(s, t, wall, bounds=False, deflate=self._lead)
        if t_exit is None:
            return None, s
        self._event(t_exit, "exit", wall, 0.0, 0.0, s)
        return t_exit, s

    def plate_test(self, t: float, s: np.ndarray, wall: str):
        """Is the strike (state ``s`` on ``wall`` at time t, before the impact) inside Pi_2?

        Returns (inside, t_edge, state at the edge): the edge, where the free relative
        acceleration along the constrained motion returns to zero, is the exit of the
        sliding that would follow (None when the run ends first).
        """
        n = _normal(wall)
        R = self.R
        v = n * float(s[VY])
        acc = n * float(self.accel_row @ s)
        jerk = n * float(self.jerk_row @ s)
        if quick_reject(R, v, acc, jerk):
            return False, None, None
        self.stats["plate_tests"] += 1
        t_edge, s_edge, jmin, jmax = self._constrained(self._stuck_state(s), t, wall, bounds=True)
        window = (t_edge if t_edge is not None else self.t_end) - t
        inside = not math.isnan(window) and plate_conditions(R, v, acc, jmin, jmax, window).inside
        return inside, t_edge, s_edge

    def _strike(self, t: float, s: np.ndarray, wall: str, plate_seen: bool):
        """Resolve a strike at a wall. Returns (t, s, stuck_wall or None, plate_seen)."""
        n = _normal(wall)
        R = self.R
        self._lead = 0
        v_minus = float(s[VY])
        v = n * v_minus  # wall-normal incoming velocity, <= 0
        acc = n * float(self.accel_row @ s)
        if R == 0.0 or v >= 0.0:
            # perfectly inelastic, or a graze with no incoming speed
            s_in = self._stuck_state(s)
            self._event(t, "impact", wall, v_minus, 0.0, s_in)
            pressed, self._lead = self._rest(s_in, wall)
            if pressed:
                self._event(t, "stick", wall, 0.0, 0.0, s_in, "inelastic" if v < 0.0 else "contact")
                return t, s_in, wall, plate_seen
            return t, s_in, None, plate_seen
        entered = False
        if not (plate_seen and self.exhaustive):
            inside, t_edge, s_edge = self.plate_test(t, s, wall)
            if inside:
                s_in = self._stuck_state(s)
                if not self.exhaustive:
                    self._event(t, "impact", wall, v_minus, 0.0, s_in, "plate")
                    self._event(t, "plate_entry", wall, v_minus, 0.0, s_in)
                    self._event(t, "stick", wall, 0.0, 0.0, s_in, "plate")
                    # the walk to the edge of the plate was the constrained motion itself
                    self._known_exit = (t_edge, s_edge)
                    return t, s_in, wall, True
                entered = True
        vy_plus, v1_plus = impact(v_minus, float(s[V1]), R, self.m1, self.m2)
        s = s.copy()
        s[VY], s[V1] = vy_plus, v1_plus
        self._event(t, "impact", wall, v_minus, vy_plus, s)
        if entered:  # exhaustive mode: Feigin's model would slide from here; the impacts go on
            self._event(t, "plate_entry", wall, v_minus, vy_plus, s)
            plate_seen = True
        pull = (1.0 - R) * -acc  # [m/s^2] a subnormal |y''| (a harmonic force at t = 5e-324) underflows to 0 here
        if acc >= 0.0 or pull <= 0.0:  # nothing presses the body onto the wall: no accumulation
            return t, s, None, plate_seen
        dt_star = 2.0 * n * vy_plus / pull  # sum of all later flights
        if dt_star > self.acc_time:
            # follow the sequence in compiled code while nothing needs the event loop
            code, t, s, acc = self._chase(t, s, wall, check_plate=not (plate_seen and self.exhaustive))
            if code == CHASE_STRIKE:
                return self._strike(t, s, wall, plate_seen)
            if code == CHASE_LEFT:
                return t, s, None, plate_seen
            dt_star = 2.0 * n * float(s[VY]) / ((1.0 - R) * -acc)
        return self._accumulate(t, s, wall, dt_star, plate_seen)

    def _accumulate(self, t: float, s: np.ndarray, wall: str, dt_star: float, plate_seen: bool):
        """Sum the rest of the sequence: stick at the accumulation point t + dt*."""
        s_in = self._stuck_state(s)
        t_z = t + dt_star
        s_in = self.stuck.advance(s_in, dt_star)
        s_in[Y], s_in[VY] = self.wall_y[wall], 0.0
        self._reseed(s_in, t_z)
        self._event(t_z, "stick", wall, 0.0, 0.0, s_in, "zeno" if self.exhaustive else "accumulation")
        return t_z, s_in, wall, plate_seen

    def _chase(self, t: float, s: np.ndarray, wall: str, check_plate: bool):
        """Run ``chatter.chase`` from just after an impact; log its impacts. Returns (code, t, s, acc)."""
        n = _normal(wall)
        other = "upper" if wall == "lower" else "lower"
        s = s.copy()
        code, count, t = chase(
            self._flat, self.free.order, self.system.size, self.accel_row, self.jerk_row, s, t, self.t_end,
            self.wall_y[wall], n, self.wall_y.get(other, 0.0), other in self.wall_y, self.R, self._share,
            self.acc_time, self.options.root_rtol, self.free.step, self._omegas, check_plate, self._chase_buf,
        )
        if count:
            rows = self._chase_buf[:count].tolist()
            self.log.rows.extend((r[0], "impact", wall, r[1], r[2], r[3], r[4], "") for r in rows)
            if len(self.log) > self.options.max_events:
                raise _EventLimit
        return code, t, s, n * float(self.accel_row @ s)


class _Stalled(Exception):
    """The run stopped making progress (see ``Result``); the message says where."""


class _EventLimit(Exception):
    pass


def simulate(scene: Scene, chatter: str = "feigin", options: Options | None = None) -> Result:
    """Run the reference on ``scene`` for ``scene.duration`` seconds.

    Parameters
    ----------
    scene : Scene
        The validated scene.
    chatter : {"feigin", "exhaustive"}
        How chatter is resolved (see the module docstring); ignored when ``options`` is given.
    options : Options, optional
        Full options (tolerances, guard).
    """
    options = options or Options(chatter=chatter)
    with np.errstate(over="ignore", invalid="ignore"):  # absurd scales overflow the flow: reported as "stalled"
        sim = _Simulator(scene, options)
    start = time.perf_counter()
    status, message = "ok", ""
    try:
        needed = scene.duration / min(sim.free.step, sim.stuck.step)
        if not needed <= options.max_steps:
            raise _Stalled(f"the run needs about {needed:.3g} flow steps of {min(sim.free.step, sim.stuck.step):.3g} s "
                           f"(the scene's fastest time scale) over {scene.duration:g} s, more than max_steps = "
                           f"{options.max_steps}; check the forcing frequencies and stiffnesses")
        t, s = sim.run()
    except _EventLimit:
        status, message = "max_events", f"stopped after {options.max_events} events"
        t, s = math.nan, np.full(5, math.nan)
    except _Stalled as exc:
        status, message = "stalled", str(exc)
        t, s = math.nan, np.full(5, math.nan)
    wall = time.perf_counter() - start
    log = sim.log.frame()
    return Result(
        scene=scene,
        options=options,
        log=log,
        episodes=episodes(log),
        final=(float(t), float(s[X1]), float(s[V1]), float(s[Y]), float(s[VY])),
        status=status,
        message=message,
        wall_time=wall,
        stats=dict(sim.stats, events=len(sim.log)),
    )


def in_plate(scene: Scene, wall: str, t, v, x1=0.0, v1=0.0) -> np.ndarray:
    """Feigin's sufficient region: is each strike (time t [s], incoming y' = v [m/s]) inside Pi_2?

    Evaluates (2.1)-(2.2) exactly as the event loop does (window to the edge of the
    plate, bounds of the jerk from the closed-form motion). Arrays broadcast; returns bool.
    """
    sim = _Simulator(scene, Options())
    t, v, x1, v1 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (t, v, x1, v1)))
    out = np.zeros(t.shape, dtype=bool)
    y_wall = scene.gap.position(wall)
    for idx in np.ndindex(t.shape):
        state = sim.system.state(float(t[idx]), float(x1[idx]), float(v1[idx]), y_wall, float(v[idx]))
        sim.t_end = float(t[idx]) + scene.time_scale  # the window never needs more than a period here
        out[idx] = sim.plate_test(float(t[idx]), state, wall)[0]
    return out
