"""The run every stepping engine shares: the scene's forces applied each step, the samples recorded, the bare loop.

    >>> import numpy as np
    >>> from chatterbench.engines.stepping import force_plan
    >>> from chatterbench.reference.scene import load_scene
    >>> time1, time2, gain = force_plan(load_scene("spring-pair"), np.array([0.0, 0.1]))
    >>> time2.round(3), gain[1].tolist()        # body 2: the harmonic push and the preload; the coupling spring's gain
    (array([-2.5  , -1.022]), [50.0, 0.0, -50.0, 0.0])

``run_steps(adapter, run)`` is ``EngineAdapter.simulate`` for an adapter that writes ``build``
and ``step`` (``base.py``): it builds the world, then for each step k of ``run.n``

1. moves a prescribed body 1 (``adapter.drive(world, x1(t_k), v1(t_k), x1(t_k+1))``);
2. evaluates the scene's forces at the step's start, t_k and the state there (``force_plan``:
   time part + gain . (x1, v1, x2, v2), Feigin 1967 (1.1)), as the force on body 1 and on body 2;
3. calls ``adapter.step(world, (f1, f2))`` and keeps the state and wall forces it returns;

and hands the samples to ``run.add`` every ``window.CHUNK`` steps (the initial state first),
adding the steps' wall time to ``run.wall_time``. The force plan is made per chunk, the state
is checked for a blow-up every ``FINITE_CHECK_EVERY`` steps (the recording cuts at the first
bad sample), an exception of ``step`` ends the run once the samples before it are recorded,
and a world with a ``close()`` is closed. ``bare_seconds`` steps a fresh world with the forces
a recorded run applied (replayed from its states, bit for bit) and records nothing: the
benchmark's bare loop.

Promises: sample k is the state after k steps; the forces are evaluated in one order for every
engine (``force_sum``), so that two engines given one scene apply the same numbers.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from chatterbench.reference.forces import ForceModel
from chatterbench.reference.scene import Scene

from .window import CHUNK

FINITE_CHECK_EVERY = 1024  # [steps] how often the loop checks the state is finite (a power of 2: a mask test)
_ROUNDING = 1e-12  # [-] relative slack of duration / dt, so that 2.0 / 1e-4 gives 20000 steps


def n_steps(duration: float, dt: float) -> int:
    """Steps of ``dt`` [s] covering ``duration`` [s]: the largest n with n dt <= duration (to rounding), >= 1
    (every engine's run, ``base.n_steps``)."""
    return max(1, int(math.floor(duration / dt * (1.0 + _ROUNDING))))


def force_plan(scene: Scene, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The scene's forces at the step starts ``t`` [s] as the affine map an engine loop applies each step
    (``ForceModel.body_forces``): the time parts on body 1 and body 2 [N] (shape of ``t``) and the (2 x 4) gain
    on (x1, v1, x2, v2); none on an infinite body 1 (its prescription, or rest, moves it)."""
    time1, time2, gain = ForceModel.from_scene(scene).body_forces(t)
    time1 = np.broadcast_to(time1, t.shape).astype(float)
    time2 = np.broadcast_to(time2, t.shape).astype(float)
    if scene.body1_infinite:
        time1[:] = 0.0
        gain[0, :] = 0.0
    return time1, time2, gain


def forces_on(scene: Scene, dt: float) -> tuple[bool, bool]:
    """Whether body 1 and body 2 ever feel a scene force over the run at ``dt`` [s] (planned chunk by chunk): an
    adapter may skip applying a force that is always zero."""
    n = n_steps(scene.duration, dt)
    on1 = on2 = False
    for k0 in range(0, n, CHUNK):
        time1, time2, gain = force_plan(scene, scene.initial.t + dt * np.arange(k0, min(n, k0 + CHUNK)))
        on1 = on1 or bool(np.any(time1 != 0.0) or np.any(gain[0] != 0.0))
        on2 = on2 or bool(np.any(time2 != 0.0) or np.any(gain[1] != 0.0))
    return on1, on2


def replayed_forces(scene: Scene, t: np.ndarray, states: tuple[np.ndarray, ...],
                    force_sum: str = "grouped") -> tuple[np.ndarray, np.ndarray]:
    """The forces [N] on body 1 and body 2 at the times ``t`` and states (x1, v1, x2, v2), summed as ``run_steps``
    sums them (``force_sum``): a bare loop replays a run's forces bit for bit."""
    time1, time2, g = force_plan(scene, t)
    s = states
    if force_sum == "in order":
        return tuple(part + g[i, 0] * s[0] + g[i, 1] * s[1] + g[i, 2] * s[2] + g[i, 3] * s[3]
                     for i, part in enumerate((time1, time2)))
    if not np.any(g != 0.0):
        return time1, time2
    return tuple(part + (g[i, 0] * s[0] + g[i, 1] * s[1] + g[i, 2] * s[2] + g[i, 3] * s[3])
                 for i, part in enumerate((time1, time2)))


class _Chunk:
    """One chunk's samples as the loop fills them: position 0 is the chunk's first sample (the state it starts
    from), position j + 1 the state after its step j; wall forces only where a wall pushed."""

    def __init__(self, c: int, state: tuple[float, float, float, float]) -> None:
        x1, v1, x2, v2 = state
        self.x1, self.v1, self.x2, self.v2 = [x1] * (c + 1), [v1] * (c + 1), [x2] * (c + 1), [v2] * (c + 1)
        self.pushed: list[tuple[int, tuple[float, ...]]] = []
        self.last = c  # the last position with a sample
        self.failure: Exception | None = None

    def hand_over(self, run: Any, times: np.ndarray, first: int) -> bool:
        """Positions ``first`` .. ``last`` to ``run.add`` (body 1's where the adapter reported it); whether to go on."""
        stop = self.last + 1
        body1 = not run.scene.body1_infinite or (self.last > 0 and self.x1[self.last] is not None)
        force = {w: np.zeros(stop - first) for w in run.scene.gap.walls}
        walls = tuple(force)
        for j, pushed in self.pushed:
            if first <= j < stop:
                for wall, f in zip(walls, pushed):
                    force[wall][j - first] = f
        cols = {"x2": np.array(self.x2[first:stop]), "v2": np.array(self.v2[first:stop])}
        if body1:
            cols.update(x1=np.array(self.x1[first:stop]), v1=np.array(self.v1[first:stop]))
        return run.add(times[first:stop], force, **cols)


def run_steps(adapter: Any, run: Any) -> None:
    """Build ``adapter``'s world for ``run`` and step it ``run.n`` times (module docstring); raises what ``step``
    raised once the samples before it are recorded."""
    world = adapter.build(run.scene, run.settings)
    try:
        _steps(adapter, world, run)
    finally:
        close = getattr(world, "close", None)
        if close is not None:
            close()


def _steps(adapter: Any, world: Any, run: Any) -> None:
    scene, dt, n = run.scene, run.settings.dt, run.n
    ini = scene.initial
    state = (float(ini.x1), float(ini.v1), float(ini.x1) + ini.y, float(ini.v1) + ini.vy)
    for k0 in range(0, n, CHUNK):
        c = min(n, k0 + CHUNK) - k0
        times = ini.t + dt * np.arange(k0, k0 + c + 1)  # = base.sample_times(scene, dt)[k0:k0 + c + 1]
        chunk = _Chunk(c, state)
        start = time.perf_counter()
        state = _chunk(adapter, world, scene, times, chunk, state)
        run.wall_time += time.perf_counter() - start
        go_on = chunk.hand_over(run, times, 0 if k0 == 0 else 1)
        if chunk.failure is not None:
            raise chunk.failure
        if not go_on or chunk.last < c:
            return


def _chunk(adapter: Any, world: Any, scene: Scene, times: np.ndarray, out: _Chunk,
           state: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """Steps of one chunk into ``out`` from ``state``; the state after its last step. The loop is the cost the
    benchmark measures, so it keeps Python work per step small: the time parts as lists, eight gains as floats."""
    time1, time2, gain = force_plan(scene, times[:-1])
    time1, time2 = time1.tolist(), time2.tolist()
    g10, g11, g12, g13, g20, g21, g22, g23 = (float(v) for v in gain.ravel())
    grouped, in_order = adapter.force_sum == "grouped" and bool(np.any(gain != 0.0)), adapter.force_sum == "in order"
    finite1 = not scene.body1_infinite
    prescribed = scene.prescribed if scene.body1_infinite else None
    if prescribed is not None:
        px, pv = prescribed.position(times).tolist(), prescribed.velocity(times).tolist()
    step, drive, isfinite, mask = adapter.step, adapter.drive, math.isfinite, FINITE_CHECK_EVERY - 1
    x1s, v1s, x2s, v2s, pushes = out.x1, out.v1, out.x2, out.v2, out.pushed
    x1, v1, x2, v2 = state
    j = 0
    try:
        for j in range(len(time1)):
            if prescribed is not None:
                x1, v1 = px[j], pv[j]
                drive(world, x1, v1, px[j + 1])
            if grouped:
                f1 = time1[j] + (g10 * x1 + g11 * v1 + g12 * x2 + g13 * v2)
                f2 = time2[j] + (g20 * x1 + g21 * v1 + g22 * x2 + g23 * v2)
            elif in_order:
                f1 = time1[j] + g10 * x1 + g11 * v1 + g12 * x2 + g13 * v2
                f2 = time2[j] + g20 * x1 + g21 * v1 + g22 * x2 + g23 * v2
            else:
                f1, f2 = time1[j], time2[j]
            (y1, w1, x2, v2), pushed = step(world, (f1, f2))
            x1s[j + 1], v1s[j + 1] = y1, w1  # None for an infinite body 1 the adapter leaves to the base
            if finite1:
                x1, v1 = y1, w1
            x2s[j + 1], v2s[j + 1] = x2, v2
            if pushed:
                pushes.append((j + 1, pushed))
            if not j & mask and not isfinite(x1 + v1 + x2 + v2):
                out.last = j + 1
                break
    except Exception as exc:  # noqa: BLE001  the engine's failure: the samples before it are recorded first
        out.failure, out.last = exc, j
    return x1, v1, x2, v2


def bare_seconds(adapter: Any, scene: Scene, settings: Any, traj: Any) -> float:
    """Seconds of ``adapter``'s steps over the run ``traj`` of ``scene`` (full), on a fresh world, with the forces
    the run applied (replayed from its states, summed as it summed them) and nothing recorded."""
    world = adapter.build(scene, settings)
    try:
        n = len(traj.t) - 1
        f1, f2 = (f.tolist() for f in replayed_forces(scene, traj.t, (traj.x1, traj.v1, traj.x2, traj.v2),
                                                      adapter.force_sum))
        step, drive = adapter.step, adapter.drive
        if scene.body1_infinite and scene.prescribed is not None:
            px, pv = scene.prescribed.position(traj.t).tolist(), scene.prescribed.velocity(traj.t).tolist()
            start = time.perf_counter()
            for k in range(n):
                drive(world, px[k], pv[k], px[k + 1])
                step(world, (f1[k], f2[k]))
        else:
            start = time.perf_counter()
            for k in range(n):
                step(world, (f1[k], f2[k]))
        return time.perf_counter() - start
    finally:
        close = getattr(world, "close", None)
        if close is not None:
            close()
