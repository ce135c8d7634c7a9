"""Comparisons of engine trajectories with the reference: events, episodes, verdicts, reports.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import compare, reference_trajectory
    >>> scene = load_scene("bouncing-ball")
    >>> known = reference_trajectory(scene, dt=1e-3)              # the exact answer, sampled
    >>> compare(scene, engines=("pybullet",), trajectories={"pybullet": known}).table["verdict"].tolist()
    ['match']

The public entry points are loaded on first use, so importing one submodule does not load
the engines.
"""

from __future__ import annotations

import importlib

_PUBLIC = {
    "Comparison": "pipeline.compare", "compare": "pipeline.compare",
    "reference_trajectory": "pipeline.sampling", "Tolerances": "pipeline.tolerances",
    "judge_trajectory": "pipeline.trajectory_file", "trajectory_table": "pipeline.trajectory_file",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    if name in _PUBLIC:
        return getattr(importlib.import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
