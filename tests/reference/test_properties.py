"""Properties of the reference on random scenes of the catalogue's four families.

Each example draws one scene (parameters, initial time and state) from a family, runs it
for a few forcing periods and checks what must hold whatever the scene:

- every impact conserves m1 v1 + m2 v2 (Feigin 1967, (1.3)) against the free flight that
  arrives at it, and never increases |y'| (R < 1);
- event times never decrease; equal times only inside an impact's group
  (impact, plate_entry, stick: the promise of ``simulate.py``);
- y stays in the gap to 1e-12 m, on a grid and right around every event;
- a constrained stretch never ends while (3.1) still pushes into the wall, and (3.1) pushes
  into the wall all along it;
- the two chatter modes agree on the exits (section 4 of the paper);
- the same inputs give the same log, bit for bit.

Example counts come from the hypothesis profiles in ``tests/conftest.py``.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from hypothesis import assume, given, note, strategies as st

from chatterbench.reference import simulate
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.dense import sample
from chatterbench.reference.forces import body1_acceleration, relative_acceleration
from chatterbench.reference.scene import Scene, SceneError, load_scene, scene_from_dict
from chatterbench.reference.simulate import Options

TWO_PI = 2.0 * math.pi
MODES = ("feigin", "exhaustive")
FAMILIES = ("bouncing-ball", "feigin-pair", "impact-damper", "spring-pair")
# families whose forces depend on time only: Feigin's model is exact there (section 4)
TIME_ONLY = ("bouncing-ball", "feigin-pair")

# R up to 0.9: a chatter at R = 0.9 is ~200 impacts before the accumulation test sums
# the rest, which keeps an exhaustive example under ~50 ms; R = 0 is its own code path
restitutions = st.one_of(st.just(0.0), st.floats(0.05, 0.9))
unit = st.floats(0.0, 1.0)
# where in the gap the run starts: often on a wall (the initial-strike path)
gap_fraction = st.one_of(st.sampled_from([0.0, 1.0]), unit)


def _build(data: dict) -> Scene:
    try:
        scene = scene_from_dict(data)
    except SceneError as exc:  # draws are built to validate; a refusal is a strategy slip
        note(f"refused: {exc}")
        assume(False)
        raise  # pragma: no cover
    return scene


@st.composite
def bouncing_ball(draw) -> Scene:
    """Fixed floor, gravity g, drop height h (0: starts resting or striking), restitution."""
    d = copy.deepcopy(CATALOGUE["bouncing-ball"])
    g, m2 = draw(st.floats(1.0, 20.0)), draw(st.floats(0.1, 5.0))
    d.update(mass2=m2, restitution=draw(restitutions), duration=draw(st.floats(0.2, 3.0)))
    d["forces"] = [{"kind": "constant", "on": "body2", "value": -g * m2}]
    d["initial"] = {"t": draw(st.floats(0.0, 10.0)), "x1": 0.0, "v1": 0.0,
                    "y": draw(st.one_of(st.just(0.0), st.floats(0.0, 2.0))), "vy": draw(st.floats(-3.0, 3.0))}
    return _build(d)


@st.composite
def feigin_pair(draw) -> Scene:
    """Section 4: P sin(w t + phi) on body 1, |y| <= d; any mass ratio, start anywhere in the gap."""
    d = copy.deepcopy(CATALOGUE["feigin-pair"])
    half = draw(st.floats(0.01, 0.5))
    omega = draw(st.floats(0.5, 3.0))
    d.update(mass1=draw(st.floats(0.2, 5.0)), mass2=draw(st.floats(0.2, 5.0)), restitution=draw(restitutions))
    d["gap"] = {"lower": -half, "upper": half}
    d["forces"] = [{"kind": "harmonic", "on": "body1", "amplitude": d["mass1"] * draw(st.floats(0.2, 3.0)) * omega**2,
                    "omega": omega, "phase": draw(st.floats(0.0, TWO_PI))}]
    d["initial"] = {"t": draw(st.floats(0.0, 20.0)), "x1": draw(st.floats(-1.0, 1.0)), "v1": draw(st.floats(-1.0, 1.0)),
                    "y": -half + 2.0 * half * draw(gap_fraction), "vy": draw(st.floats(-1.0, 1.0)) * half * omega}
    d["duration"] = draw(st.floats(0.3, 3.0)) * TWO_PI / omega
    return _build(d)


@st.composite
def impact_damper(draw) -> Scene:
    """A primary on a spring and damper, forced near resonance, with a free mass in a cavity."""
    d = copy.deepcopy(CATALOGUE["impact-damper"])
    k = draw(st.floats(10.0, 400.0))
    w_n = math.sqrt(k)  # m1 = 1 kg
    omega = w_n * draw(st.floats(0.7, 1.3))
    half = draw(st.floats(0.002, 0.05))
    # a damper's free mass is a fraction of the primary's (the catalogue's: 0.1): up to 0.3 keeps
    # the primary's motion during the chatter close to the constrained one, which
    # test_modes_agree_on_exits relies on (a draw with mass2 = mass1 shifted an exit by 1.3e-3 of
    # the period: Feigin's idealisation, not an error of either mode)
    d.update(mass2=draw(st.floats(0.02, 0.3)), restitution=draw(restitutions))
    d["gap"] = {"lower": -half, "upper": half}
    d["forces"] = [
        {"kind": "spring", "on": "body1", "stiffness": k, "rest": 0.0},
        {"kind": "damper", "on": "body1", "damping": draw(st.floats(0.0, 2.0)) * 2.0 * 0.05 * w_n},
        {"kind": "harmonic", "on": "body1", "amplitude": draw(st.floats(0.5, 10.0)), "omega": omega,
         "phase": draw(st.floats(0.0, TWO_PI))},
    ]
    d["initial"] = {"t": draw(st.floats(0.0, 5.0)), "x1": draw(st.floats(-0.05, 0.05)), "v1": draw(st.floats(-0.5, 0.5)),
                    "y": -half + 2.0 * half * draw(gap_fraction), "vy": draw(st.floats(-0.5, 0.5))}
    d["duration"] = draw(st.floats(1.0, 4.0)) * TWO_PI / omega
    return _build(d)


@st.composite
def spring_pair(draw) -> Scene:
    """One-sided gap, a preloaded coupling spring pulling together, a harmonic push on body 2."""
    d = copy.deepcopy(CATALOGUE["spring-pair"])
    omega = draw(st.floats(1.0, 10.0))
    d.update(mass1=draw(st.floats(0.2, 2.0)), mass2=draw(st.floats(0.1, 2.0)), restitution=draw(restitutions))
    d["forces"] = [
        {"kind": "spring", "on": "coupling", "stiffness": draw(st.floats(5.0, 200.0)), "rest": draw(st.floats(-0.2, 0.02))},
        {"kind": "harmonic", "on": "body2", "amplitude": draw(st.floats(0.5, 10.0)), "omega": omega,
         "phase": draw(st.floats(0.0, TWO_PI))},
    ]
    d["initial"] = {"t": draw(st.floats(0.0, 5.0)), "x1": draw(st.floats(-0.1, 0.1)), "v1": draw(st.floats(-0.5, 0.5)),
                    "y": draw(st.one_of(st.just(0.0), st.floats(0.0, 0.1))), "vy": draw(st.floats(-0.5, 0.5))}
    d["duration"] = draw(st.floats(1.0, 4.0)) * TWO_PI / omega
    return _build(d)


SCENES = {"bouncing-ball": bouncing_ball(), "feigin-pair": feigin_pair(),
          "impact-damper": impact_damper(), "spring-pair": spring_pair()}


# far above any drawn run (a few thousand events at most), far below the default 5e6,
# which a runaway takes minutes to reach
MAX_EVENTS = 200_000


def _run(scene: Scene, mode: str):
    result = simulate(scene, mode, Options(chatter=mode, max_events=MAX_EVENTS))
    note(f"scene = {scene.to_dict()!r}")
    assert result.status == "ok", result.message
    return result


def _velocity_scale(result) -> float:
    """Largest speed in the log, at least 1 m/s: the scale of the absolute velocity tolerances."""
    log = result.log
    if log.empty:
        return 1.0
    return float(max(1.0, log.v_minus.abs().max(), log.v_plus.abs().max(), log.v1.abs().max(), abs(result.scene.initial.v1),
                     abs(result.scene.initial.vy)))


# -- the properties, each on one run ------------------------------------------------------
def check_impacts(result) -> None:
    """Momentum and energy at every impact, against the free flight sampled just before it.

    From the row, (1.3) inverted: v1_before = v1 + m2/(m1+m2) (v_plus - v_minus). The flight
    is sampled with ``dense.sample`` at t - delta (delta = 1e-8 s, or half the time since the
    previous event) and carried to t at first order with its own accelerations; the
    neglected term is jerk delta^2 / 2 < 1e-13 m/s for these scenes. Tolerance 1e-10 of the
    velocity scale, absolute: each flight is a closed-form flow at ~1e-14 relative, the
    sample time t - delta carries an absolute rounding of 1e-15 t, and near a Zeno point
    v_minus is itself tiny, so a relative test would ask more than the state holds.
    """
    scene, log = result.scene, result.log
    m1, m2 = scene.mass1, scene.mass2
    share = 0.0 if math.isinf(m1) else m2 / (m1 + m2)
    scale = _velocity_scale(result)
    imp = log[log.kind == "impact"]
    # |y'+| = R |y'-| <= |y'-|: the relative kinetic energy never grows (exact: one product)
    assert (imp.v_plus.abs() <= imp.v_minus.abs()).all(), imp[imp.v_plus.abs() > imp.v_minus.abs()]
    times = log.t.to_numpy()
    t0 = scene.initial.t
    rows = np.flatnonzero(log.kind.to_numpy() == "impact")
    v1, v_minus, v_plus = (log[c].to_numpy(dtype=float) for c in ("v1", "v_minus", "v_plus"))
    # the flight delta before each impact, every impact's sampled in one call (each sample is the flow from the
    # start of its own segment, as when sampled alone): None for a strike of the initial state itself, or within
    # a few ulps of it (an initial y one ulp inside the wall), where no time between t0 and t can be sampled
    before = []
    for i in rows:
        t = float(times[i])
        earlier = times[times < t]
        t_prev = float(earlier.max()) if len(earlier) else t0
        before.append(None if t - t0 <= 4 * math.ulp(t) and not len(earlier) else min(1e-8, 0.5 * (t - t_prev)))
    at = [float(times[i]) - delta for i, delta in zip(rows, before) if delta is not None]
    flights = iter(sample(scene, log, at).itertuples()) if at else iter(())
    for i, delta in zip(rows, before):
        t = float(times[i])
        v1_before = v1[i] + share * (v_plus[i] - v_minus[i])
        if delta is None:  # the state before it is the initial one
            vy_b, v1_b = scene.initial.vy, scene.initial.v1
        else:
            s = next(flights)
            a_y = relative_acceleration(scene, t - delta, s.x1, s.v1, s.y, s.vy)
            a_1 = body1_acceleration(scene, t - delta, s.x1, s.v1, s.y, s.vy)
            vy_b, v1_b = s.vy + a_y * delta, s.v1 + a_1 * delta
        tol = 1e-10 * scale
        assert abs(vy_b - v_minus[i]) <= tol, ("y' before the impact", i, t, vy_b, v_minus[i])
        assert abs(v1_b - v1_before) <= tol, ("x1' before the impact", i, t, v1_b, v1_before)
        if math.isinf(m1):
            assert v1[i] == v1_before  # an infinite body 1 is never kicked
        else:
            p_before = m1 * v1_b + m2 * (v1_b + vy_b)
            p_after = m1 * v1[i] + m2 * (v1[i] + v_plus[i])
            assert abs(p_after - p_before) <= 2.0 * tol * (m1 + m2), ("momentum", i, t, p_before, p_after)


# what may share one time: an impact, then its plate entry and/or its stick, on one wall
SAME_TIME = {("impact", "plate_entry"), ("impact", "stick"), ("plate_entry", "stick")}


def check_event_order(result) -> None:
    log, scene = result.log, result.scene
    t = log.t.to_numpy()
    if len(t) == 0:
        return
    assert t[0] >= scene.initial.t and t[-1] <= scene.t_end
    dt = np.diff(t)
    assert (dt >= 0.0).all(), log.iloc[np.flatnonzero(dt < 0.0)[0]:][:3]
    kinds, walls = log.kind.to_numpy(), log.wall.to_numpy()
    for i in np.flatnonzero(dt == 0.0):
        pair = (kinds[i], kinds[i + 1])
        assert pair in SAME_TIME and walls[i] == walls[i + 1], ("events share a time", i, pair, t[i], log.iloc[i:i + 2])


def _times_around_events(result, n: int = 2001) -> np.ndarray:
    scene, t = result.scene, result.log.t.to_numpy()
    offsets = np.concatenate([-np.logspace(-12, -3, 4), [0.0], np.logspace(-12, -3, 4)])
    times = np.concatenate([np.linspace(scene.initial.t, scene.t_end, n), (t[:, None] + offsets).ravel()])
    return np.clip(times, scene.initial.t, scene.t_end)


def check_in_gap(result) -> None:
    """y in [lower, upper] to 1e-12 m: impacts put y exactly on the wall, flights are exact to ~1e-15 relative."""
    scene = result.scene
    y = sample(scene, result.log, _times_around_events(result)).y.to_numpy()
    assert y.min() >= scene.gap.lower - 1e-12, y.min() - scene.gap.lower
    if scene.gap.upper is not None:
        assert y.max() <= scene.gap.upper + 1e-12, y.max() - scene.gap.upper


def _stretches(result):
    """(wall, t_stick, t_end of the stretch, exit row or None) for every constrained stretch."""
    log, out, open_ = result.log, [], None
    for row in log.itertuples():
        if row.kind == "stick":
            open_ = (row.wall, row.t)
        elif row.kind == "exit":
            assert open_ is not None and open_[0] == row.wall, ("exit without a stick on its wall", row)
            out.append((row.wall, open_[1], row.t, row))
            open_ = None
    if open_ is not None:
        out.append((open_[0], open_[1], result.scene.t_end, None))
    return out


def check_exits(result) -> None:
    """(3.1) at every exit is no longer into the wall, and along every stretch it is.

    Tolerance at the exit: 1e-9 of the largest |y''| seen along the stretch. The exit is a
    root of the closed-form y'' found to 1e-14 relative in time, so |y''| there is about
    |y'''| * 1e-14 t; 1e-9 leaves room for the t ~ 30 s of these runs and rounding in the
    force sum. Inside the stretch the sign is strict: 50 interior samples, none at its ends.
    """
    scene = result.scene
    for wall, t_stick, t_stop, exit_row in _stretches(result):
        n = 1.0 if wall == "lower" else -1.0
        inner = np.linspace(t_stick, t_stop, 52)[1:-1]
        traj = sample(scene, result.log, inner)
        a = n * relative_acceleration(scene, inner, traj.x1.to_numpy(), traj.v1.to_numpy(), traj.y.to_numpy(),
                                      traj.vy.to_numpy())
        if t_stop > t_stick:
            assert (a < 0.0).all(), ("(3.1) not into the wall inside a stuck stretch", wall, t_stick, t_stop,
                                     inner[a >= 0.0][:3], a[a >= 0.0][:3])
        if exit_row is not None:
            y_wall = scene.gap.position(wall)
            a_exit = n * relative_acceleration(scene, exit_row.t, exit_row.x1, exit_row.v1, y_wall, 0.0)
            acc_scale = max(float(np.abs(a).max()) if len(a) else 0.0, abs(a_exit), 1e-300)
            assert a_exit >= -1e-9 * acc_scale, ("exit while (3.1) is still into the wall", wall, exit_row.t, a_exit)


@pytest.mark.slow
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("family", FAMILIES)
@given(data=st.data())
def test_run_properties(family, mode, data):
    result = _run(data.draw(SCENES[family], label="scene"), mode)
    check_event_order(result)
    check_impacts(result)
    check_in_gap(result)
    check_exits(result)


# -- across runs ---------------------------------------------------------------------------
def _exits(result) -> tuple[np.ndarray, np.ndarray]:
    ex = result.log[result.log.kind == "exit"]
    return ex.t.to_numpy(), ex.wall.to_numpy()


def _exit_shift_bound(scene: Scene, feigin, exhaustive) -> float:
    """Largest first-order shift [s] of the first exit that the chatter's state difference causes.

    Stuck on a wall, both runs follow the same linear motion of the pair (mass M = m1 + m2)
    on body 1's spring k and damper c. The Feigin run enters it at the plate; the exhaustive
    run at the end of its chatter, with body 1 moved by ~m2/M of the chatter height. Their
    difference (dx, dv) in (x1, v1) at the exhaustive run's stick is a free damped oscillation
    whose energy M dv^2/2 + k dx^2/2 never grows (c >= 0), so along the stick |dx1| <= A =
    hypot(dx, sqrt(M/k) dv) and |dv1| <= sqrt(k/M) A. (3.1) = -F1/m1 then differs by at most
    (k + c sqrt(k/M)) A / m1, and the exit, a root of (3.1) with slope J, moves by that over
    |J| (J from (3.1) at 1e-3 of the period before the Feigin exit, where (3.1) is ~J h).
    0 where (3.1) does not depend on x1 or v1 (no spring or damper on body 1: spring-pair)
    or where the exhaustive run has no stick before its first exit (both start stuck).
    """
    k = sum(f.stiffness for f in scene.forces if f.kind == "spring" and f.on == "body1")
    c = sum(f.damping for f in scene.forces if f.kind == "damper" and f.on == "body1")
    log = exhaustive.log.reset_index(drop=True)
    first_exit = int(np.flatnonzero(log.kind.to_numpy() == "exit")[0])
    sticks = log.iloc[:first_exit][log.kind.iloc[:first_exit] == "stick"]
    if k <= 0.0 or sticks.empty:
        return 0.0
    stick = sticks.iloc[-1]
    ref = sample(scene, feigin.log, [stick.t]).iloc[0]
    mass = scene.mass1 + scene.mass2
    amp = math.hypot(stick.x1 - ref.x1, math.sqrt(mass / k) * (stick.v1 - ref.v1))
    da = (k + c * math.sqrt(k / mass)) * amp / scene.mass1
    t_exit = _exits(feigin)[0][0]
    h = 1e-3 * scene.time_scale
    p = sample(scene, feigin.log, [t_exit - h]).iloc[0]
    jerk = abs(relative_acceleration(scene, t_exit - h, p.x1, p.v1, p.y, p.vy)) / h
    return da / jerk if jerk > 0.0 else math.inf


def _exit_tolerance(scene: Scene, bound: float) -> float:
    """1e-4 of the period (rounding of the roots) + twice the first-order shift ``bound`` (its second order)."""
    return 1e-4 * scene.time_scale + 2.0 * bound


@pytest.mark.parametrize("family", FAMILIES)
@given(data=st.data())
def test_modes_agree_on_exits(family, data):
    """Feigin mode against every impact followed (exhaustive).

    Time-only forces (bouncing-ball, feigin-pair): the sign of (3.1) along the chatter and
    along the constrained motion is the same function of t, and the centre of mass moves
    the same way in both modes, so every exit agrees to 1e-9 s (roots at 1e-14 relative,
    t < 40 s) and so does everything after it.

    State-dependent forces (impact-damper: spring on body 1; spring-pair: coupling spring):
    during the chatter x1 (or y) differs from the constrained motion by ~m2/(m1+m2) of the
    chatter height, which shifts the exit; the catalogue impact-damper measures 2.7e-6 s.
    After a shifted exit the runs are different trajectories (a later graze may be a strike
    in one and a miss in the other), so only the first exit is compared, within 1e-4 of
    the forcing period plus twice the shift that the chatter's own state difference can
    cause (``_exit_shift_bound``). A fixed 1e-4 of the period failed on a draw whose chatter
    rose 0.26% of the gap (``test_tall_chatter_shifts_the_exit_within_its_bound``).
    """
    scene = data.draw(SCENES[family], label="scene")
    f, e = _run(scene, "feigin"), _run(scene, "exhaustive")
    tf, wf = _exits(f)
    te, we = _exits(e)
    if family in TIME_ONLY:
        assert len(tf) == len(te), (tf, te)
        assert (wf == we).all()
        np.testing.assert_allclose(tf, te, rtol=0.0, atol=1e-9)
    else:
        # the first stretch: if either run has an exit, compare the first one of each
        if len(tf) and len(te):
            assert wf[0] == we[0]
            assert abs(tf[0] - te[0]) <= _exit_tolerance(scene, _exit_shift_bound(scene, f, e)), (tf[0], te[0], tf[0] - te[0])


@pytest.mark.parametrize("mode", MODES)
@given(family=st.sampled_from(FAMILIES), data=st.data())
def test_bit_identical_reruns(mode, family, data):
    # the promise of simulate.py: the result is bit-identical for the same inputs
    scene = data.draw(SCENES[family], label="scene")
    a, b = _run(scene, mode), _run(scene, mode)
    assert a.log.equals(b.log)
    assert a.episodes.equals(b.episodes)
    assert a.final == b.final or all(x == y or (x != x and y != y) for x, y in zip(a.final, b.final))


# -- bugs the draws found (kept as regression tests) ---------------------
# the draw that failed a fresh-clone CI run (stop 58): its chatter, 0.034 m/s after the first
# strike, rose 0.16 mm (0.26% of the gap) and lasted 30 ms, so the exhaustive run sticks with
# body 1 6.4e-5 m/s off the Feigin run's constrained motion and exits 5.48e-5 s earlier.
TALL_CHATTER = {
    "name": "impact-damper", "mass1": 1.0, "mass2": 0.28125, "restitution": 0.3125,
    "gap": {"lower": -0.03125, "upper": 0.03125},
    "forces": [{"kind": "spring", "on": "body1", "stiffness": 179.0, "rest": 0.0},
               {"kind": "damper", "on": "body1", "damping": 0.0},
               {"kind": "harmonic", "on": "body1", "amplitude": 4.0, "omega": 12.124798645235309, "phase": 2.5}],
    "gravity": 0.0, "initial": {"t": 1.15625, "x1": -0.048828125, "v1": 0.0, "y": -0.03125, "vy": 0.125},
    "duration": 0.5182094557626896,
}


def _first_exit_shift(scene: Scene) -> tuple[float, float, float]:
    """(|first exit, Feigin - exhaustive| [s], ``_exit_shift_bound``, ``_exit_tolerance``) of ``scene``, outside a draw."""
    f, e = (simulate(scene, mode, Options(chatter=mode, max_events=MAX_EVENTS)) for mode in MODES)
    bound = _exit_shift_bound(scene, f, e)
    return abs(_exits(f)[0][0] - _exits(e)[0][0]), bound, _exit_tolerance(scene, bound)


def test_tall_chatter_shifts_the_exit_within_its_bound():
    scene = scene_from_dict(TALL_CHATTER)
    shift, bound, tolerance = _first_exit_shift(scene)
    # the fixed 1e-4 of the period fails it; the first-order estimate from the chatter's
    # state difference is of the shift's size (5.8e-5 s against 5.5e-5 s), not a blanket allowance
    assert shift > 1e-4 * scene.time_scale
    assert 0.5 * shift < bound < 2.0 * shift
    assert shift <= tolerance


def test_catalogue_damper_exit_bound_is_small():
    # the catalogue's chatter is low: the bound stays near the measured 2.7e-6 s, far below 1e-4 T
    scene = load_scene("impact-damper")
    shift, bound, _ = _first_exit_shift(scene)
    assert shift <= bound * 2.0 + 1e-9
    assert bound < 1e-5 * scene.time_scale
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("start", [0.0, 2.0 * math.pi])
@pytest.mark.parametrize("overrides", [["initial.y=-0.1"], ["initial.y=-0.1", "restitution=0.0"],
                                       ["initial.y=-0.1", "initial.vy=-0.001", "restitution=0.0"]])
def test_resting_start_with_zero_acceleration_sticks(overrides, start, mode):
    """feigin-pair from rest on the lower wall at t = 0: y'' = -sin t is 0, then into the wall.

    The masses are in contact and pressed together from t = 0+: the run must stick at t = 0
    (rule ``contact``, or ``inelastic`` after the R = 0 strike) and stay stuck until the
    exit at t = pi, as the catalogue run's lower-wall stretches do. Before the fix: an
    endless sequence of impacts at t = 0 with v_minus = v_plus = 0 (status max_events; with
    the default guard of 5e6 events that took ~10 minutes in feigin mode). The draws above
    hit this start easily (phase 0, t 0 and a wall start are boundary values).

    At t = 2 pi, sin t = -2.4e-16: y'' is rounding away from the wall. The stick decision
    skipped that negligible term but the exit search did not, so the run stuck and exited
    at once, forever (fixed: ``stuck.negligible_lead`` is shared by both). Exit at 3 pi.
    """
    scene = load_scene("feigin-pair", [*overrides, f"initial.t={start!r}", "duration=4.0"])
    result = simulate(scene, mode, Options(chatter=mode, max_events=1000))
    assert result.status == "ok", (result.message, result.log.head(3))
    stick = result.log[result.log.kind == "stick"]
    assert len(stick) and stick.t.iloc[0] == start
    exits = result.log[result.log.kind == "exit"]
    assert len(exits) == 1 and abs(exits.t.iloc[0] - (start + math.pi)) <= 1e-9


@pytest.mark.parametrize("mode", MODES)
def test_rest_that_lets_go_flies(mode):
    """spring-pair resting on its wall at t = 0 with y'' = -5e-289 (a coupling rest of
    -1.7e-289 m) and the jerk away from the wall: y'' is rounding, so the contact lets go
    and the pair flies (first impact back at t = 3.463 s). Before the fix the stick test
    skipped the negligible y'' but the free flight's root search did not, so the flight
    struck the wall at once, forever.
    """
    scene = load_scene("spring-pair", ["forces.0.rest=-1.748488297252303e-289", "forces.0.stiffness=5.0",
                                       "forces.1.amplitude=1.0", "forces.1.omega=1.0", "forces.1.phase=0.0",
                                       "mass1=1.0", "mass2=1.0", "restitution=0.0", "initial.y=0.0", "initial.vy=0.0",
                                       "initial.x1=0.0", "initial.v1=0.0", "initial.t=0.0", f"duration={TWO_PI!r}"])
    result = simulate(scene, mode, Options(chatter=mode, max_events=1000))
    assert result.status == "ok", (result.message, result.log.head(3))
    kinds = result.log.kind.tolist()
    assert kinds[:2] == ["impact", "impact"], result.log
    assert result.log.t.iloc[0] == 0.0 and 3.0 < result.log.t.iloc[1] < 4.0


@pytest.mark.parametrize("mode", MODES)
def test_rest_without_force_stays(mode):
    """No force at all, resting on the wall: the contact stays (stick, no exit), no loop."""
    scene = load_scene("spring-pair", ["forces.1.amplitude=0", "forces.0.rest=0", "initial.y=0", "initial.vy=0"])
    result = simulate(scene, mode, Options(chatter=mode, max_events=1000))
    assert result.status == "ok", result.message
    assert result.log.kind.tolist() == ["impact", "stick"]


@pytest.mark.parametrize("mode", MODES)
def test_a_start_closer_to_the_wall_than_positions_resolve_is_on_it(mode):
    # found by hypothesis (a venv run's random examples): at rest 5e-85 m above the wall and pressed into it, the
    # flight's root lay under the resolution of t; before, no impact was seen and y went 1.5e-7 m through the wall
    scene = scene_from_dict({
        "name": "spring-pair", "mass1": 1.0, "mass2": 1.0, "restitution": 0.0, "gap": {"lower": 0.0},
        "forces": [{"kind": "spring", "on": "coupling", "stiffness": 5.0, "rest": 0.0},
                   {"kind": "harmonic", "on": "body2", "amplitude": 1.0, "omega": 8.375, "phase": 4.5625}],
        "initial": {"t": 2.453125, "x1": 0.0, "v1": 0.0, "y": 5.119600830865138e-85, "vy": 0.0},
        "duration": 0.750231081454279})
    result = simulate(scene, mode, Options(chatter=mode, max_events=MAX_EVENTS))
    assert result.status == "ok", result.message
    check_in_gap(result)
    check_exits(result)
    assert result.log["kind"].tolist()[:2] == ["impact", "stick"] and result.log["t"].iloc[1] == scene.initial.t


@pytest.mark.parametrize("mode", MODES)
def test_a_start_at_rest_just_inside_a_wall_and_pressed_into_it_strikes_it(mode):
    # found by hypothesis (a quiet suite run's random examples): at rest 6.25e-7 m inside the upper wall, y'' = 0.156
    # m/s^2 into it, y crosses it after 2.8 ms and is back inside by 25 ms, all within the root finder's first grid
    # step; the dip was not looked for because y' = 0 at the start (roots.py), no impact was seen and y went 6.4e-6 m
    # through the wall
    scene = scene_from_dict({
        "name": "impact-damper", "mass1": 1.0, "mass2": 0.25, "restitution": 0.0, "gap": {"lower": -0.03125, "upper": 0.03125},
        "forces": [{"kind": "spring", "on": "body1", "stiffness": 10.0, "rest": 0.0},
                   {"kind": "harmonic", "on": "body1", "amplitude": 6.0, "omega": 3.1622776601683795, "phase": 0.0}],
        "initial": {"t": 0.0, "x1": 0.015625, "v1": 0.0, "y": 0.031249375000000003, "vy": 0.0},
        "duration": 1.98691765315922})
    result = simulate(scene, mode, Options(chatter=mode, max_events=MAX_EVENTS))
    assert result.status == "ok", result.message
    check_in_gap(result)
    check_exits(result)
    first = result.log.iloc[0]
    assert (first["kind"], first["wall"]) == ("impact", "upper")
    # no sooner than at y'' = 0.156 m/s^2 throughout (2.83 ms): the forcing's 6 sin(w t) on body 1 lessens it as it grows
    assert math.sqrt(2 * 6.25e-7 / 0.15625) < first["t"] < 3.5e-3
