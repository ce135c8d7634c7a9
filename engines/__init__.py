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
run at once (``samples``). The engines are one table (``registry.ENGINES``): seven built in
(``registry.BUILT_IN``: MuJoCo and PyBullet always; Drake, MuJoCo Warp, PhysX and DART with
their extras; Siconos with Debian's ``python3-siconos``) and any a plugin adds. To add an
engine: a package with a frozen settings dataclass (a checked ``dt``) and an ``EngineAdapter``
subclass, declared in the entry-point group ``chatterbench.engines`` of its own
``pyproject.toml``; it imports all it needs from ``api.py``, ``examples/engine_plugin`` is such a
package, complete, ``docs/how-to/plugin.md`` says what it uses, and ``pytest
--chatterbench-engine NAME`` runs the contract suite against it (``contract_suite.py``). The
public names here are loaded on first use.
"""

import importlib

_PUBLIC = {
    "BenchmarkResult": "base", "EngineAdapter": "base", "Recording": "base", "Status": "base", "n_steps": "base",
    "sample_times": "base", "Trajectory": "trajectory", "DEFAULT_ENGINES": "registry", "ENGINE_NAMES": "registry",
    "ENGINES": "registry", "adapter": "registry", "engine_version": "registry", "make_settings": "registry",
    "run_engine": "registry", "run_engine_batch": "registry",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):  # loaded on first use: the pytest plugin (``contract_suite``) imports nothing heavy
    if name in _PUBLIC:
        return getattr(importlib.import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
