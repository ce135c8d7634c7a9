"""One run's samples as the base hands them over: checked against the run's grid, cut at a blow-up, body 1 filled.

    >>> import numpy as np
    >>> from chatterbench.engines.pybullet_engine import PybulletSettings
    >>> from chatterbench.engines.recording import Recording
    >>> from chatterbench.reference.scene import load_scene
    >>> run = Recording("x", load_scene("bouncing-ball", ["duration=0.002"]), PybulletSettings(dt=1e-3), {}, None,
    ...                 (0.0, np.inf))
    >>> run.add(np.array([0.0, 1e-3, 2e-3]), {"lower": np.zeros(3)}, y=np.array([1.0, np.nan, 0.9]), vy=np.zeros(3))
    False
    >>> run.trajectory().status, run.trajectory().message
    ('diverged', 'non-finite or huge state at t = 0.001 s (sample 1)')

``Recording`` is where every engine's samples go, from the base's step loop
(``stepping.py``), from a whole-run engine's generator (``wholerun.py``) or from a batch's
block (``batch_recording.py``): ``add`` checks each chunk against the run's time grid
t0 + k dt (``GRID_SLACK``), cuts the run at the first non-finite or huge sample (``MAXVAL``),
fills in body 1 of infinite mass, and records through ``window.Recorder`` (a long run kept
compact); ``trajectory`` classifies the run (``status.Status``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping

import numpy as np

from chatterbench.reference.scene import Scene

from .status import Crashed, Diverged, Status, TimedOut, failed_trajectory
from .stepping import n_steps
from .trajectory import Trajectory
from .window import Recorder

MAXVAL = 1e10  # [m, m/s] a larger |position| or |velocity| is a blow-up (MuJoCo's mjMAXVAL, for every engine)
GRID_SLACK = 1e-3  # [steps] how far a sample's time may be from t0 + k dt (rounding, an accumulated t += dt)


class Recording:
    """One run's samples as the base hands them over: checked, cut at a blow-up, body 1 filled, recorded.

    ``record`` (the settings record; an adapter may add what its run learns), ``wall_time``
    [s] (the base adds the stepping time it measured), ``contact_time`` [s] and ``contact_frequency``
    [rad/s] (defaults from ``EngineAdapter.contact_scales``; an adapter whose run calibrates its
    contact may set them) go into the trajectory. A whole-run adapter's ``samples(run)`` reads
    ``scene``, ``settings``, ``n`` (the run's steps) and ``stopped``.
    """

    def __init__(self, engine: str, scene: Scene, settings: Any, record: dict[str, Any], compact_above: float | None,
                 scales: tuple[float, float]) -> None:
        self.engine, self.scene, self.settings, self.record = engine, scene, settings, record
        self.n = n_steps(scene.duration, settings.dt)  # steps; the run has n + 1 samples
        self.wall_time = 0.0
        self.contact_time, self.contact_frequency = scales
        self.cut = ""  # why the samples were cut ("": not cut)
        self.recorder = Recorder(scene, self.n + 1, compact_above)  # MemoryError for a run that cannot fit

    @property
    def stopped(self) -> bool:
        """Whether a blow-up ended the run (the adapter stops stepping)."""
        return bool(self.cut)

    def add(self, t: np.ndarray, force: Mapping[str, np.ndarray], *, y: np.ndarray | None = None,
            vy: np.ndarray | None = None, x2: np.ndarray | None = None, v2: np.ndarray | None = None,
            x1: np.ndarray | None = None, v1: np.ndarray | None = None, bad: np.ndarray | None = None) -> bool:
        """The next samples, in order: times ``t`` [s], per wall the force on body 2 [N] (contact where > 0),
        body 2 as ``x2, v2`` or relative to body 1 as ``y, vy`` (then x2 = x1 + y), body 1 as ``x1, v1``
        (None for an infinite body 1: its prescribed motion, or rest at x1), ``bad``: samples the engine
        knows to be broken. Cuts at the first bad, non-finite or huge sample; returns whether to go on.
        ValueError for samples off the run's time grid t0 + k dt, k = 0..n (out of order, or too many)."""
        if self.cut:
            return False
        self._check_times(np.asarray(t, dtype=float))
        state = [a for a in (x1, v1, y, vy, x2, v2) if a is not None]
        broken = ~np.logical_and.reduce([np.isfinite(a) for a in (*state, *force.values())])
        broken |= np.logical_or.reduce([np.abs(a) > MAXVAL for a in state])
        if bad is not None:
            broken |= bad
        m = len(t)
        if broken.any():
            m = int(np.argmax(broken))
            self.cut = f"non-finite or huge state at t = {t[m]:.6g} s (sample {self.recorder.count + m})"
            t, force = t[:m], {w: f[:m] for w, f in force.items()}
            x1, v1, y, vy, x2, v2 = (None if a is None else a[:m] for a in (x1, v1, y, vy, x2, v2))
        if x1 is None:
            x1, v1 = self.body1(t)
        if x2 is None:
            x2, v2 = x1 + y, v1 + vy
        self.recorder.add(t, x1, v1, x2, v2, {w: f > 0.0 for w, f in force.items()}, force)
        return not self.cut

    def _check_times(self, t: np.ndarray) -> None:
        """The samples handed over are the next ones of the run's grid, to ``GRID_SLACK`` of a step."""
        k, dt = self.recorder.count, self.settings.dt
        grid = self.scene.initial.t + dt * np.arange(k, k + len(t))
        off = ~(np.abs(t - grid) <= GRID_SLACK * dt)
        if off.any() or k + len(t) > self.n + 1:
            i = int(np.argmax(off)) if off.any() else self.n + 1 - k
            shown = f"t = {t[i]:.9g} s, not t0 + k dt = {grid[i]:.9g} s" if off.any() else "past the run's end"
            raise ValueError(f"sample {k + i}: {shown} (the samples are t0 + k dt, k = 0..{self.n}, in order)")

    def body1(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position [m] and velocity [m/s] of an infinite body 1 at times ``t``: prescribed, or at rest."""
        scene = self.scene
        if not scene.body1_infinite:
            raise ValueError("body 1 has a finite mass: the engine reports its motion")
        if scene.prescribed is not None:
            return scene.prescribed.position(t), scene.prescribed.velocity(t)
        return np.full(len(t), scene.initial.x1), np.zeros(len(t))

    def trajectory(self, failure: BaseException | None = None) -> Trajectory:
        """The recorded samples with their status (module docstring: how a run is classified)."""
        status, message = Status.OK, ""
        if failure is not None:
            status = (Status.DIVERGED if isinstance(failure, Diverged) else Status.CRASHED if isinstance(failure, Crashed)
                      else Status.TIMEOUT if isinstance(failure, TimedOut) else Status.ERROR)
            message = f"{self.engine}: {type(failure).__name__}: {failure}".splitlines()[0]
        if self.cut:
            status, message = Status.DIVERGED, "; ".join(filter(None, (self.cut, message)))
        elif status is Status.OK and self.recorder.count < self.n + 1:
            status, message = Status.ERROR, f"{self.engine} stopped at sample {self.recorder.count} of {self.n + 1}"
        fields = dict(settings=self.record, status=status, message=message, contact_time=self.contact_time,
                      contact_frequency=self.contact_frequency, step=self.settings.dt)  # dt carried, not re-derived
        if not self.recorder.count:  # failed before its first sample: the initial state stands for it
            return dataclasses.replace(failed_trajectory(self.engine, self.scene, status, message), **fields,
                                       wall_time=self.wall_time)
        return self.recorder.trajectory(self.engine, self.wall_time, **fields)
