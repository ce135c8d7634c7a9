"""What the ``siconos`` engine sends its child (a JSON request) and gets back (binary frames), from a ``Scene``.

    >>> from chatterbench.engines.siconos_engine.protocol import request
    >>> from chatterbench.reference.scene import load_scene
    >>> req = request(load_scene("bouncing-ball"), dt=1e-3, steps=2000, theta=0.5, solver="lemke", tolerance=1e-12)
    >>> req["mass"], req["force"][0]["constant"], req["walls"]
    ([1.0], -9.81, [{'name': 'lower', 'row': [1.0], 'offset': 0.0}])

The child (``child.py``, run by an interpreter that has Siconos) reads one **request**, a
JSON object on its stdin, protocol 2:

==============  ==================================================================================
``protocol``    2
``mass``        the dofs' masses [kg], 1 or 2 (a diagonal mass matrix M)
``stiffness``   K, n x n [N/m];  ``damping``: C, n x n [N s/m]
``force``       per dof ``{"constant": F0 [N], "harmonics": [[A [N], omega [rad/s], phase [rad]], ...]}``:
                F(t) = F0 + sum A sin(omega t + phase); the dofs obey M q'' + C q' + K q = F(t) + contact
``q0``, ``v0``  the initial state [m, m/s]
``walls``       1 or 2 ``{"name", "row", "offset"}``: the gap g = row . q + offset [m] stays >= 0
``restitution`` Newton's R of every wall (``NewtonImpactNSL``)
``t0``, ``dt``  the start time and the step [s]; ``steps``: how many steps
``theta``       Moreau-Jean's theta in [0, 1];  ``solver``: the LCP solver (``child.SOLVERS``);
                ``tolerance``: its tolerance (Siconos's ``SICONOS_DPARAM_TOL``)
``chunk``       steps per reply frame;  ``bare``: step without replying samples (a child silent to its end)
==============  ==================================================================================

The **reply** on its stdout is a sequence of frames, little-endian: an int64 count m, then

- m = 0, first: ready, nothing more: the model is built, stepping starts (what came before is the
  child's start, which the adapter does not count as stepping);
- m > 0: m rows of float64, row j the state after the next step: q (n values), v (n values),
  and per wall the LCP's impulse over the step, ``lambda(1)`` [N s] (>= 0: the wall pushes);
- m = -1: the end, nothing more.

The parent times the frames (``wholerun.py``: the time from the ready frame to the last is the
run's stepping time); protocol 1's end frame carried the child's own clock.

Then the child exits 0. A request it refuses: one line on stderr, exit 2; a failure of
Siconos: one line on stderr, exit 1.

The scene becomes dofs two ways. A finite body 1: q = (x1, x2), M = diag(m1, m2), and K, C
and F(t) are the scene's force model as an affine map (``ForceModel.body_forces``: body 1
feels time1(t) + gain[0] . s, body 2 time2(t) + gain[1] . s, s = (x1, v1, x2, v2)); walls
y - lower = x2 - x1 - lower >= 0 and upper - y >= 0. An infinite body 1 (fixed or prescribed):
one dof q = y, body 2 seen from body 1, m2 y'' = F2 - F12 - m2 x1''(t) (Feigin 1967, (1.2)),
whose time part holds body 1's prescribed x1(t), x1'(t), x1''(t) (themselves harmonics), so
a moving floor is exact and its gap constant; walls y - lower >= 0 and upper - y >= 0.
``request`` checks its constant-plus-harmonics forces against ``body_forces`` at a few times,
so the two cannot drift apart.
"""

from __future__ import annotations

import math
import struct
from typing import BinaryIO, Iterator

import numpy as np

from chatterbench.reference.forces import ForceModel, Terms
from chatterbench.reference.scene import Scene

PROTOCOL = 2
FORCE_CHECK = 1e-9  # relative agreement of the sent F(t) with ``body_forces`` at the check times [-]


class ProtocolError(RuntimeError):
    """The child's reply is not frames of this protocol (cut short, a wrong count)."""


def _time(terms: Terms, sign: float = 1.0) -> tuple[float, list[list[float]]]:
    """A target's time part T(t) (times ``sign``) as (constant [N], harmonics)."""
    return sign * terms.constant, [[sign * a, w, p] for a, w, p in terms.harmonics]


def _sum(*parts: tuple[float, list]) -> dict:
    return {"constant": float(sum(c for c, _ in parts)), "harmonics": [h for _, hs in parts for h in hs]}


def _body1_motion(scene: Scene) -> tuple[tuple, tuple, tuple]:
    """x1(t) [m], x1'(t) [m/s] and x1''(t) [m/s^2] of an infinite body 1, each as (constant, harmonics)."""
    pr = scene.prescribed
    if pr is None:
        return (scene.initial.x1, []), (0.0, []), (0.0, [])
    a, w, ph = pr.amplitude, pr.omega, pr.phase
    return (pr.offset, [[a, w, ph]]), (0.0, [[a * w, w, ph + math.pi / 2]]), (0.0, [[-a * w * w, w, ph]])


def _scaled(part: tuple[float, list], k: float) -> tuple[float, list]:
    return k * part[0], [[k * h[0], h[1], h[2]] for h in part[1]]


def _evaluate(force: dict, t: np.ndarray) -> np.ndarray:
    out = force["constant"] + 0.0 * t
    for a, w, p in force["harmonics"]:
        out = out + a * np.sin(w * t + p)
    return out


def request(scene: Scene, *, dt: float, steps: int, theta: float, solver: str, tolerance: float, chunk: int = 4096,
            bare: bool = False) -> dict:
    """The JSON request (module docstring) for ``steps`` steps of ``dt`` [s] of ``scene``."""
    model = ForceModel.from_scene(scene)
    b1, b2, c = model.body1, model.body2, model.coupling
    gain = model.body_forces(0.0)[2].astype(float)
    # body_forces: time1 = K1 r1 + T1(t) - K12 r12 + T12(t), time2 = K2 r2 + T2(t) + K12 r12 - T12(t)
    time2 = (b2.spring_force + c.spring_force, []), _time(b2), _time(c, -1.0)
    lo, hi = scene.gap.lower, scene.gap.upper
    if scene.body1_infinite:
        x1, v1, a1 = _body1_motion(scene)
        force = [_sum(*time2, _scaled(x1, gain[1, 0] + gain[1, 2]), _scaled(v1, gain[1, 1] + gain[1, 3]),
                      _scaled(a1, -scene.mass2))]
        dofs = dict(mass=[scene.mass2], stiffness=[[float(-gain[1, 2])]], damping=[[float(-gain[1, 3])]],
                    q0=[scene.initial.y], v0=[scene.initial.vy])
        rows = {"lower": [1.0], "upper": [-1.0]}
    else:
        time1 = (b1.spring_force - c.spring_force, []), _time(b1), _time(c)
        force = [_sum(*time1), _sum(*time2)]
        ini = scene.initial
        dofs = dict(mass=[scene.mass1, scene.mass2], stiffness=(-gain[:, [0, 2]]).tolist(),
                    damping=(-gain[:, [1, 3]]).tolist(), q0=[ini.x1, ini.x1 + ini.y], v0=[ini.v1, ini.v1 + ini.vy])
        rows = {"lower": [-1.0, 1.0], "upper": [1.0, -1.0]}
    _check_forces(scene, model, force)
    walls = [{"name": w, "row": rows[w], "offset": 0.0 - lo if w == "lower" else hi} for w in scene.gap.walls]
    return dict(protocol=PROTOCOL, **dofs, force=force, walls=walls, restitution=scene.restitution,
                t0=scene.initial.t, dt=dt, steps=steps, theta=theta, solver=solver, tolerance=tolerance, chunk=chunk,
                bare=bare)


def _check_forces(scene: Scene, model: ForceModel, force: list[dict]) -> None:
    """The sent time parts agree with ``body_forces`` (and the prescribed motion) at a few times."""
    t = scene.initial.t + scene.duration * np.array([0.0, 0.137, 0.5, 0.911])
    time1, time2, gain = model.body_forces(t)
    if scene.body1_infinite:
        x1, v1 = (np.full(len(t), scene.initial.x1), np.zeros(len(t))) if scene.prescribed is None else \
            (scene.prescribed.position(t), scene.prescribed.velocity(t))
        a1 = np.zeros(len(t)) if scene.prescribed is None else scene.prescribed.acceleration(t)
        want = [time2 + (gain[1, 0] + gain[1, 2]) * x1 + (gain[1, 1] + gain[1, 3]) * v1 - scene.mass2 * a1]
    else:
        want = [time1 + 0.0 * t, time2 + 0.0 * t]
    for f, w in zip(force, want):
        got = _evaluate(f, t)
        if not np.allclose(got, w, rtol=FORCE_CHECK, atol=FORCE_CHECK * (1.0 + np.abs(w).max())):
            raise ValueError(f"siconos request: the forces sent ({got}) are not the scene's ({w})")


def read_frames(stream: BinaryIO, width: int) -> Iterator[np.ndarray]:
    """The reply's frames in order: arrays of shape (m, ``width``), the ready frame an empty one (m = 0); returns at
    the end frame. ProtocolError for a reply that ends before it or is not frames."""
    while True:
        head = stream.read(8)
        if len(head) < 8:
            raise ProtocolError(f"the reply ended without its end frame ({len(head)} bytes of a frame header)")
        (m,) = struct.unpack("<q", head)
        if m == -1:
            return
        if m == 0:
            yield np.empty((0, width))
            continue
        if m < 1 or m > 1 << 40:
            raise ProtocolError(f"a frame of {m} rows")
        body = stream.read(8 * m * width)
        if len(body) < 8 * m * width:
            raise ProtocolError(f"a frame of {m} rows is cut short ({len(body)} of {8 * m * width} bytes)")
        yield np.frombuffer(body, dtype="<f8").reshape(m, width).astype(float)
