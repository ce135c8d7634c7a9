"""One call, one table: run the reference and the engines on a scene and judge every episode.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> result = compare(load_scene("bouncing-ball"), settings=settings_for(("mujoco", "pybullet"), dt=1e-4))
    >>> result.table[["engine", "wall", "verdict"]].values.tolist()   # PyBullet's default threshold 0: it keeps bouncing
    [['mujoco', 'lower', 'rebound'], ['pybullet', 'lower', 'buzz']]
    >>> result.summary()[["engine", "verdict", "n_match"]].values.tolist()   # the columns of ``summary.ROW_COLUMNS``
    [['mujoco', 'rebound', 0], ['pybullet', 'buzz', 0]]

The table has one row per (engine, reference or engine episode) with the columns of
``judge.TABLE_COLUMNS`` plus ``engine``, ``dt`` [s], ``status`` (the engine run's status)
and ``cost_per_sim_s`` (wall-clock seconds of engine stepping per simulated second);
``impacts`` has every paired resolved impact (``judge.IMPACT_PAIR_COLUMNS`` plus
``engine``). A failing engine never raises: its run is classified (``error``,
``diverged``) and its rows say so; the other engines' results are kept.

Settings are objects here (``settings={"pybullet": PybulletSettings(...)}``, or
``registry.settings_for(engines, dt, overrides)`` for callers who hold a timestep and strings:
made and checked there, once); an engine given none runs at its defaults. Each class of failure is caught in one place, none here:
an engine's failure (it raises, blows up, stops short, its samples do not fit) by the
adapter, as the run's status (``base.EngineAdapter.run``); a crash or a hang of an isolated
run (``timeout``) by ``isolate``, which also turns anything the child raises into ``error``.
Settings the scene cannot run with are the caller's mistake: ``SettingsError``, raised
before that engine starts (inside an isolated run: that run's ``error``).
"""

from __future__ import annotations

import math
import platform
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any, Callable, Mapping, Sequence

import pandas as pd

from chatterbench.engines.registry import (DEFAULT_ENGINES, adapter, check_engine, engine_version, make_settings,
                                           run_engine, run_engine_isolated, settings_dict)
from chatterbench.engines.settings import SettingsError
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import Scene
from chatterbench.reference.simulate import Result

from .budget import Budget, check_comparison
from .extract import Extraction, extract
from .extract_options import ExtractionOptions
from .judge import IMPACT_PAIR_COLUMNS, TABLE_COLUMNS, judge
from .solution import ReferenceSolution, solve
from .summary import SUMMARY_COLUMNS, summarize  # summary imports only the vocabulary: no cycle
from .tolerances import Tolerances

COLUMNS = ["engine", "dt"] + TABLE_COLUMNS + ["status", "cost_per_sim_s"]


@dataclass(frozen=True)
class EngineRun:
    """One engine's run on the scene: trajectory, what the extraction found, settings and cost."""

    engine: str
    settings: dict[str, Any]
    trajectory: Trajectory
    found: Extraction
    wall_time: float  # [s] spent stepping
    version: str
    t_diverged: float  # [s], NaN if none
    t_penetrated: float  # [s], NaN if none

    @property
    def status(self) -> str:
        return self.trajectory.status

    @property
    def log(self) -> pd.DataFrame:
        """The recovered event log (``reference/log.py`` format)."""
        return self.found.log

    @property
    def episodes(self) -> pd.DataFrame:
        """The recovered episodes (``reference/log.py`` format)."""
        return self.found.episodes

    @property
    def cost_per_sim_s(self) -> float:
        """Wall-clock seconds per simulated second."""
        sim = float(self.trajectory.t[-1] - self.trajectory.t[0]) if len(self.trajectory.t) > 1 else 0.0
        return self.wall_time / sim if sim > 0 else math.nan


@dataclass(frozen=True)
class Comparison:
    """Everything ``compare`` produced; ``table`` is the headline."""

    scene: Scene
    table: pd.DataFrame
    solution: ReferenceSolution
    tolerances: Tolerances
    impacts: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=["engine", *IMPACT_PAIR_COLUMNS]))
    runs: dict[str, EngineRun] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)

    @property
    def reference(self) -> pd.DataFrame:
        """The reference's episodes with their scales (``solution.EPISODE_COLUMNS``)."""
        return self.solution.episodes

    @property
    def feigin(self) -> Result:
        return self.solution.feigin

    @property
    def exhaustive(self) -> Result:
        return self.solution.exhaustive

    def summary(self) -> pd.DataFrame:
        """One row per engine (``summary.ROW_COLUMNS`` without the sweep's point id)."""
        return pd.DataFrame([summarize(self, name, {}) for name in self.runs], columns=SUMMARY_COLUMNS)


def judge_run(ref: ReferenceSolution, name: str, settings: Any, tol: Tolerances, trajectory: Trajectory | None = None,
              options: ExtractionOptions | None = None,
              timeout: float | None = None) -> tuple[EngineRun, pd.DataFrame, pd.DataFrame]:
    """Run one engine (or take its ``trajectory``, already run), extract and judge it.

    Returns the run, its judged table (``judge.TABLE_COLUMNS``) and its paired impacts.
    ``settings``: the engine's settings object. An engine's failure comes back from its adapter
    as the run's status (nothing is caught here). With ``timeout`` [s] the engine runs in a
    forked child (``run_engine_isolated``): a crash or a hang becomes a ``crashed`` or
    ``timeout`` run and this process goes on. Raises SettingsError (in this process) for
    settings the scene cannot run with.
    """
    scene = ref.scene
    if trajectory is not None:
        traj = trajectory
    elif timeout is not None:
        traj = run_engine_isolated(name, scene, settings, timeout)
    else:
        traj = run_engine(name, scene, settings)
    found = extract(traj, scene, ref.stick_tolerance(tol.stick), options)
    judged = judge(ref, found, traj, tol)
    run = EngineRun(
        engine=name, settings=dict(traj.settings) or settings_dict(settings), trajectory=traj, found=found,
        wall_time=traj.wall_time, version=engine_version(name), t_diverged=judged.t_diverged,
        t_penetrated=judged.t_penetrated,
    )
    return run, judged.table, judged.impacts


def engine_settings(engines: Sequence[str], settings: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Each engine's settings object: ``settings[name]`` as given, else its defaults (``registry.make_settings``).

    Raises SettingsError, naming the entry, for an unknown engine, and for a ``settings`` entry for an engine not in
    ``engines`` or of another engine's type. Text (``--dt``, ``--set``, a TOML file) becomes settings objects at the
    edge, before this: ``registry.make_settings`` / ``registry.settings_for``.

    >>> from chatterbench.comparisons.pipeline.compare import engine_settings
    >>> from chatterbench.engines.pybullet_engine import PybulletSettings
    >>> s = engine_settings(("mujoco", "pybullet"), {"pybullet": PybulletSettings(dt=1e-3)})
    >>> type(s["mujoco"]).__name__, s["mujoco"].dt, s["pybullet"].dt
    ('MujocoSettings', 0.0001, 0.001)
    """
    given = dict(settings or {})
    for name, obj in given.items():
        if name not in engines:
            raise SettingsError(f"settings[{name!r}]: {name} is not among the engines run ({', '.join(engines) or 'none'}); "
                                "add it to engines or leave its settings out")
        want = adapter(check_engine(name)).settings_type
        if type(obj) is not want:
            raise SettingsError(f"settings[{name!r}]: a {type(obj).__name__}; {name} takes a {want.__name__} "
                                f"(registry.make_settings({name!r}, ...))")
    return {name: given[name] if name in given else make_settings(check_engine(name)) for name in engines}


def compare(
    scene: Scene,
    engines: Sequence[str] | None = None,
    tol: Tolerances | None = None,
    trajectories: Mapping[str, Trajectory] | None = None,
    solution: ReferenceSolution | None = None,
    options: ExtractionOptions | None = None,
    timeout: float | None = None,
    budget: Budget | None = None,
    progress: Callable[[str], None] | None = None,
    settings: Mapping[str, Any] | None = None,
) -> Comparison:
    """Run the reference (both chatter modes) and each engine on ``scene``; judge every episode.

    Parameters
    ----------
    engines : sequence of names of ``engines.registry.ENGINE_NAMES``, optional
        The engines run, in this order; None: those of ``settings`` when given, else ``DEFAULT_ENGINES``.
    tol : Tolerances, optional
    trajectories : mapping engine name -> Trajectory, optional
        Runs already made (a sweep's MuJoCo batch, or any trajectory to judge: the exact
        reference from ``reference_trajectory`` is the known answer); those engines are
        judged on them instead of being run.
    solution : ReferenceSolution, optional
        ``solve(scene)`` already computed (tune and sweeps judge many runs against one).
    options : ExtractionOptions, optional
        The extraction's internal thresholds (their robustness is tested, not tuned).
    timeout : float, optional
        Wall-clock limit [s] of each engine run; given, each engine runs isolated in a forked
        child (the command line always does this), so a crash or hang in one engine is that
        engine's ``crashed`` / ``timeout`` verdict and the others' results are kept. None: in
        this process, without a limit.
    budget : Budget, optional
        Refuse (``BudgetError``) before any run when the reference or an engine run is estimated
        over it (``budget.py``); None: no estimate.
    progress : callable, optional
        Called with ``"reference"`` before the reference is solved and with each engine's name
        before that engine runs (the command line's progress bar).
    settings : mapping engine name -> settings object, optional
        The settings of some or all of ``engines``, each of its engine's ``settings_type``; the others run at
        their defaults. The only way settings come in: text becomes these objects at the edge
        (``registry.settings_for(engines, dt, overrides)``, the command line's ``settings_of``), checked there once.
    """
    tol = tol or Tolerances()
    engines = tuple(engines if engines is not None else settings or DEFAULT_ENGINES)
    settings = engine_settings(engines, settings)  # every refusal before any run
    if budget is not None:
        check_comparison(scene, {n: s for n, s in settings.items() if n not in (trajectories or {})}, budget,
                         reference=solution is None)
    say = progress or (lambda what: None)
    if solution is None:
        say("reference")
    ref = solution if solution is not None else solve(scene)
    runs, tables, impact_tables = {}, [], []
    for name in engines:
        say(name)
        run, table, impacts = judge_run(ref, name, settings[name], tol, (trajectories or {}).get(name), options, timeout)
        runs[name] = run
        step = run.trajectory.dt  # the run's dt, recorded with it (engines/trajectory.py)
        step = getattr(settings[name], "dt", math.nan) if math.isnan(step) else step
        table.insert(0, "dt", step)
        table.insert(0, "engine", name)
        table["status"] = run.status
        table["cost_per_sim_s"] = run.cost_per_sim_s
        tables.append(table)
        impact_tables.append(impacts.assign(engine=name)[["engine", *IMPACT_PAIR_COLUMNS]])
    table = pd.concat(tables, ignore_index=True) if tables else pd.DataFrame(columns=COLUMNS)
    impacts = pd.concat(impact_tables, ignore_index=True) if impact_tables else pd.DataFrame(columns=["engine", *IMPACT_PAIR_COLUMNS])
    provenance = {
        "scene": scene.name,
        "scene_data": scene.to_dict(),
        "engines": {name: {"version": run.version, "settings": run.settings, "status": run.status,
                           "message": run.trajectory.message, "wall_time_s": run.wall_time} for name, run in runs.items()},
        # the reference's own cost is Feigin's model (the exhaustive chase is a cross-check)
        "reference": {"chatter_modes": ["feigin", "exhaustive"], "wall_time_s": ref.wall_time,
                      "cost_per_sim_s": ref.cost_per_sim_s},
        "tolerances": tol.as_dict(),
        "machine": f"{platform.machine()} {platform.processor() or ''} {platform.system()} python {platform.python_version()}".strip(),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    return Comparison(scene=scene, table=table[COLUMNS], solution=ref, tolerances=tol, impacts=impacts, runs=runs,
                      provenance=provenance)
