"""What an engine adapter may do beyond running a scene: small protocols, each a capability the commands above use.

    >>> from chatterbench.engines.api import EngineAdapter, TuningSpace
    >>> from chatterbench.engines.capabilities import implemented
    >>> from chatterbench.engines.mujoco_engine import MujocoEngine
    >>> implemented(MujocoEngine), implemented(EngineAdapter)
    (('TuningSpace', 'ExportedModel', 'Snippet'), ())
    >>> isinstance(MujocoEngine(), TuningSpace)
    True

The core contract is ``base.EngineAdapter``'s: ``build`` and ``step`` (or ``samples``). Each
protocol here is optional: an adapter that implements one overrides the base's method with
the signature and units the protocol states, and the command that reads it (``tune``, ``run
--export-model``, ``calibrate``/``tune --out``) gets the engine's own answer. The base answers
each with "none" (no tuning space, no files, the settings object as the snippet), so the
commands call them on every adapter alike; ``implemented(cls)`` says which a class answers
itself, and the shipped contract suite (``contract_suite.py``) checks those answers' shapes.
The protocols are ``runtime_checkable``: ``isinstance(adapter, TuningSpace)`` checks the
methods are there (true of every adapter, through the base), not that the engine overrides
them (``implemented``).

The facts an adapter declares as class attributes (``compliant``, ``precision``,
``bytes_per_step``, ...) are checked when it is registered (``contract.py``); their units are
stated where the base declares them (``base.EngineAdapter``).
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol, runtime_checkable

from chatterbench.reference.scene import Scene


@runtime_checkable
class TuningSpace(Protocol):
    """What ``chatterbench tune`` searches for an engine (``comparisons/studies/tune.py``)."""

    def tuning_space(self, scene: Scene) -> dict[str, tuple] | None:
        """The candidates for ``scene``: ``"dt"`` -> steps [s] from coarse to fine (the ladder ``tune`` climbs), and
        ``"ENGINE.FIELD"`` -> values of that settings field in the field's own unit (the field comment's), the
        default first. None: the engine declares none (``tune`` then needs ``--space``)."""
        ...


@runtime_checkable
class ExportedModel(Protocol):
    """A scene as files that run in the engine alone (``run --export-model``, ``tune --out``)."""

    exports: ClassVar[tuple[str, ...]]  # the files' names, the model file first ("model.xml", "run.py")
    export_kind: ClassVar[str]  # what the model file is, for messages: "an MJCF model"

    def export(self, scene: Scene, settings: Any, command: str | None = None) -> dict[str, str]:
        """File name (each of ``exports``) -> text: ``scene`` at ``settings`` in the engine's own format, SI units
        (m, kg, s, N), which run without chatterbench and print one line per impact (``impact_lines``: time [s],
        wall, speeds before and after [m/s]); ``command``, the command that wrote them, kept in them."""
        ...


@runtime_checkable
class Snippet(Protocol):
    """The settings as a user pastes them into their own model (``tune --out``, ``calibrate``)."""

    def snippet(self, scene: Scene, settings: Any) -> str:
        """Text in the engine's own language (MJCF, Python) setting what ``settings`` set for ``scene``: the step
        [s] and the contact parameters in the engine's units, with a comment naming the scene."""
        ...


CAPABILITIES: dict[str, tuple[type, tuple[str, ...]]] = {  # name -> (protocol, the methods that implement it)
    "TuningSpace": (TuningSpace, ("tuning_space",)),
    "ExportedModel": (ExportedModel, ("export",)),
    "Snippet": (Snippet, ("snippet",)),
}


def implemented(cls: type) -> tuple[str, ...]:
    """The capabilities adapter class ``cls`` answers itself (its methods, not the base's "none"), in
    ``CAPABILITIES``' order."""
    from .base import EngineAdapter

    return tuple(name for name, (_, methods) in CAPABILITIES.items()
                 if all(getattr(cls, m, None) is not getattr(EngineAdapter, m) for m in methods))
