"""Engine adapters: MuJoCo and PyBullet run the reference's scenes with Newton restitution R.

    >>> from chatterbench.engines import run_engine
    >>> traj = run_engine("mujoco", scene, dt=1e-4)

Each adapter builds a minimal 1-D model (slide/prismatic joints, no friction, no rotation)
from a ``Scene`` and returns a ``Trajectory``.
"""

from .trajectory import Engine, Trajectory

__all__ = ["Engine", "Trajectory"]
