"""An engine plugin for chatterbench: "exact", the reference solution sampled every dt (judged ``match``).

    >>> from chatterbench.engines import run_engine, make_settings
    >>> from chatterbench.reference.scene import load_scene
    >>> run_engine("exact", load_scene("bouncing-ball"), make_settings("exact", dt=1e-3)).status
    'ok'

What an engine needs: a frozen settings dataclass with a checked ``dt`` [s], and an
``EngineAdapter`` subclass that names itself, its package and its settings, and writes
``simulate`` (step the engine, hand the samples to ``run.add``) and ``bare_seconds`` (its own
loop, for the benchmark); the base does the rest. ``pyproject.toml`` declares it in the
entry-point group ``chatterbench.engines``.
"""

import time
from dataclasses import dataclass

from chatterbench.comparisons import reference_trajectory
from chatterbench.engines import EngineAdapter
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.errors import check_number


@dataclass(frozen=True)
class ExactSettings:
    dt: float = 1e-3  # [s] sampling step

    def __post_init__(self):
        check_number("exact.dt", self.dt, lo=0.0, lo_open=True, unit=" [s]", error=SettingsError)


class ExactEngine(EngineAdapter):
    name, package, settings_type = "exact", "chatterbench-exact-engine", ExactSettings

    def simulate(self, run):
        ref = reference_trajectory(run.scene, run.settings.dt)
        run.add(ref.t, ref.normal_force, x1=ref.x1, v1=ref.v1, x2=ref.x2, v2=ref.v2)

    def bare_seconds(self, scene, settings, traj):
        start = time.perf_counter()
        reference_trajectory(scene, settings.dt)
        return time.perf_counter() - start
