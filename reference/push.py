"""Which term of a scene accelerates the gap hardest: named when a run is too fast to judge.

    >>> from chatterbench.reference.push import fastest_push
    >>> from chatterbench.reference.scene import load_scene
    >>> fastest_push(load_scene("bouncing-ball"))[1]      # gravity, 9.81 m/s^2
    9.81
"""

from __future__ import annotations

from .scene import Scene


def fastest_push(scene: Scene) -> tuple[str, float]:
    """The scene's term that accelerates the gap y hardest: (its field, value and mass as text, |y''| it gives [m/s^2]).

    Each term alone, at the initial state: a constant or harmonic force F on a body of mass m gives |F| / m (on the
    coupling: |F| (1/m1 + 1/m2)), a spring its pull at the initial state, gravity |g| when body 1 does not fall with
    body 2, a prescribed body 1 amplitude omega^2; ("the scene", 0.0) when nothing pushes. Used to name the likely
    cause of a run too fast to judge.
    """
    x1, y = scene.initial.x1, scene.initial.y
    inverse = {"body1": 0.0 if scene.body1_infinite else 1.0 / scene.mass1, "body2": 1.0 / scene.mass2}
    inverse["coupling"] = inverse["body1"] + inverse["body2"]
    mass = {"body1": f"mass1 = {scene.mass1:g} kg", "body2": f"mass2 = {scene.mass2:g} kg",
            "coupling": f"mass1 = {scene.mass1:g} kg, mass2 = {scene.mass2:g} kg"}
    at = {"body1": x1, "body2": x1 + y, "coupling": y}
    terms = [("the scene", 0.0)]
    if scene.body1_infinite and scene.gravity:
        terms.append((f"gravity = {scene.gravity:g} m/s^2", abs(scene.gravity)))
    if scene.prescribed is not None:
        p = scene.prescribed
        terms.append((f"prescribed.amplitude = {p.amplitude:g} m at omega = {p.omega:g} rad/s", abs(p.amplitude) * p.omega * p.omega))
    for i, f in enumerate(scene.forces):
        name, unit, force = {"constant": ("value", "N", f.value), "harmonic": ("amplitude", "N", f.amplitude),
                             "spring": ("stiffness", "N/m", f.stiffness * (at[f.on] - f.rest)),
                             "damper": ("damping", "N s/m", 0.0)}[f.kind]
        terms.append((f"forces[{i}].{name} = {getattr(f, name):g} {unit} on {f.on} ({mass[f.on]})", abs(force) * inverse[f.on]))
    return max(terms, key=lambda term: term[1])
