"""What an engine plugin imports, all of it: the adapter base, a whole run's samples, the settings checks, the errors.

    >>> from dataclasses import dataclass
    >>> from chatterbench.engines.api import SettingsError, check_dt
    >>> @dataclass(frozen=True)
    ... class EulerSettings:
    ...     dt: float = 1e-4  # [s] the step
    ...     def __post_init__(self):
    ...         check_dt("euler", self.dt)
    >>> EulerSettings(dt=0)
    Traceback (most recent call last):
    chatterbench.engines.settings.SettingsError: euler.dt = 0: must be > 0 [s]

The contract (``base.EngineAdapter``, checked when the engine is registered, ``contract.py``):

- a frozen settings dataclass, every field with a default, its ``dt`` [s] checked when made
  (``check_dt``: ``dt`` <= 0 or NaN is a ``SettingsError`` naming the field and its range);
- an ``EngineAdapter`` subclass naming itself (``name``), the distribution whose version is
  reported (``package``) and its settings (``settings_type``), which writes either
  ``build(scene, settings) -> world`` and ``step(world, forces) -> (state, wall_forces)`` (a
  stepping engine: the base applies the forces, records, times and classifies), or
  ``samples(run)``, a generator of ``Samples`` (a whole-run engine: the base drives it, times
  it, records and classifies the same way);
- one entry point in the group ``chatterbench.engines`` of its ``pyproject.toml``.

Optional: the capabilities ``TuningSpace``, ``ExportedModel`` and ``Snippet`` (protocols, each
with its units), the class facts of ``EngineAdapter`` (``compliant``, ``precision``, ...), and
``Diverged``, ``Crashed`` or ``TimedOut`` raised to classify a failure the engine reports
itself. ``pytest --chatterbench-engine NAME`` runs the contract suite against the installed
engine (``contract_suite.py``); ``docs/how-to/plugin.md`` is the how-to.
"""

from .base import Crashed, Diverged, EngineAdapter, Recording, TimedOut
from .capabilities import ExportedModel, Snippet, TuningSpace
from .settings import SettingsError, check_choice, check_dt, check_integer, check_number
from .wholerun import Samples

__all__ = [
    "EngineAdapter", "Recording", "Samples",  # the adapter base; a whole-run engine's run and its chunks
    "SettingsError", "check_dt", "check_number", "check_integer", "check_choice",  # settings checked when made
    "Diverged", "Crashed", "TimedOut",  # failures an engine reports itself (any other exception: ``error``)
    "TuningSpace", "ExportedModel", "Snippet",  # optional capabilities
]
