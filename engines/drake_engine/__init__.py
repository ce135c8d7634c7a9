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
calibration), ``model`` (the diagram), ``run`` (stepping, sampling, the bare loop).

Cost lever: ``accuracy`` in continuous mode (the integrator picks its steps; ``dt`` is
only the output sampling), ``dt`` in discrete mode.
"""

from __future__ import annotations

from typing import Any

from chatterbench.reference.scene import Scene

from ..base import EngineAdapter, Recording
from ..trajectory import Trajectory
from . import run as _run
from .contact import ContactLaw, contact_law
from .model import DrakeModel, build
from .settings import INTEGRATORS, MODES, SOLVERS, DrakeSettings

__all__ = ["INTEGRATORS", "MODES", "SOLVERS", "ContactLaw", "DrakeEngine", "DrakeModel", "DrakeSettings", "build",
           "contact_law", "run", "snippet"]


def snippet(scene: Scene, settings: DrakeSettings | None = None) -> str:
    """The contact and the time stepping these settings give ``scene``, as Python for the user's own plant."""
    s = settings or DrakeSettings()
    law = contact_law(scene, s)
    time_step = s.dt if s.mode == "discrete" else 0.0
    lines = [
        f"# Drake contact for scene {scene.name!r}: w0 = {law.w0:.6g} rad/s over reduced mass {law.mass:.6g} kg,",
        f"# calibrated for R = {law.restitution:g} at {law.calibration_speed:.6g} m/s ({law.law}).",
        "# Every wall-ball pair has k, d, tau: each of the two geometries gets 2 k, d and tau / 2.",
        "from pydrake.geometry import AddContactMaterial, ProximityProperties",
        "from pydrake.multibody.plant import CoulombFriction, MultibodyPlantConfig",
        "from pydrake.systems.analysis import SimulatorConfig",
        "",
        "props = ProximityProperties()",
        f"AddContactMaterial(dissipation={law.dissipation!r}, point_stiffness={2.0 * law.stiffness!r},",
        "                   friction=CoulombFriction(0.0, 0.0), properties=props)",
        f"props.AddProperty(\"material\", \"relaxation_time\", {0.5 * law.relaxation_time!r})",
        f"plant_config = MultibodyPlantConfig(time_step={time_step!r}, contact_model=\"point\",",
        f"                                    discrete_contact_approximation=\"{s.solver if time_step else ''}\",",
        "                                    adjacent_bodies_collision_filters=False)",
    ]
    if s.mode == "continuous":
        lines += [f"simulator_config = SimulatorConfig(integration_scheme=\"{s.integrator}\", accuracy={s.accuracy!r},",
                  f"                                   max_step_size={s.max_step!r}, use_error_control=True)"]
    return "\n".join(lines) + "\n"


class DrakeEngine(EngineAdapter):
    """Drake behind the engine contract (``base.EngineAdapter``): compliant Hunt-Crossley contact, float64."""

    name = "drake"
    package = "drake"
    settings_type = DrakeSettings
    compliant = True
    bytes_per_step = 250.0  # measured peak growth per sample, feigin-pair: 181 B (continuous, 4e5) and 214 B (discrete, 1e5)

    def simulate(self, run: Recording) -> None:
        """Build the diagram, advance it, hand on its samples (``run.simulate``)."""
        _run.simulate(run)

    def record(self, scene: Scene, settings: DrakeSettings) -> dict[str, Any]:
        """The cost lever and the contact law's name (the run adds the calibrated contact and the steps taken)."""
        return {"cost_lever": settings.cost_lever, "law": settings.law}

    def bare_seconds(self, scene: Scene, settings: DrakeSettings, traj: Trajectory) -> float:
        """Drake's own ``AdvanceTo`` on the same model, nothing recorded (``run.bare_seconds``)."""
        return _run.bare_seconds(scene, settings)

    def build(self, scene: Scene, settings: DrakeSettings | None = None) -> DrakeModel:
        """The scene's diagram and plant (``model.build``)."""
        return build(scene, settings)

    def snippet(self, scene: Scene, settings: DrakeSettings | None = None) -> str:
        """The contact properties and configs, as Python (``snippet``)."""
        return snippet(scene, settings)

    def tuning_space(self, scene: Scene) -> dict[str, tuple]:
        """dt from 1 ms down to 10 us (the sampling in continuous mode, the step in discrete mode); both
        modes; the integrator's accuracy; a softer and a stiffer contact. Defaults first."""
        base = DrakeSettings()
        return {"dt": (1e-3, 3e-4, 1e-4, 3e-5, 1e-5), "drake.mode": (base.mode, "discrete"),
                "drake.accuracy": (base.accuracy, 1e-4, 1e-8), "drake.contact_time_ratio": (base.contact_time_ratio, 0.001, 0.01)}

    def cost_lever(self, settings: DrakeSettings) -> str:
        """``"accuracy"`` in continuous mode, ``"dt"`` in discrete mode."""
        return settings.cost_lever


def run(scene: Scene, settings: DrakeSettings | None = None, compact_above: float | None = None) -> Trajectory:
    """``DrakeEngine().run``: one run, classified by the base (``base.EngineAdapter.run``)."""
    return DrakeEngine().run(scene, settings, compact_above)
