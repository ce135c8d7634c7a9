"""A scene file's constant force that is a body's weight, m g, read as the scene's ``gravity``: the force then follows the mass.

    >>> from chatterbench.reference.scene import scene_from_dict
    >>> from chatterbench.reference.weight import weights_as_gravity
    >>> ball = {"mass1": "inf", "mass2": 2.0, "restitution": 0.5, "gap": {"lower": 0.0},
    ...         "forces": [{"kind": "constant", "on": "body2", "value": -19.62}], "initial": {"y": 1.0}}
    >>> data, notes = weights_as_gravity(ball, scene_from_dict)
    >>> data["gravity"], data["forces"]
    (-9.81, [])
    >>> print(notes[0])
    forces[0]: constant -19.62 N on body2 (mass2 2 kg) read as gravity = -9.81 m/s^2 (the force now follows the mass)

Scene files written before the scene had ``gravity`` give it as a ``constant`` force of m g
on the body. That force stays what it was when the mass is changed (``--set mass2=0.2``: a
0.2 kg ball under 9.81 N falls at 49 m/s^2), which is never what the file meant. The loader
(``scene.load_scene``, TOML files only, before the overrides) reads such a force as
``gravity`` when it is one:

- the file sets no ``gravity`` of its own (then its constant forces are forces), and is a
  valid scene as written (else it is refused later, by name, with the overrides applied);
- every body that moves has one: body 2, and body 1 when ``mass1`` is finite (an infinite
  body 1 is kinematic), each a ``constant`` force equal to its mass times g, with one g of
  ``STANDARD_G`` (either sign) for all of them, to ``MATCH_RTOL`` relative. A weight on body 2
  alone over a finite body 1 is not gravity (body 1 would fall too): it stays a force.

Promises: the first such force on each body is removed and ``gravity`` set to that g; every
other force is kept, in its order; one note per removed force, made of numbers and fixed
words only (never text from the file). The forces' sum changes by at most ``MATCH_RTOL``
relative (the standard g replaces value / m).
"""

from __future__ import annotations

import copy
from typing import Any, Callable, Mapping

from .errors import InputError

STANDARD_G = (9.81, 9.80665)  # [m/s^2] the values of g a weight is written with (rounded, and the standard one)
MATCH_RTOL = 1e-9  # [-] |value - m g| <= MATCH_RTOL |m g|: the force is that body's weight


def _weight_index(forces: tuple, body: str, mass: float, g: float) -> int | None:
    """Index of the first constant force on ``body`` equal to ``mass`` [kg] times ``g`` [m/s^2], or None."""
    w = mass * g
    for i, f in enumerate(forces):
        if f.kind == "constant" and f.on == body and abs(f.value - w) <= MATCH_RTOL * abs(w):
            return i
    return None


def weights_as_gravity(data: Mapping[str, Any], build: Callable[[Mapping[str, Any]], Any]
                       ) -> tuple[dict[str, Any], tuple[str, ...]]:
    """Scene data (the TOML layout) with its weights read as ``gravity`` (module docstring), and the notes saying so.

    ``build`` validates the data as written into a ``Scene`` (``scene.scene_from_dict``; passed in, since the
    scene's loader calls this). Returns a copy of ``data`` (unchanged where nothing is a weight) and one note per
    force read as gravity.
    """
    out = copy.deepcopy(dict(data))
    if "gravity" in data:
        return out, ()
    try:
        scene = build(data)
    except InputError:
        return out, ()
    moving = [("body2", "mass2", scene.mass2)] + ([] if scene.body1_infinite else [("body1", "mass1", scene.mass1)])
    for g in (-STANDARD_G[0], -STANDARD_G[1], STANDARD_G[0], STANDARD_G[1]):
        found = {body: _weight_index(scene.forces, body, mass, g) for body, _, mass in moving}
        if all(i is not None for i in found.values()):
            break
    else:
        return out, ()
    notes = tuple(f"forces[{found[body]}]: constant {scene.forces[found[body]].value:.10g} N on {body} "
                  f"({name} {mass:.10g} kg) read as gravity = {g:.10g} m/s^2 (the force now follows the mass)"
                  for body, name, mass in sorted(moving, key=lambda b: found[b[0]]))
    out["forces"] = [f for i, f in enumerate(out.get("forces", [])) if i not in found.values()]
    out["gravity"] = g
    return out, notes
