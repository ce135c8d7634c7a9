"""dt carried with the run (issue 43): the settings' dt is the trajectory's step and the compare table's dt, never
re-derived from the sample times; samples from elsewhere take their median spacing once.

Before: ``Trajectory.dt`` was ``t[1] - t[0]`` and ``sampling_step()`` the median of ``diff(t)``, two derivations that
differ from the dt asked for in the last bits (t = t0 + k dt rounded), and from each other. Now one name, ``dt``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from chatterbench.comparisons import compare
from chatterbench.comparisons.pipeline.sampling import reference_trajectory
from chatterbench.engines.registry import make_settings, run_engine, settings_for
from chatterbench.engines.window import compact
from chatterbench.reference.scene import load_scene

BALL = load_scene("bouncing-ball", ["duration=0.7"])
DT = 3e-4  # not a power of two: t = k dt is rounded, so a spacing read off the samples is not dt


def test_an_engine_runs_trajectory_carries_the_dt_it_was_run_at():
    traj = run_engine("pybullet", BALL, make_settings("pybullet", dt=DT))
    assert traj.step == DT and traj.dt == DT
    spacings = np.diff(traj.t)
    assert (spacings != DT).any()  # the samples' own spacing is not dt bit for bit: what the old code read


def test_compact_keeps_the_recorded_dt():
    traj = run_engine("pybullet", BALL, make_settings("pybullet", dt=DT))
    small = compact(traj, BALL, above=100, chunk=64)
    assert small.compact and small.step == DT


def test_compares_dt_column_is_the_settings_dt():
    table = compare(BALL, settings=settings_for(("pybullet",), dt=DT)).table
    assert table["dt"].tolist() == [DT] * len(table)


def test_samples_from_elsewhere_take_their_median_spacing_once():
    ref = reference_trajectory(BALL, dt=DT)
    assert ref.step == float(np.median(np.diff(ref.t)))
    # known answer the other way: a trajectory whose step was given keeps it, whatever its samples say
    given = dataclasses.replace(ref, step=2 * DT)
    assert given.dt == 2 * DT
