"""Feigin's sliding model (1967) as an exact, event-driven reference simulator.

    >>> from chatterbench.reference import load_scene, simulate
    >>> result = simulate(load_scene("feigin-pair"))
    >>> result.episodes[["wall", "t_stick", "t_exit"]].head(2).round(4).values.tolist()
    [['lower', 1.5977, 3.1416], ['upper', 5.0682, 6.2832]]

This package imports no engine: it is the physics the engines are judged against.
"""

from .scene import Force, Gap, Initial, Prescribed, Scene, SceneError, load_scene, scene_from_dict

__all__ = ["Force", "Gap", "Initial", "Prescribed", "Scene", "SceneError", "load_scene", "scene_from_dict"]

from .simulate import Options, Result, simulate  # noqa: E402

__all__ += ["Options", "Result", "simulate"]
