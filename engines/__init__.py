"""Engine adapters: MuJoCo and PyBullet run the reference's scenes with Newton restitution R.

    >>> from chatterbench.engines import make_settings, run_engine
    >>> traj = run_engine("mujoco", load_scene("bouncing-ball"), make_settings("mujoco", dt=1e-4))
    >>> traj.status
    'ok'

Each adapter builds a minimal 1-D model (slide/prismatic joints, no friction, no rotation)
from a ``Scene`` and returns a ``Trajectory``, behind one contract (``base.EngineAdapter``).
To add an engine: a package beside ``mujoco_engine`` with its settings dataclass and an
``EngineAdapter`` subclass, and one line in ``registry._ADAPTERS``.
"""

from .base import EngineAdapter, n_steps, sample_times
from .registry import DEFAULT_ENGINES, ENGINE_NAMES, adapter, engine_version, make_settings, run_engine, run_engine_batch
from .trajectory import Trajectory

__all__ = ["DEFAULT_ENGINES", "ENGINE_NAMES", "EngineAdapter", "Trajectory", "adapter", "engine_version", "make_settings", "n_steps",
           "run_engine", "run_engine_batch", "sample_times"]
