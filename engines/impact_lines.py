"""The impact printer of the exported scripts: Python lines that record the run's samples and print its impacts as the judge finds them.

    >>> from chatterbench.engines.impact_lines import record_lines, report_lines, setup_lines
    >>> code = "\\n".join([*setup_lines({"lower": 0.0}, 0.5, 0.0, 0.0, 1e-3, 900), "for k in range(STEPS + 1):",
    ...                    "    t = T0 + k * DT; v1 = (2 * 9.81) ** 0.5; t1 = v1 / 9.81",   # a ball that bounces with R
    ...                    "    y = 1 - 9.81 * t * t / 2 if t < t1 else 0.5 * v1 * (t - t1) - 9.81 * (t - t1) ** 2 / 2",
    ...                    "    vy = -9.81 * t if t < t1 else 0.5 * v1 - 9.81 * (t - t1)", "    a = -9.81; x1 = 0.0",
    ...                    *record_lines("    "), '    forces["lower"].append(0.0)', *report_lines()])
    >>> exec(code, {})
    # impact: every impact of chatterbench's judge ...
    impact t=0.451524 v_in=-4.42945 v_out=2.21472 e=0.5
    # rest: after each stick ...

Every exported script (``mujoco_engine.export``, ``pybullet_engine.export``) steps its engine
and records each sample k (``record_lines``: the gap y = x2 - x1 [m], y' [m/s] and y'' of the
free motion ``a`` [m/s^2], and each wall's normal force on body 2 in ``forces``), at times
T0 + k DT as chatterbench's adapters sample them. Once the run is over (``report_lines``) it
prints the impacts of the judge's event log (``sampled_impacts.judged_impacts``, whose
source the script carries: it needs neither numpy nor chatterbench), one line each,
``impact t=... v_in=... v_out=... e=...``: t [s] the impact, v_in and v_out the relative
velocity y' = x2' - x1' where body 2 crosses the wall's surface on its way in and out [m/s],
e = -v_out / v_in; ``HEADER`` first. So the script's impact count is the run's (``chatterbench
run`` counts the log's impacts) and each e is the judge's. The judge's sticking tolerance
decides which late bounces are a rest (``sampled_impacts``: the flight band): ``judged_by``
hands it to the exporters, which write it into the script; without it, the sampling floor.

After the impacts, ``REST_HEADER`` and one line per rest window ``judged_by`` names (the
reference's stick plus the sticking tolerance to its exit less the exit tolerance), ``rest
wall=... t0=... t1=... onsets=... onsets_per_s=... open=... gap_max=...``: whether the contact
stays closed after the stick (``sampled_impacts.contact_rest``: a contact where the wall's force
is > 0), what the judge's persistence check measures (issue 41: a contact that opens every two
steps after the stick is ``buzz``). Run with a path, ``python THIS_FILE run.csv``, a script also
writes its samples as the CSV ``chatterbench judge`` reads (t, x1, x2, v1, v2, force_WALL).
"""

from __future__ import annotations

import ast
import contextlib
import contextvars
import inspect
import math

from chatterbench.reference.forces import ForceModel
from chatterbench.reference.scene import Scene

from . import sampled_impacts

HEADER = ("# impact: every impact of chatterbench's judge (its event log): each contact's onset and each velocity jump "
          "between two free samples near a wall; v_in and v_out where body 2 crosses the wall's surface (the free flight "
          "of the last free samples before it and the first after, carried to the surface), e = -v_out / v_in; bounces "
          "inside a stuck stretch (flights shorter than f_min = {f_min:.6g} s after a slow impact, until the bodies "
          "separate) are a rest, not impacts")
REST_HEADER = ("# rest: after each stick (the reference's, plus the sticking tolerance, to its exit less the exit tolerance), "
               "the wall's contact: onsets (a contact starting), onsets per second, open (the share of the time the "
               "contact is open) and gap_max [m]; a contact at rest has none, 0 and 0")
_FLIGHT_BAND: contextvars.ContextVar[float] = contextvars.ContextVar("flight_band", default=0.0)
_REST: contextvars.ContextVar[tuple] = contextvars.ContextVar("rest_windows", default=())


@contextlib.contextmanager
def judged_by(flight_band: float | None, rest: tuple = ()):
    """Within the block, exported scripts take ``flight_band`` [s] (the judge's band x sticking tolerance x (1 - R),
    ``sampled_impacts``) as what decides a rest (None or NaN: 0, the sampling floor alone), and report the contact
    over each ``rest`` window (t0 [s], t1 [s], wall): the reference's stick plus the sticking tolerance to its exit
    less the exit tolerance (``comparisons/pipeline/persistence.reference_rest_windows``)."""
    value = 0.0 if flight_band is None or not math.isfinite(flight_band) else max(float(flight_band), 0.0)
    token = _FLIGHT_BAND.set(value)
    windows = _REST.set(tuple((float(t0), float(t1), str(w)) for t0, t1, w in rest))
    try:
        yield
    finally:
        _FLIGHT_BAND.reset(token)
        _REST.reset(windows)


def rest_windows() -> tuple:
    """The rest windows the exporters write now (``judged_by``; none outside it)."""
    return _REST.get()


def flight_band() -> float:
    """The flight band [s] the exporters write now (``judged_by``; 0 outside it)."""
    return _FLIGHT_BAND.get()


def docstring(lines: list[str]) -> list[str]:
    """A script's docstring from ``lines``, safe for any text in them (a scene name may hold quotes, backslashes)."""
    text = "\n".join(lines).replace("\\", "\\\\").replace('"""', '\\"\\"\\"')
    return ['"""' + text, '"""']


def functions_source() -> str:
    """``sampled_impacts`` as script text: its code without the module docstring (which imports chatterbench)."""
    source = inspect.getsource(sampled_impacts)
    body = ast.parse(source).body
    first = body[1] if isinstance(body[0], ast.Expr) else body[0]  # the statement after the docstring
    return "\n".join(source.splitlines()[first.lineno - 1:]).rstrip() + "\n"


def _num(v: float) -> str:
    return repr(float(v))


def _time_part(constant: float, harmonics) -> str:
    """constant + sum A sin(w t + phase) as a Python expression in ``t``."""
    return _num(constant) + "".join(f" + {_num(a)} * math.sin({_num(w)} * t + {_num(ph)})"
                                    for a, w, ph in harmonics if a != 0.0)


def force_lines(scene: Scene, indent: str) -> list[str]:
    """``f1`` (a finite body 1) and ``f2`` [N], the forces on the bodies at time ``t`` and state ``x1, v1, x2, v2``,
    as the scene's force model gives them (``ForceModel.body_forces``: F1 + F12 and F2 - F12)."""
    f = ForceModel.from_scene(scene)
    b1, b2, c = f.body1, f.body2, f.coupling
    neg = [(-a, w, ph) for a, w, ph in c.harmonics]
    time1 = _time_part(b1.spring_force + b1.constant - c.spring_force + c.constant, [*b1.harmonics, *c.harmonics])
    time2 = _time_part(b2.spring_force + b2.constant + c.spring_force - c.constant, [*b2.harmonics, *neg])
    _, _, gain = f.body_forces(0.0)

    def affine(row: int, time: str) -> str:
        return time + "".join(f" + {_num(g)} * {s}" for g, s in zip(gain[row], ("x1", "v1", "x2", "v2")) if g != 0.0)

    lines = [] if scene.body1_infinite else [f"{indent}f1 = {affine(0, time1)}"]
    return lines + [f"{indent}f2 = {affine(1, time2)}"]


def acceleration_line(scene: Scene, indent: str) -> str:
    """``a``: y'' of the free motion [m/s^2] from ``f1``, ``f2`` (Feigin (1.2)), or with body 1's prescribed x1''(t)."""
    if not scene.body1_infinite:
        return f"{indent}a = f2 / {_num(scene.mass2)} - f1 / {_num(scene.mass1)}"
    p = scene.prescribed
    if p is None:
        return f"{indent}a = f2 / {_num(scene.mass2)}"
    return (f"{indent}a = f2 / {_num(scene.mass2)} + {_num(p.amplitude * p.omega**2)} * math.sin({_num(p.omega)} * t + "
            f"{_num(p.phase)})  # body 1's prescribed x1'' subtracted")


def setup_lines(walls: dict[str, float], restitution: float, flight_band: float, t0: float, dt: float,
                steps: int) -> list[str]:
    """The judge's functions and the recording's state, before the loop: ``walls`` name -> position in y [m]."""
    return [functions_source(),
            "",
            f"T0, DT, STEPS = {_num(t0)}, {_num(dt)}, {int(steps)}  # samples at T0 + k DT, k = 0 .. STEPS",
            f"WALLS = {dict((w, float(y)) for w, y in walls.items())!r}  # the walls' positions in y = x2 - x1 [m]",
            f"R = {_num(restitution)}  # Newton's restitution of the scene",
            f"FLIGHT_BAND = {_num(flight_band)}  # [s] the judge's band x sticking tolerance x (1 - R): shorter "
            "flights do not matter",
            f"REST = {list(rest_windows())!r}  # (t0, t1, wall): after each stick the contact should stay closed",
            "ys, vys, accs = [], [], []  # per sample: y [m], y' [m/s], y'' of the free motion [m/s^2]",
            "x1s, v1s = [], []  # per sample: body 1's x [m] and x' [m/s]",
            "forces = {wall: [] for wall in WALLS}  # per sample: each wall's normal force on body 2 [N]"]


def loop_start_lines(scene: Scene) -> list[str]:
    """The state at the start (``x1, v1, x2, v2`` [m, m/s]), sample 0's wall forces (none) and the head of the loop
    over the samples: ``t`` and the sample's ``y``, ``vy`` as the adapters record it; the step follows in the loop."""
    ini = scene.initial
    return [f"x1, v1 = {_num(ini.x1)}, {_num(ini.v1)}",
            f"x2, v2 = {_num(ini.x1 + ini.y)}, {_num(ini.v1 + ini.vy)}",
            "for wall in WALLS:  # sample 0: no step has ended there, no wall has pushed",
            "    forces[wall].append(0.0)",
            "for k in range(STEPS + 1):  # sample k, then the step from it",
            "    t = T0 + k * DT",
            "    y, vy = x2 - x1, v2 - v1  # the sample as the adapter records it"]


def record_lines(indent: str) -> list[str]:
    """Record sample k: ``y``, ``vy`` and ``a`` (the script appends each wall's force itself)."""
    return [f"{indent}ys.append(y)", f"{indent}vys.append(vy)", f"{indent}accs.append(a)", f"{indent}x1s.append(x1)",
            f"{indent}v1s.append(v1)"]


def report_lines() -> list[str]:
    """After the loop: the judge's impacts of the recorded run, one line each, after ``HEADER``."""
    return [
        "t = [T0 + k * DT for k in range(len(ys))]",
        f"print({HEADER!r}.format(f_min=max(FLOOR_STEPS * DT, FLIGHT_BAND)))",
        "for t_i, wall, v_in, v_out in judged_impacts(t, ys, vys, accs, forces, WALLS, R, FLIGHT_BAND):",
        "    e = -v_out / v_in if v_in != 0.0 else math.nan",
        '    print(f"impact t={t_i:.6f} v_in={v_in:.6g} v_out={v_out:.6g} e={e:.6g}")',
        f"print({REST_HEADER!r})",
        "for t0, t1, wall in REST:",
        "    nrm = 1.0 if wall == 'lower' else -1.0",
        "    d = [nrm * (v - WALLS[wall]) for v in ys]",
        "    t1 = min(t1, t[-1])",
        "    n, share, gap = contact_rest(t, d, forces[wall], t0, t1)",
        "    rate = n / (t1 - t0) if t1 > t0 else math.nan",
        '    print(f"rest wall={wall} t0={t0:.6f} t1={t1:.6f} onsets={n} onsets_per_s={rate:.4g} open={share:.4g} '
        'gap_max={gap:.4g}")',
        "import sys",
        "if __name__ == '__main__' and len(sys.argv) > 1:  # python THIS_FILE run.csv: the samples as chatterbench judge reads them",
        "    with open(sys.argv[1], 'w') as out:",
        "        out.write(','.join(['t', 'x1', 'x2', 'v1', 'v2', *('force_' + w for w in WALLS)]) + '\\n')",
        "        for k in range(len(ys)):",
        "            row = [t[k], x1s[k], x1s[k] + ys[k], v1s[k], v1s[k] + vys[k], *(forces[w][k] for w in WALLS)]",
        "            out.write(','.join(repr(float(v)) for v in row) + '\\n')",
    ]
