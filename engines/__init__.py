"""Engine adapters: every engine of the table (seven built in, and plugins) runs the scenes behind one contract.

    >>> from chatterbench.engines import make_settings, run_engine
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = run_engine("mujoco", load_scene("bouncing-ball"), make_settings("mujoco", dt=1e-4))
    >>> traj.status
    'ok'

Each adapter builds a minimal 1-D model (slide/prismatic joints, no friction, no rotation)
from a ``Scene`` and returns a ``Trajectory``, behind one contract (``base.EngineAdapter``):
the base owns the run (forces, settings record, failure classes, divergence, recording,
benchmark), the adapter builds its world and steps it (``build``, ``step``), or runs a whole
run at once (``simulate``). The engines are one table (``registry.ENGINES``): seven built in
(``registry.BUILT_IN``: MuJoCo and PyBullet always; Drake, MuJoCo Warp, PhysX and DART with
their extras; Siconos with Debian's ``python3-siconos``) and any a plugin adds. To add an
engine: a package with a frozen settings dataclass (a checked ``dt``) and an ``EngineAdapter``
subclass, declared in the entry-point group ``chatterbench.engines`` of its own
``pyproject.toml``; ``examples/engine_plugin`` is such a package, complete, and the README's
"Write an engine plugin" says what it uses.
"""

from .base import BenchmarkResult, EngineAdapter, Recording, Status, n_steps, sample_times
from .registry import DEFAULT_ENGINES, ENGINE_NAMES, ENGINES, adapter, engine_version, make_settings, run_engine, run_engine_batch
from .trajectory import Trajectory

__all__ = ["DEFAULT_ENGINES", "ENGINES", "ENGINE_NAMES", "BenchmarkResult", "EngineAdapter", "Recording", "Status",
           "Trajectory", "adapter", "engine_version", "make_settings", "n_steps", "run_engine", "run_engine_batch",
           "sample_times"]
