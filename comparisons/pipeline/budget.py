"""What a run will cost, estimated from its inputs before it starts; refused when over budget.

    >>> from chatterbench.comparisons.pipeline.budget import Budget, check_engine_run, engine_estimate
    >>> from chatterbench.reference.scene import load_scene
    >>> budget = Budget()                                   # 5e7 steps per engine run, 4 GiB
    >>> scene = load_scene("feigin-pair")
    >>> engine_estimate(scene, "mujoco", 1e-4).steps        # 40.2 s at 1e-4 s
    402123
    >>> check_engine_run(scene, "mujoco", 1e-7, budget)
    Traceback (most recent call last):
    ...
    chatterbench.comparisons.pipeline.budget.BudgetError: mujoco on 'feigin-pair': dt = 1e-07 s over duration = 40.2 s is 4.02e+08 steps and about 37.8 GiB, more than --max-steps 5e+07 ...

Estimates, each from a measurement on this code (2-core machine, ``/usr/bin/time -f %M``
of ``chatterbench run feigin-pair --engine E --dt D`` at 4e6 and 8e6 or 1.2e7 steps):
- an engine run: ``duration / dt`` steps (``engines.base.n_steps``); its memory is
  ``EngineAdapter.bytes_per_step`` per step (MuJoCo 69 B, PyBullet 88 B measured, stated
  with a margin) over the ``BASE_MEMORY`` of a process with the default engines loaded. A run that
  long is handed on compact (``engines/window.py``: the samples near the walls, about a third
  of feigin-pair's), so the figure follows the time the scene spends near its walls; a scene
  in contact most of the time keeps more (spring-pair: 72 % of its samples);
- the reference (both chatter modes): events = the events of a pilot run over the first
  ``PILOT_PERIODS`` forcing periods, scaled to the duration (only for runs longer than
  ``LONG_PERIODS`` periods: shorter ones cost under a second); ``BYTES_PER_EVENT`` each
  (1.2 kB measured on feigin-pair at 2000 s);
- a plate map: ``BYTES_PER_STRIKE`` per strike of the grid, and one short engine run each.

A refusal is a ``BudgetError`` (an ``InputError``: exit 2) naming the input that makes the
run too big, the estimate, the limit and the option that raises it (``--max-steps``,
``--max-memory``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from chatterbench.engines.base import n_steps
from chatterbench.engines.registry import adapter
from chatterbench.reference.errors import InputError
from chatterbench.reference.scene import Scene, scene_from_dict

GIB = 2.0**30
MAX_STEPS = 5e7  # engine steps per run: MuJoCo about 100 s, PyBullet about 15 min on this machine
MAX_MEMORY = 4.0 * GIB  # [B] per process: a 2-core, 24 GiB machine runs two at once with room to spare
BASE_MEMORY = 0.3 * GIB  # [B] a process with numpy, pandas, the default engines and numba kernels loaded
BYTES_PER_EVENT = 1500.0  # [B] one reference event, both the log row and its episode bookkeeping
BYTES_PER_STRIKE = 200.0  # [B] one plate-map strike: grid, fates, table columns
LONG_PERIODS = 200  # reference runs longer than this many forcing periods get a pilot estimate
PILOT_PERIODS = 8
# times are floats: a step must be this many float spacings wide at the run's end time
STEP_RESOLUTION = 1e3


class BudgetError(InputError):
    """A run that would exceed the step or memory budget (the message says which input and limit)."""


@dataclass(frozen=True)
class Budget:
    """Limits on one command's runs: engine steps per run, memory per process [B]."""

    max_steps: float = MAX_STEPS
    max_memory: float = MAX_MEMORY

    def __post_init__(self) -> None:
        for name, low, unit in (("max_steps", 1.0, 1.0), ("max_memory", BASE_MEMORY, GIB)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value < math.inf:
                shown = f"{value / unit:g}" if unit != 1.0 and isinstance(value, (int, float)) else repr(value)
                raise BudgetError(f"--{name.replace('_', '-')} = {shown}: must be a finite number >= {low / unit:g}"
                                  f"{' [GiB]: the memory of a process with both engines loaded' if unit != 1.0 else ''}")


@dataclass(frozen=True)
class Estimate:
    """What a run will take: steps (engine) or events (reference), and memory [B]."""

    steps: float
    memory: float


def _gib(n: float) -> str:
    return f"{n / GIB:.3g} GiB"


def engine_estimate(scene: Scene, engine: str, dt: float) -> Estimate:
    """Steps and peak memory [B] of running ``scene`` in ``engine`` at timestep ``dt`` [s]."""
    ratio = scene.duration / dt if dt > 0 else math.inf
    steps = n_steps(scene.duration, dt) if ratio < 1e18 else ratio  # past 1e18 the count is only an estimate
    return Estimate(steps, BASE_MEMORY + steps * adapter(engine).bytes_per_step)


def check_engine_run(scene: Scene, engine: str, dt: float, budget: Budget) -> Estimate:
    """The engine run's estimate; ``BudgetError`` when it is over ``budget`` or its steps cannot be told apart."""
    est = engine_estimate(scene, engine, dt)
    what = f"{engine} on {scene.name!r}: dt = {dt:g} s over duration = {scene.duration:.3g} s is {est.steps:.3g} steps"
    over = [f"--max-steps {budget.max_steps:.3g}"] if est.steps > budget.max_steps else []
    if est.memory > budget.max_memory:
        over.append(f"--max-memory {_gib(budget.max_memory)}")
    if over:
        raise BudgetError(f"{what} and about {_gib(est.memory)}, more than {' and '.join(over)}; use a larger dt "
                          "(--dt or ENGINE.dt) or a shorter duration, or raise the limit")
    spacing = math.ulp(max(abs(scene.initial.t), abs(scene.t_end)))
    if dt < STEP_RESOLUTION * spacing:
        raise BudgetError(f"{engine} on {scene.name!r}: dt = {dt:g} s is too small for times near "
                          f"t = {scene.t_end:.3g} s (spaced {spacing:.3g} s apart); use dt >= {STEP_RESOLUTION * spacing:.3g} s "
                          "or an initial.t nearer 0")
    return est


def reference_estimate(scene: Scene) -> Estimate:
    """Events and memory [B] of the reference's two runs (Feigin and exhaustive) over ``scene.duration``."""
    periods = scene.duration / scene.time_scale
    if periods <= LONG_PERIODS:
        return Estimate(0.0, BASE_MEMORY)
    data = scene.to_dict()
    data["duration"] = PILOT_PERIODS * scene.time_scale
    pilot = scene_from_dict(data)
    from chatterbench.reference.simulate import simulate  # numba's kernels: loaded by the work, not by --help

    events = sum(len(simulate(pilot, mode).log) for mode in ("feigin", "exhaustive"))
    events *= scene.duration / pilot.duration
    return Estimate(events, BASE_MEMORY + events * BYTES_PER_EVENT)


def check_reference(scene: Scene, budget: Budget) -> Estimate:
    """The reference's estimate; ``BudgetError`` naming the duration when it is over ``budget``."""
    est = reference_estimate(scene)
    if est.memory > budget.max_memory:
        raise BudgetError(f"the reference on {scene.name!r}: duration = {scene.duration:.3g} s "
                          f"({scene.duration / scene.time_scale:.3g} forcing periods) is about {est.steps:.3g} events "
                          f"and {_gib(est.memory)}, more than --max-memory {_gib(budget.max_memory)}; use a shorter "
                          "duration or raise the limit")
    return est


def check_plate_map(n_phase: int, n_speed: int, budget: Budget) -> Estimate:
    """A plate map's grid; ``BudgetError`` naming ``--phases`` and ``--speeds`` when it is over ``budget``."""
    strikes = float(n_phase) * float(n_speed)
    est = Estimate(strikes, BASE_MEMORY + strikes * BYTES_PER_STRIKE)
    if est.memory > budget.max_memory:
        raise BudgetError(f"--phases {n_phase} x --speeds {n_speed} is {strikes:.3g} strikes and about "
                          f"{_gib(est.memory)}, more than --max-memory {_gib(budget.max_memory)}; use fewer phases or "
                          "speeds, or raise the limit")
    return est


def check_comparison(scene: Scene, settings: Mapping[str, Any], budget: Budget, reference: bool = True) -> None:
    """Check every engine run (``settings``: engine name -> its settings, with ``dt``), then the reference."""
    for name, s in settings.items():
        check_engine_run(scene, name, s.dt, budget)
    if reference:
        check_reference(scene, budget)
