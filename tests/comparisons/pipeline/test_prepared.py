"""A run prepared once for many tolerances (``pipeline.prepared``) judges as ``judge`` does at each: the same tables,
and the same verdicts and columns without them, on real engines' runs that pass and fail."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from chatterbench.comparisons.pipeline.compare import judge_run
from chatterbench.comparisons.pipeline.extract import extract
from chatterbench.comparisons.pipeline.judge import judge
from chatterbench.comparisons.pipeline.prepared import PreparedRun
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.registry import make_settings
from chatterbench.reference import load_scene

# tolerances that move every part a prepared run keeps: the rest window (stick, exit), the impacts' measure
# (restitution), the pairing (resolved_steps), the allowance (penetration) and the energy bound
TOLERANCES = [Tolerances(stick=s, exit=s, first_impact=s, restitution=r) for s in (0.01, 0.05, 0.2) for r in (0.02, 0.3)]
TOLERANCES += [Tolerances(resolved_steps=4.0, penetration=0.01, energy_gain=0.01, persistence=0.5)]
CASES = [
    ("mujoco", "bouncing-ball", 1e-3, {"mujoco.w0_dt": 0.3, "mujoco.impedance": 0.9}),  # late, rebound, match
    ("pybullet", "bouncing-ball", 1e-4, {}),  # buzz
    ("pybullet", "feigin-pair", 2e-3, {"pybullet.restitution_velocity_threshold": 0.01}),  # both walls, late and match
    ("mujoco", "impact-damper", 1e-3, {}),  # penetrated: the run's row
]


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


@pytest.mark.parametrize("engine, scene, dt, settings", CASES, ids=[f"{c[0]}-{c[1]}-{c[2]:g}" for c in CASES])
def test_a_prepared_run_judges_as_judge_does_at_every_tolerance(engine, scene, dt, settings):
    ref = solve(load_scene(scene, ["duration=12.6"] if scene == "feigin-pair" else []))
    run, _, _ = judge_run(ref, engine, make_settings(engine, dt, settings), Tolerances())
    found = extract(run.trajectory, ref.scene, ref.stick_tolerance(0.05))
    prepared = PreparedRun(ref, found, run.trajectory)
    seen = set()
    for tol in TOLERANCES:
        want = judge(ref, found, run.trajectory, tol)
        got = prepared.judgement(tol)
        pd.testing.assert_frame_equal(got.table, want.table, check_exact=True)
        pd.testing.assert_frame_equal(got.impacts, want.impacts, check_exact=True)
        for field in ("t_diverged", "t_penetrated", "penetration_allowance"):
            assert _same(getattr(got, field), getattr(want, field)), field
        level = prepared.verdicts(tol)
        assert level.verdicts == tuple(want.table["verdict"])
        for c in want.table.columns.drop(["verdict", "reason"]):
            assert all(_same(a, b) for a, b in zip(level.column(c), want.table[c].tolist())), c
        assert len(level.excess) == len(want.impacts)
        assert all(_same(a, b) for a, b in zip(level.excess.tolist(), want.impacts["excess"].astype(float).tolist()))
        # without the contact after the stick where the verdict is decided before it: the same verdicts
        assert prepared.verdicts(tol, complete=False).verdicts == level.verdicts
        seen |= set(level.verdicts)
    assert seen - {"match"}, seen  # each case fails somewhere: the comparison covers failing rows
