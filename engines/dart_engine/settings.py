"""DART's settings for a scene: time step, LCP solver, collision detector, split impulse.

    >>> from chatterbench.engines.dart_engine.settings import DartSettings
    >>> s = DartSettings(dt=1e-3, lcp_solver="pgs")
    >>> s.lcp_solver, s.pgs_iterations, s.collision_detector
    ('pgs', 30, 'fcl')

Every field is checked when the settings are made (``SettingsError`` naming ``dart.FIELD``,
the value and the allowed range), so DART never starts with a user mistake. The values are
DART 6.20's own defaults but for ``dt`` (DART: 1e-3 s; 1e-4 s here, as the other rigid
engines): DART's defaults already give Newton's R on a single impact, provided the shapes
carry restitution (``world.py``: DART's per-shape default is 0, and the contact's coefficient
is the product of the two shapes'; the adapter puts R on body 2 and 1 on the walls).

What DART does not let Python set (compile-time ``#define`` constants of dartsim/dart's
``dart/constraint``: defined at the top of ``ContactConstraint.cpp`` in older releases and in
``ContactSurface.hpp`` since the contact surface handlers came, with the same values, and
applied in ``ContactConstraint::getInformation``):

- ``DART_BOUNCING_VELOCITY_THRESHOLD`` = 0.1 m/s: the restitution velocity R v_in is imposed
  only ``if (restitutionVel > DART_BOUNCING_VELOCITY_THRESHOLD)``; a slower rebound is
  dropped (e = 0, the body stays in contact). ``BOUNCE_THRESHOLD`` below; measured in
  ``tests/engines/test_dart.py`` both ways. It is a threshold on the rebound speed R v_in, not
  on the impact speed: with R = 0.5 impacts slower than 0.2 m/s stick.
- ``DART_MAX_BOUNCING_VELOCITY`` = 100 m/s: rebounds are capped there.
- ``DART_ERP`` = 0.01, ``DART_MAX_ERV`` = 1e-3 m/s: penetration is pushed out at most at
  1 mm/s (the ball's "rebound" after a dropped one: measured 0.65 and 1.0 mm/s at dt 1e-3
  and 1e-4).
- ``DART_CFM`` = 1e-5, added to the LCP's diagonal: e = R - (1 + R) 1e-5 (measured 0.499985
  for R = 0.5).
- ``DART_RESTITUTION_COEFF_THRESHOLD`` = 1e-3: a product of coefficients at or below it
  switches bounce off altogether.

Not settable from dartpy 6.20 either: the contact cap (``ConstraintSolver.getCollisionOption``
hands Python a copy, so ``maxNumContacts``, 1000, cannot be changed; one sphere on a box face
makes one contact anyway), and a second PGS solver (``PgsBoxedLcpSolver`` has no Python
constructor: ``lcp_solver = "pgs"`` promotes DART's own fallback instance, which then leaves no
fallback).
"""

from __future__ import annotations

from dataclasses import dataclass

from chatterbench.reference.errors import check_bool, check_choice, check_integer, check_number

from ..settings import SettingsError

LCP_SOLVERS = ("dantzig", "pgs")  # BoxedLcpConstraintSolver's primary solver: DantzigBoxedLcpSolver, PgsBoxedLcpSolver
COLLISION_DETECTORS = ("fcl", "dart", "bullet", "ode")  # World.setCollisionDetector: FCL (DART's default), DART's own, ...
BOUNCE_THRESHOLD = 0.1  # [m/s] DART_BOUNCING_VELOCITY_THRESHOLD: a rebound R v_in at or below it is dropped (module docstring)
MAX_BOUNCE_SPEED = 100.0  # [m/s] DART_MAX_BOUNCING_VELOCITY: rebounds are capped there


@dataclass(frozen=True)
class DartSettings:
    """How DART runs a scene (DART's defaults beside each field; module docstring for what is fixed)."""

    dt: float = 1e-4  # World.setTimeStep [s], > 0 (DART: 1e-3)
    lcp_solver: str = "dantzig"  # primary boxed LCP solver, "dantzig" or "pgs" (DART: dantzig)
    pgs_fallback: bool = True  # with dantzig: PGS as the secondary solver when Dantzig fails (DART: True)
    pgs_iterations: int = 30  # PgsBoxedLcpSolverOption.mMaxIteration of every PGS solver, >= 1 (DART: 30)
    collision_detector: str = "fcl"  # "fcl", "dart", "bullet" or "ode" (DART: fcl)
    split_impulse: bool = False  # ConstraintSolver.setSplitImpulseEnabled: penetration fixed by positions (DART: False)

    def __post_init__(self) -> None:
        check_number("dart.dt", self.dt, lo=0.0, lo_open=True, unit=" [s]", error=SettingsError)
        object.__setattr__(self, "dt", float(self.dt))
        check_choice("dart.lcp_solver", self.lcp_solver, LCP_SOLVERS, error=SettingsError)
        check_bool("dart.pgs_fallback", self.pgs_fallback, error=SettingsError)
        check_integer("dart.pgs_iterations", self.pgs_iterations, lo=1, error=SettingsError)
        check_choice("dart.collision_detector", self.collision_detector, COLLISION_DETECTORS, error=SettingsError)
        check_bool("dart.split_impulse", self.split_impulse, error=SettingsError)


def settings_snippet(settings: DartSettings, restitution: float = 0.5) -> str:
    """The dartpy calls these settings make, for a user's own ``world`` and colliding shape nodes (``BALL``,
    ``WALL``): the restitution is the product of the two shapes' coefficients, so the moving one carries R."""
    s = settings
    if s.lcp_solver == "pgs":  # DART's fallback PGS instance becomes the primary (no Python constructor)
        solver = ["pgs = solver.getSecondaryBoxedLcpSolver()", "solver.setSecondaryBoxedLcpSolver(None)",
                  "solver.setBoxedLcpSolver(pgs)"]
    else:
        solver = ["pgs = solver.getSecondaryBoxedLcpSolver()"] + ([] if s.pgs_fallback else
                                                                   ["solver.setSecondaryBoxedLcpSolver(None)"])
    return "\n".join([
        "import dartpy as dart",
        "# world: your dart.simulation.World; BALL, WALL: the two colliding ShapeNodes",
        f"world.setTimeStep({s.dt!r})",
        f"world.setCollisionDetector(dart.collision.{_DETECTOR_CLASSES[s.collision_detector]}())",
        "solver = world.getConstraintSolver()",
        "option = dart.constraint.PgsBoxedLcpSolverOption()",
        f"option.mMaxIteration = {s.pgs_iterations!r}",
        *solver,
        "pgs.setOption(option)",
        f"solver.setSplitImpulseEnabled({s.split_impulse!r})",
        f"for node, r in ((BALL, {restitution!r}), (WALL, 1.0)):  # DART multiplies the two; a shape's default is 0",
        "    node.getDynamicsAspect().setRestitutionCoeff(r)",
        "    node.getDynamicsAspect().setFrictionCoeff(0.0)",
        f"# fixed in DART's source: a rebound R v_in <= {BOUNCE_THRESHOLD} m/s is dropped (e = 0)",
        "",
    ])


_DETECTOR_CLASSES = {"fcl": "FCLCollisionDetector", "dart": "DARTCollisionDetector",
                     "bullet": "BulletCollisionDetector", "ode": "OdeCollisionDetector"}
