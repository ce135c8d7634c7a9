"""Siconos's settings for a scene: the time step, Moreau-Jean's theta and the LCP solver of each step.

    >>> from chatterbench.engines.siconos_engine.settings import SiconosSettings
    >>> SiconosSettings().theta                  # Siconos's own default, MoreauJeanOSI(theta=0.5)
    0.5
    >>> SiconosSettings(theta=1.0).theta
    1.0

Every field is checked when the settings are made (``SettingsError`` naming ``siconos.FIELD``,
the value and the allowed range), so the child never starts with a user mistake.
"""

from __future__ import annotations

from dataclasses import dataclass

from chatterbench.reference.errors import check_choice, check_number

from ..settings import SettingsError

# The LCP solvers offered (Siconos's numerics names in ``child.SOLVERS``); Siconos's ``LCP()`` default is Lemke.
SOLVERS = ("lemke", "enum", "pgs", "nsgs")


@dataclass(frozen=True)
class SiconosSettings:
    """How Siconos steps a scene: Moreau-Jean time stepping with Newton's impact law and one LCP per step.

    Siconos's own defaults are kept where they give R on every impact; each comment says.
    """

    dt: float = 1e-4  # the time step [s], > 0 (TimeDiscretisation); the cost lever
    # Moreau-Jean's theta in [0, 1] (MoreauJeanOSI(theta); Siconos's default 0.5). The velocity
    # obeys Newton's law v+ = -R v- exactly for any theta; theta weighs the step's forces and the
    # position update q+ = q + dt ((1 - theta) v + theta v+): 0.5 is second order in free flight
    # and puts each rebound where the exact one is (bouncing ball: last lift-off 1.3534 s at dt 1e-4
    # against the Zeno point 1.3546 s); 1 moves each impact step with the rebound speed alone, so the
    # ball rebounds from a step and a half early and keeps bouncing past Zeno (1.3561 s; README)
    theta: float = 0.5
    solver: str = "lemke"  # the LCP solver of each step, one of SOLVERS (Siconos's LCP() default: lemke)
    tolerance: float = 1e-12  # the LCP solver's tolerance [-], > 0 and < 1 (Siconos's default 1e-6)

    def __post_init__(self) -> None:
        def number(name: str, **limits) -> None:
            object.__setattr__(self, name, check_number(f"siconos.{name}", getattr(self, name), error=SettingsError, **limits))

        number("dt", lo=0.0, lo_open=True, unit=" [s]")
        number("theta", lo=0.0, hi=1.0)
        check_choice("siconos.solver", self.solver, SOLVERS, error=SettingsError)
        number("tolerance", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
