"""pytest plugin: the ``chatter_gate`` fixture, an accuracy gate written as a test (and ``chatter_judge``, for any trajectory).

    def test_mujoco_slides_on_time(chatter_gate):
        chatter_gate.check("feigin-pair", engine="mujoco", dt=1e-4, verdict=["match", "rebound"],
                           stick_error_rel_max=0.05, exit_error_max=2e-4)

Registered through the ``pytest11`` entry point ``chatterbench``, so installing chatterbench
is enough (disable with ``-p no:chatterbench``). ``check`` takes the keys of a gate file's
check (``gate.py``: ``scene``, ``engine``, ``dt``, ``settings``, ``scene_overrides``,
``tolerances``, ``name``) and its limits as keywords: a bare value means the metric's
usual bound (errors and cost ``<=``, ``n_match >=``, ``verdict ==``; ``gate.DEFAULT_OPS``),
a list of verdicts means ``in``, and ``(op, value)`` names the operator. A failing limit
fails the test with one line per limit, measured against the limit; a check that cannot
run as written (unknown metric, scene key, setting) fails it with the gate file's message.
The failure ends with the ``chatterbench compare`` and ``tune`` commands to run next.

Promises: nothing heavy is imported until a test asks for the fixture; runs are shared
within the session between checks that ask for the same run.
"""

from __future__ import annotations

from typing import Any, Mapping

import pytest


class ChatterGate:
    """What the ``chatter_gate`` fixture gives a test: ``check(...)``."""

    def __init__(self, cache: dict) -> None:
        self._cache = cache

    def check(
        self,
        scene: Any,
        engine: str,
        dt: float | None = None,
        settings: Mapping[str, Any] | None = None,
        scene_overrides: Mapping[str, Any] | None = None,
        tolerances: Mapping[str, Any] | None = None,
        name: str | None = None,
        **limits: Any,
    ):
        """Run ``scene`` on ``engine`` and fail the test unless every limit holds.

        Returns the ``checks.CheckResult`` (its ``row`` has every metric) when all hold.
        """
        from chatterbench.reference.errors import InputError

        from .checks import run_check
        from .decision import decide_check
        from .gate import limits_from_keywords, make_check

        refused = ""
        try:
            check = make_check(scene, engine, limits_from_keywords(**limits), dt=dt, settings=settings,
                               scene_overrides=scene_overrides, tolerances=tolerances, name=name)
        except InputError as exc:  # a misspelt metric, a bad scene or setting: said once, outside the handler
            refused = f"chatter_gate.check: {exc}"
        if refused:
            pytest.fail(refused, pytrace=False)
        result = run_check(check, self._cache)
        decision = decide_check(result)
        if not decision.passed:
            pytest.fail(decision.account(), pytrace=False)
        return result


@pytest.fixture(scope="session")
def _chatter_gate_runs() -> dict:
    """Runs shared by every ``chatter_gate`` check of the session (keyed by ``Check.run_key``)."""
    return {}


@pytest.fixture
def chatter_gate(_chatter_gate_runs: dict) -> ChatterGate:
    """Accuracy checks against the reference: ``chatter_gate.check(scene, engine=..., dt=..., METRIC=LIMIT, ...)``."""
    return ChatterGate(_chatter_gate_runs)


@pytest.fixture
def chatter_judge():
    """Judge your own engine's trajectory in its own CI: ``chatter_judge(scene, table_or_path, engine=..., verdict=...)``.

    ``scene`` is a Scene, a built-in name or a TOML path; the trajectory a DataFrame or a CSV or
    Parquet file (``pipeline/trajectory_file.py``). Fails the test, with the episode table, unless
    every episode's verdict is in ``verdict`` (default ``match`` or ``none``); returns the Comparison.
    """
    def judge(scene: Any, trajectory: Any, engine: str = "engine", verdict=("match", "none"),
              tolerances: Mapping[str, Any] | None = None):
        from chatterbench.comparisons.pipeline.tolerances import make_tolerances
        from chatterbench.comparisons.pipeline.trajectory_file import judge_trajectory
        from chatterbench.reference.errors import InputError

        try:
            result = judge_trajectory(scene, trajectory, engine=engine, tol=make_tolerances(tolerances))
        except InputError as exc:
            pytest.fail(f"chatter_judge: {exc}", pytrace=False)
        allowed = (verdict,) if isinstance(verdict, str) else tuple(verdict)
        bad = result.table[~result.table["verdict"].isin(allowed)]
        if len(bad):
            shown = bad[["wall", "ref_t_stick", "t_stick", "stick_error_rel", "ref_t_exit", "t_exit", "verdict"]]
            pytest.fail(f"{engine} on {result.scene.name}: {len(bad)} of {len(result.table)} episodes not in "
                        f"{', '.join(allowed)}:\n{shown.to_string(index=False)}", pytrace=False)
        return result

    return judge
