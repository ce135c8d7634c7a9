"""Drake's settings for a scene: continuous (error-controlled integrator) or discrete (contact solver) time, and the contact.

    >>> from chatterbench.engines.drake_engine.settings import DrakeSettings
    >>> s = DrakeSettings(integrator="radau3", accuracy=1e-4)
    >>> s.mode, s.cost_lever
    ('continuous', 'accuracy')
    >>> DrakeSettings(mode="discrete", dt=1e-4).cost_lever
    'dt'

``dt`` means two things, one per mode. ``mode = "discrete"``: the plant's time step, one
sample per step (sample k is the state after k steps), the cost lever. ``mode =
"continuous"``: only the **output sampling interval** of the trajectory; the integrator
chooses its own steps to meet ``accuracy`` (capped by ``max_step``) and the samples at
t0 + k dt are interpolated between its steps (``run.py``): ``accuracy`` is the cost lever.

Every field is checked when the settings are made (``SettingsError`` naming the field, the
value and the allowed range), so Drake never starts with a user mistake.
"""

from __future__ import annotations

from dataclasses import dataclass

from chatterbench.reference.errors import check_choice, check_number

from ..settings import SettingsError

MODES = ("continuous", "discrete")
# Drake's error-controlled integration schemes (``SimulatorConfig.integration_scheme``); those the
# installed Drake lacks are dropped (CENIC, the convex integrator, is in 1.51.1). Not offered: the
# fixed-step ones (runge_kutta2, explicit and semi-explicit Euler step at max_step whatever the accuracy)
_WANTED = ("runge_kutta3", "runge_kutta5", "bogacki_shampine3", "radau1", "radau3", "implicit_euler",
           "velocity_implicit_euler", "cenic")
# discrete contact approximations (``MultibodyPlantConfig.discrete_contact_approximation``): "sap" is
# linear Kelvin-Voigt with a relaxation time; "tamsi", "similar", "lagged" use Hunt-Crossley's d
SOLVERS = ("sap", "tamsi", "similar", "lagged")
HUNT_CROSSLEY_SOLVERS = ("tamsi", "similar", "lagged")


def _installed_schemes() -> tuple[str, ...]:
    from pydrake.systems.analysis import GetIntegrationSchemes

    have = set(GetIntegrationSchemes())
    return tuple(s for s in _WANTED if s in have)


INTEGRATORS = _installed_schemes()


@dataclass(frozen=True)
class DrakeSettings:
    """How Drake runs a scene (Drake's own names where it has one); module docstring for ``dt``."""

    dt: float = 1e-4  # [s] > 0: output sampling interval (continuous) or plant time step (discrete)
    mode: str = "continuous"  # "continuous" (error-controlled integrator) or "discrete" (time-stepping contact solver)
    integrator: str = "runge_kutta3"  # continuous only: Drake's integration_scheme, one of INTEGRATORS
    accuracy: float = 1e-6  # continuous only: the integrator's target accuracy [-], in (0, 1)
    max_step: float = 1e-2  # continuous only: largest integrator step [s], > 0
    solver: str = "sap"  # discrete only: contact approximation, "sap", "tamsi", "similar" or "lagged"
    # Contact stiffness rule (contact.py): the contact lasts this fraction of the calibration
    # impact's flight time 2 v / |a| (w0 = pi / (ratio * 2 v / |a|)); 0.0035 gives the bouncing
    # ball w0 = 994 rad/s
    contact_time_ratio: float = 0.0035  # [-], > 0
    w0: float = 0.0  # [rad/s] >= 0: contact natural frequency; 0 = from contact_time_ratio
    calibration_speed: float = 0.0  # [m/s] >= 0: impact speed at which the contact gives R; 0 = the reference's first impact
    plastic_restitution: float = 0.01  # [-] in (0, 0.5]: the R a scene with R = 0 is run with (no finite dissipation is plastic)

    def __post_init__(self) -> None:
        def number(name: str, **limits) -> None:
            object.__setattr__(self, name, check_number(f"drake.{name}", getattr(self, name), error=SettingsError, **limits))

        number("dt", lo=0.0, lo_open=True, unit=" [s]")
        check_choice("drake.mode", self.mode, MODES, error=SettingsError)
        check_choice("drake.integrator", self.integrator, INTEGRATORS, error=SettingsError)
        number("accuracy", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
        number("max_step", lo=0.0, lo_open=True, unit=" [s]")
        check_choice("drake.solver", self.solver, SOLVERS, error=SettingsError)
        number("contact_time_ratio", lo=0.0, lo_open=True)
        number("w0", lo=0.0, unit=" [rad/s] (0: from contact_time_ratio)")
        number("calibration_speed", lo=0.0, unit=" [m/s] (0: the reference's first impact speed)")
        number("plastic_restitution", lo=0.0, hi=0.5, lo_open=True)

    @property
    def cost_lever(self) -> str:
        """The field that trades accuracy for cost: ``"accuracy"`` (continuous) or ``"dt"`` (discrete)."""
        return "accuracy" if self.mode == "continuous" else "dt"

    @property
    def unread(self) -> frozenset[str]:
        """The fields this mode does not read: the integrator's in discrete mode, the contact solver in continuous."""
        return frozenset(("integrator", "accuracy", "max_step")) if self.mode == "discrete" else frozenset(("solver",))

    @property
    def law(self) -> str:
        """The contact's dissipation law: ``"hunt_crossley"`` (continuous, TAMSI, similar, lagged) or
        ``"kelvin_voigt"`` (SAP's relaxation time)."""
        return "kelvin_voigt" if self.mode == "discrete" and self.solver == "sap" else "hunt_crossley"
