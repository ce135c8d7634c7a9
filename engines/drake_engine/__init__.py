"""The Drake adapter: a scene as a MultibodyPlant with compliant point contact, run continuous or discrete.

    >>> from chatterbench.engines.drake_engine import DrakeEngine, DrakeSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = DrakeEngine().run(load_scene("bouncing-ball", ["duration=0.6"]), DrakeSettings(dt=1e-3))
    >>> traj.status, round(traj.contact_frequency), DrakeEngine().cost_lever(DrakeSettings())
    ('ok', 994, 'accuracy')

Drake's point contact is compliant: Hunt-Crossley f = k x (1 + d x') in continuous time
(and the TAMSI / similar / lagged discrete approximations), a linear Kelvin-Voigt spring with
a relaxation time in discrete SAP. Neither has a coefficient of restitution: the stiffness
comes from the scene's scales and the dissipation is calibrated so that one impact at a
stated speed rebounds with the scene's R (``contact.py``); Hunt-Crossley rebounds depend on
the impact speed (``hunt_crossley.py``), so the other impacts of a run do not give R.

Modules: ``settings`` (``DrakeSettings``: mode, integrator and accuracy, or time step and
solver), ``hunt_crossley`` (rebound of the contact law), ``contact`` (stiffness rule and
calibration), ``model`` (the diagram), ``run`` (the adapter: a whole run at once, its samples,
the bare loop; the snippet).

Cost lever: ``accuracy`` in continuous mode (the integrator picks its steps; ``dt`` is
only the output sampling), ``dt`` in discrete mode.
"""

from __future__ import annotations

from .contact import ContactLaw, contact_law
from .model import DrakeModel, build
from .run import DrakeEngine, snippet
from .settings import INTEGRATORS, MODES, SOLVERS, DrakeSettings

__all__ = ["INTEGRATORS", "MODES", "SOLVERS", "ContactLaw", "DrakeEngine", "DrakeModel", "DrakeSettings", "build",
           "contact_law", "snippet"]
