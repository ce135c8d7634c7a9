"""Impact phases: the same motion started later by a fraction of a step, so its impacts fall elsewhere within a step.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> from chatterbench.comparisons.studies.phases import phase_solution
    >>> ref = solve(load_scene("bouncing-ball"))
    >>> moved = phase_solution(ref, dt=1e-3, phase=0.5)
    >>> moved.scene.initial.t, round(moved.scene.initial.y, 9), moved.scene.t_end    # 0.5 ms later, 1.2 um lower
    (0.0005, 0.999998774, 2.0)
    >>> round(float(moved.episodes["t_stick"].iloc[0] - ref.episodes["t_stick"].iloc[0]), 12)   # the same motion
    0.0

An engine steps from the scene's start, t0 + k dt, so where an impact falls within a step is
fixed by the start: a setting can pass with the first impact 0.1 step after a sample and fail
with it 0.6 step after (issue 41: PyBullet's 0.00606 s is ``match``, 0.006063 s ``late``). To
check a setting at other places in a step, the scene is started ``phase`` x dt later on its
own exact trajectory: the initial state becomes the reference's at t0 + phase dt
(``ReferenceSolution.motion``, exact: the closed-form flow from the last event), the end
time stays, and everything the samples meet afterwards is the same motion on a grid moved by
``phase`` of a step. ``phase`` in [0, 1); 0 is the scene itself. The moved scene gets its own
reference solution (exact, and cheap: 16-29 ms for a built-in scene), so the judge compares
like with like even where the move passes an event.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from chatterbench.reference.errors import check_number
from chatterbench.reference.scene import Scene, SceneError
from chatterbench.reference.scene_parts import Initial

from ..pipeline.solution import ReferenceSolution, solve

PHASES = (0.0, 0.25, 0.5, 0.75)  # [step] the places in a step a band-robust setting is checked at (4: the least)


def phase_scene(ref: ReferenceSolution, dt: float, phase: float) -> Scene:
    """``ref.scene`` started ``phase`` x ``dt`` [s] later on its own exact trajectory (module docstring)."""
    phase = check_number("phase", phase, lo=0.0, hi=1.0, hi_open=True, error=SceneError)
    scene = ref.scene
    if phase == 0.0:
        return scene
    shift = phase * check_number("dt", dt, lo=0.0, lo_open=True, unit=" [s]", error=SceneError)
    if not shift < scene.duration:
        raise SceneError(f"phase {phase:g} of dt = {dt:g} s: moves the start past the scene's end")
    t = scene.initial.t + shift
    states, _ = ref.motion.states(np.array([t]))
    x1, v1, y, vy = (float(v) for v in states[0])
    if scene.body1_infinite:
        x1, v1 = scene.body1_motion(t)  # exactly what the scene's check of a fixed or prescribed body 1 asks
    upper = scene.gap.upper if scene.gap.upper is not None else math.inf
    y = min(max(y, scene.gap.lower), upper)  # a rounding past a wall the motion rests on
    return dataclasses.replace(scene, initial=Initial(t=t, x1=x1, v1=v1, y=y, vy=vy), duration=scene.t_end - t)


@functools.lru_cache(maxsize=256)
def _solved(scene: Scene) -> ReferenceSolution:
    return solve(scene)


def phase_solution(ref: ReferenceSolution, dt: float, phase: float) -> ReferenceSolution:
    """The reference of ``phase_scene`` (``ref`` itself at phase 0); kept per moved scene in this process."""
    return ref if phase == 0.0 else _solved(phase_scene(ref, dt, phase))
