"""The engine contract: the base class owns the run, an adapter owns its engine (build its world, step it).

    >>> from chatterbench.engines.base import Status, n_steps, sample_times
    >>> from chatterbench.reference.scene import load_scene
    >>> n_steps(1.0, 3e-4)                  # the last sample at or before the end of the run
    3333
    >>> sample_times(load_scene("bouncing-ball"), 0.5)
    array([0. , 0.5, 1. , 1.5, 2. ])
    >>> Status.DIVERGED == "diverged", Status("crashed").message
    (True, 'the process running the engine died (a signal, or out of memory)')

``EngineAdapter.run`` is every engine's run, the way scipy's ``OdeSolver.step()`` is every
solver's step and a solver writes only ``_step_impl``: an adapter writes

- ``build(scene, settings) -> world``: its engine's model of the scene at ``scene.initial``;
- ``step(world, forces) -> (state, wall_forces)``: one step of ``settings.dt`` under the forces
  [N] on body 1 and body 2, the state (x1, v1, x2, v2) after it and what each wall pushed
  body 2 with during it; and ``drive(world, x1, v1, x1_end)`` when it can move a prescribed
  body 1;

and the base does the rest (``stepping.py``): it checks the settings (``SettingsError`` before
the engine starts), makes the settings record, applies the scene's forces every step (its
force model as an affine map, ``force_plan``), records the samples chunk by chunk
(``recording.Recording``, through ``window.Recorder``: every long run comes back compact),
times the steps, classifies what happened (``status.Status``), and steps the same world with no recording for the benchmark's bare loop. An
engine that runs a whole run at once (MuJoCo's rollout, Drake's integrator, a child process)
writes ``samples(run)`` instead, a generator of the run's samples chunk by chunk
(``wholerun.Samples``), which the base steps, times and records as it does a stepping engine's
(``wholerun.py``): no adapter reads a clock. Either way the adapter declares its facts
(``compliant``, ``precision``, ...), checked when it is registered (``contract.py``), and may
implement the optional capabilities of ``capabilities.py`` (a tuning space, an exported model,
a snippet). A plugin imports all it needs from ``api.py``. The base keeps these promises for
every engine, and the shipped contract suite (``contract_suite.py``: ``pytest
--chatterbench-engine NAME``) checks them:

- ``run`` samples the scene at ``sample_times(scene, settings.dt)``: sample 0 is the initial
  state, sample k the state after k steps, the last one at or before the scene's end;
- a user mistake in the settings is refused (``SettingsError``) before the engine starts;
  anything that goes wrong inside the engine is a ``status`` (``Status``), never an
  exception: any exception of the engine is ``error`` (``Diverged``: ``diverged``; ``Crashed``:
  ``crashed``; ``TimedOut``: ``timeout``), a sample with a non-finite or huge (> ``MAXVAL``)
  state or a non-finite force ends the run as ``diverged`` there, a run that stops short is
  ``error``; the samples before are kept;
- body 1 of infinite mass is filled in by the base (its prescribed motion, or at rest);
- the trajectory carries the contact law's own scales (``Trajectory.contact_time``,
  ``contact_frequency``) for reports; the judge never reads them;
- ``benchmark`` has one signature and one result (``BenchmarkResult``) for every engine;
- an adapter marked ``isolated`` (every plugin, ``plugins.py``) runs, batches and benchmarks in
  a forked child under the command's run limit (``isolate.run_limit``): its crash, hang or
  ``os._exit`` is that run's ``crashed`` or ``timeout``, never the command's.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from importlib.metadata import version as package_version
from typing import Any, ClassVar, Iterator, Sequence

import numpy as np

from chatterbench.reference.errors import check_integer
from chatterbench.reference.scene import Scene

from .faults import inject_planned
from .isolate import Outcome, call_isolated, inside
from .recording import GRID_SLACK, MAXVAL, Recording  # noqa: F401  (GRID_SLACK, MAXVAL: read from here too)
from .settings import SettingsError
from .status import STATUS_MESSAGE, Crashed, Diverged, Status, TimedOut, failed_trajectory  # noqa: F401
from .stepping import bare_seconds as stepping_bare_seconds
from .stepping import n_steps, run_steps  # n_steps: a run's steps, exported here
from .trajectory import Trajectory
from .wholerun import record as record_chunks

_count_steps = n_steps  # ``EngineAdapter.benchmark``'s argument has the name


def sample_times(scene: Scene, dt: float) -> np.ndarray:
    """The sample times of a run [s], t0 + k dt for k = 0..n_steps(duration, dt); shape (n + 1,)."""
    return scene.initial.t + dt * np.arange(n_steps(scene.duration, dt) + 1)


@dataclasses.dataclass(frozen=True)
class BenchmarkResult:
    """Steps per second of an adapter's ``run`` against its bare engine loop on the same run."""

    engine: str
    scene: str
    n_steps: int  # steps per repeat
    repeats: int  # best of
    adapter_steps_per_s: float  # ``run`` as a user calls it (step, record, classify), its fixed cost taken off
    raw_steps_per_s: float  # the bare loop on the same model and forces, nothing recorded (``bare_seconds``)
    status: Status  # of the adapter's last run
    details: dict[str, Any] = dataclasses.field(default_factory=dict)  # the engine's own figures (device, build time)

    @property
    def ratio(self) -> float:
        """adapter / raw steps per second (1: the adapter costs nothing)."""
        return self.adapter_steps_per_s / self.raw_steps_per_s


class EngineAdapter:
    """One engine behind the suite's contract (module docstring). Subclasses set the class facts and write ``build``
    and ``step`` (or ``samples``, a whole run at once); the base writes the run, the batch, the record, the timing and
    the benchmark."""

    name: ClassVar[str]  # the registry name, "mujoco"
    package: ClassVar[str]  # the distribution whose version is reported
    settings_type: ClassVar[type]  # a frozen dataclass with a ``dt`` field [s], validated when made
    compliant: ClassVar[bool] = False  # a contact law with its own time scale (True) or a rigid impulse law
    precision: ClassVar[str] = "float64"  # the arithmetic the engine steps in
    batches: ClassVar[bool] = False  # does run_batch do better than one run after another?
    # [B] per step of a run: the memory it holds, samples and engine state (measured); ``--max-memory`` reads it
    # (``comparisons/pipeline/budget.py``: a run's estimate is a base cost + steps x bytes_per_step, refused over it)
    bytes_per_step: ClassVar[float] = 500.0
    bench_step_cap: ClassVar[int | None] = None  # most steps a benchmark repeat takes (a slow engine's cap)
    # the registry name of an engine that steps this very model on another executor ("": none); compare reports
    # the two's conformance (``comparisons/pipeline/conformance.py``) whenever both ran
    same_model_as: ClassVar[str] = ""
    # what the first run on a machine costs before it steps, said before it starts ("": nothing worth saying)
    first_run_note: ClassVar[str] = ""
    # the files ``export`` writes a scene as, the model file first (``run --export-model``, ``tune --out``); (): none
    exports: ClassVar[tuple[str, ...]] = ()
    export_kind: ClassVar[str] = ""  # what the model file is, for messages: "an MJCF model"
    # how the base sums a step's force, time part + gain . (x1, v1, x2, v2) (``stepping.py``): "grouped", the state
    # part first, or "in order", term by term (DART's loop summed so; kept so that its runs stay bit for bit)
    force_sum: ClassVar[str] = "grouped"
    isolated: bool = False  # every run in a forked child under ``isolate.run_limit`` (the registry's plugins)

    # -- what an adapter writes: its world and one step of it (or a whole run, ``samples``) ----------
    def build(self, scene: Scene, settings: Any) -> Any:
        """The engine's world for ``scene`` at ``settings``, at ``scene.initial`` (t0, x1, v1, x2 = x1 + y, v2 = v1 +
        vy), the walls on body 1 where y = x2 - x1 meets ``scene.gap.lower`` (and ``upper``), no scene force in it
        (the base applies them). A world with a ``close()`` method is closed when the run ends."""
        raise NotImplementedError(f"{type(self).__name__} writes neither build and step nor samples")

    def step(self, world: Any, forces: tuple[float, float]) -> tuple[tuple, tuple[float, ...]]:
        """Advance ``world`` one step of ``settings.dt`` [s] with ``forces`` = (on body 1, on body 2) [N] along x
        applied over it. Returns ``(x1, v1, x2, v2)`` after the step [m, m/s] (x1, v1: None for an infinite body 1,
        which the base fills in) and per wall of ``scene.gap.walls`` the force [N] it pushed body 2 with in the
        step (> 0: a contact), or () when no wall touched body 2."""
        raise NotImplementedError(f"{type(self).__name__} writes neither build and step nor samples")

    def drive(self, world: Any, x1: float, v1: float, x1_end: float) -> None:
        """Before a step, move a prescribed (infinite) body 1: it is at ``x1`` [m] with velocity ``v1`` [m/s] at the
        step's start and at ``x1_end`` [m] at its end. An adapter without it refuses prescribed scenes."""
        raise NotImplementedError(f"{type(self).__name__} cannot move a prescribed body 1")

    def samples(self, run: Recording) -> Iterator[Any]:
        """A whole run at once, for an engine that cannot be stepped from outside (an integrator of its own, a child
        process), as a generator (``wholerun.py``): set the engine up for ``run`` (``run.scene``, ``run.settings``,
        ``run.n`` steps of ``run.settings.dt``), yield ``None`` once set up, then step and yield the samples chunk
        by chunk as ``wholerun.Samples``, in order, the initial state first. The base times what the generator
        does after its set-up (the run's stepping time) and records each chunk; the yield's value is False once the
        run is cut (stop then). Raise (anything) for a failure of the engine, ``Diverged`` for a blow-up the engine
        reports itself, ``Crashed`` when a process the adapter runs its engine in died, ``TimedOut`` when it
        stopped one at the run's time limit."""
        raise NotImplementedError(f"{type(self).__name__} writes neither build and step nor samples")

    # -- what an adapter may write: optional facts and capabilities (``capabilities.py``), the base's defaults --
    def export(self, scene: Scene, settings: Any, command: str | None = None) -> dict[str, str]:
        """File name (each of ``exports``) -> text: ``scene`` at ``settings`` as files that run in the engine alone,
        printing one line per impact (``impact_lines``); ``command``, the command that wrote them, kept in them."""
        return {}

    def measurement(self) -> str:
        """Python that measures one impact's e in the user's own model, with the snippet's placeholders ("": none)."""
        return ""

    def snippet(self, scene: Scene, settings: Any) -> str:
        """The settings as a user pastes them into their own model (MJCF, Python); here, the settings object."""
        return f"{self.settings(settings)!r}\n"

    def validate(self, scene: Scene, settings: Any) -> None:
        """Refuse (``SettingsError``) settings this scene cannot run with; the dataclass checked its own fields."""

    def record(self, scene: Scene, settings: Any) -> dict[str, Any]:
        """What the settings record adds to the settings' fields (the engine's own names for them)."""
        return {}

    def contact_scales(self, scene: Scene, settings: Any) -> tuple[float, float]:
        """The contact law's duration of one bounce [s] and natural frequency [rad/s]; (0, inf) for rigid."""
        return 0.0, math.inf

    def tuning_space(self, scene: Scene) -> dict[str, tuple] | None:
        """What ``tune`` searches for ``scene``: ``"dt"`` [s], a ladder from coarse to fine, and per setting
        (``"engine.field"``) its candidate values, the default first; None: the engine declares none."""
        return None

    def cost_lever(self, settings: Any) -> str:
        """The settings field a user turns to trade accuracy for cost: ``"dt"`` for fixed-step engines,
        ``"accuracy"`` for an error-controlled integrator (charts label their points with it)."""
        return "dt"

    def unread_fields(self, settings: Any) -> frozenset[str]:
        """The settings fields a run at ``settings`` does not read (Drake in discrete mode: the integrator's
        ``accuracy``, ``integrator`` and ``max_step``): settings that differ only there give the same run, bit for
        bit, so ``tune`` runs one of them (``tune.rows.evaluator``). The base: none (every field read)."""
        return frozenset()

    # -- what the base does for every engine ------------------------------------------------------
    def simulate(self, run: Recording) -> None:
        """Step the whole run into ``run``: the base's step loop over ``build`` and ``step`` (``stepping.run_steps``),
        or the adapter's ``samples`` generator driven, timed and recorded (``wholerun.record``); raises the engine's
        failure once the samples before it are recorded. Not an adapter's to write."""
        if self.steps():
            run_steps(self, run)
        elif self.whole_runs():
            record_chunks(run, self.samples(run))
        else:
            raise NotImplementedError(f"{type(self).__name__} writes neither build and step nor samples")

    def bare_seconds(self, scene: Scene, settings: Any, traj: Trajectory) -> float:
        """Seconds of the engine's own loop over the run ``traj`` (full; the adapter's own run of ``scene``): the
        same model and forces with no recording. The base's: ``step`` on a fresh world with the run's forces
        (``stepping.bare_seconds``); for a whole-run adapter, the run's own stepping time (what the base timed
        inside its generator). An adapter overrides it only for a loop the base cannot time (MuJoCo Warp's
        captured graphs with nothing read back)."""
        if self.steps():
            return stepping_bare_seconds(self, scene, settings, traj)
        return traj.wall_time

    @classmethod
    def steps(cls) -> bool:
        """Whether the adapter writes ``build`` and ``step`` (the base's step loop runs it)."""
        return cls.build is not EngineAdapter.build and cls.step is not EngineAdapter.step

    @classmethod
    def whole_runs(cls) -> bool:
        """Whether the adapter writes ``samples``, a whole run at once (a fast path, or its only way)."""
        return cls.samples is not EngineAdapter.samples

    def settings(self, settings: Any = None) -> Any:
        """``settings``, or the defaults when None; SettingsError for another engine's settings."""
        if settings is None:
            return self.settings_type()
        if not isinstance(settings, self.settings_type):
            raise SettingsError(f"{self.name} settings: a {self.settings_type.__name__}, not {type(settings).__name__}")
        return settings

    def open(self, scene: Scene, settings: Any = None, compact_above: float | None = None) -> Recording:
        """Check the settings and start a run's recording (``MemoryError`` for a run that cannot fit)."""
        s = self.settings(settings)
        if scene.prescribed is not None and scene.body1_infinite and not self.whole_runs() and \
                type(self).drive is EngineAdapter.drive:
            raise SettingsError(f"engine {self.name!r} cannot move a prescribed body 1 (its adapter writes no drive); "
                                "give body 1 a finite mass or run another engine")
        self.validate(scene, s)
        record = {**settings_fields(s), **self.record(scene, s)}
        return Recording(self.name, scene, s, record, compact_above, self.contact_scales(scene, s))

    def run(self, scene: Scene, settings: Any = None, compact_above: float | None = None) -> Trajectory:
        """Simulate ``scene.duration`` seconds from ``scene.initial``; never raises for an engine failure.

        ``compact_above``: hand on a compact trajectory when the run has more samples than this
        (default ``window.COMPACT_ABOVE``; ``math.inf``: always full).

        Raises
        ------
        SettingsError
            Settings the scene cannot run with, before the engine starts.
        """
        s = self.settings(settings)
        if self.isolated and not inside():
            done = call_isolated(self.run, scene, s, compact_above, refused=SettingsError)
            if isinstance(done, Outcome):
                return failed_trajectory(self.name, scene, Status(done.status), _first_line(self.name, done), 
                                         dataclasses.asdict(s), done.wall_time)
            return done
        try:
            run = self.open(scene, s, compact_above)
        except MemoryError as exc:  # the samples of the run do not fit: a result
            record = {**dataclasses.asdict(s), **self.record(scene, s)}
            return failed_trajectory(self.name, scene, Status.ERROR, f"{self.name}: MemoryError: {exc}", record)
        return self.finish(run)

    def finish(self, run: Recording) -> Trajectory:
        """``simulate`` the run and classify it (the one place an engine failure is caught: callers such as
        ``compare`` catch nothing). A test-only fault (``faults.py``) is injected here, as the engine's own."""
        try:
            inject_planned(self.name, run.scene)
            self.simulate(run)
        except Exception as exc:  # noqa: BLE001  an engine failure is a result, not a crash
            return run.trajectory(exc)
        return run.trajectory()

    def run_batch(self, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
        """Run many (scene, settings) pairs; one trajectory per pair, in order (one by one unless the engine batches)."""
        return [self.run(scene, settings) for scene, settings in jobs]

    def iter_batch(self, jobs: Sequence[tuple[Scene, Any]]) -> Iterator[tuple[int, Trajectory]]:
        """``batch``'s (index in ``jobs``, trajectory) as they are done: an engine that runs a batch in parts (MuJoCo
        Warp: blocks within its host memory) yields each part when done. The base: ``batch`` at once."""
        yield from enumerate(self.batch(jobs))

    def forks(self, settings: Any) -> bool:
        """Whether a run at ``settings`` may be made in a fork of a process that ran the engine (a CUDA one: no)."""
        return True

    def unit_runs(self, settings: Any) -> int | None:
        """Runs a sweep hands the engine at once (MuJoCo Warp on a GPU: thousands); None: the sweep's own choice."""
        return None

    def batch(self, jobs: Sequence[tuple[Scene, Any]]) -> list[Trajectory]:
        """``run_batch``, or one isolated run after another for an ``isolated`` adapter (whose own batch would run in
        the command's process)."""
        if self.isolated:
            return EngineAdapter.run_batch(self, jobs)
        return self.run_batch(jobs)

    def benchmark(self, scene: Scene, settings: Any = None, n_steps: int = 20_000, repeats: int = 3) -> BenchmarkResult:
        """Steps per second of ``run`` and of the bare engine loop on the same run, ``n_steps`` steps (at most
        ``bench_step_cap``), the best of ``repeats`` each, interleaved (slower repeats measure the machine's
        other load, as ``timeit`` takes them), after a one-step run that pays the first-use costs.

        The adapter's figure is per step beyond a run's fixed cost (building the world, calibrating a
        contact: the time of a one-step run, ``details["fixed_s"]``), the raw loop's has none: the two
        compare the work each step costs.
        """
        check_integer("n_steps", n_steps, lo=1)
        check_integer("repeats", repeats, lo=1)
        s = self.settings(settings)
        if self.isolated and not inside():  # the whole benchmark in one child: its bare loop is the engine's too
            done = call_isolated(self.benchmark, scene, s, n_steps, repeats, refused=SettingsError)
            if isinstance(done, Outcome):
                return BenchmarkResult(self.name, scene.name, 0, repeats, math.nan, math.nan, Status(done.status),
                                       {"message": _first_line(self.name, done)})
            return done
        steps = min(n_steps, self.bench_step_cap or n_steps)
        short = dataclasses.replace(scene, duration=steps * s.dt)
        one = dataclasses.replace(scene, duration=s.dt)
        n = _count_steps(short.duration, s.dt)
        full = fixed = raw = math.inf
        self.run(one, s)  # first-use costs (imports, caches, kernel compilation) are no repeat's
        for _ in range(repeats):
            start = time.perf_counter()
            traj = self.run(short, s, compact_above=math.inf)
            full = min(full, time.perf_counter() - start)
            start = time.perf_counter()
            self.run(one, s)
            fixed = min(fixed, time.perf_counter() - start)
            raw = min(raw, self.bare_seconds(short, s, traj))
        adapter = full - fixed if full > 2.0 * fixed else full  # a fixed cost lost in the noise is not taken off
        details = {"fixed_s": fixed, **{k: v for k, v in traj.settings.items() if k in ("device", "precision")}}
        return BenchmarkResult(self.name, scene.name, n, repeats, n / adapter, n / raw, Status(traj.status), details)

    def version(self) -> str:
        """The engine package's version."""
        return version_of(self.package)


_fields_kept = functools.lru_cache(maxsize=256)(dataclasses.asdict)  # a batch's runs share a few settings objects


def settings_fields(settings: Any) -> dict[str, Any]:
    """``dataclasses.asdict(settings)``, a new dict each call, made once per (hashable) settings value."""
    try:
        return dict(_fields_kept(settings))
    except TypeError:  # unhashable settings (a list in a field): made each time
        return dataclasses.asdict(settings)


def _first_line(engine: str, outcome: Outcome) -> str:
    """A failed child's message in one line, naming the engine: ``pymunk: killed by SIGSEGV``."""
    lines = outcome.message.strip().splitlines()
    return f"{engine}: {lines[0] if lines else outcome.status}"


@functools.cache
def version_of(package: str) -> str:
    """The installed version of distribution ``package`` (cached: metadata lookups cost milliseconds)."""
    return package_version(package)
