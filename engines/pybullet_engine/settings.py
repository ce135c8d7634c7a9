"""PyBullet's settings for a scene: the engine parameters that change a bounce, and the calls that set them.

    >>> from chatterbench.engines.pybullet_engine.settings import PybulletSettings, settings_snippet
    >>> PybulletSettings().restitution_velocity_threshold       # PyBullet's own default is 0.2 m/s
    0.0
    >>> [line for line in settings_snippet(PybulletSettings()).splitlines() if line.startswith("p.change")][0]
    'p.changeDynamics(BALL_ID, BALL_LINK,'

Every field is checked when the settings are made (``SettingsError`` naming the field, the
value and the allowed range).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from chatterbench.reference.errors import check_bool, check_integer, check_number

from ..settings import SettingsError
from .bullet import p


@dataclass(frozen=True)
class PybulletSettings:
    """PyBullet parameters that change a bounce, under snake_case versions of PyBullet's names.

    The defaults make one impact follow Newton's law with the scene's R. PyBullet's own
    defaults, and what each does to the bounce sequence, are listed in the comments.
    """

    dt: float = 1e-4  # fixedTimeStep [s], > 0
    # Relative normal speed [m/s] below which restitution is zero (PyBullet: 0.2). Bounces
    # slower than this stick at once: the bouncing ball rests at 1.33 s, before its Zeno
    # time 1.355 s, and the feigin-pair chatter becomes a few plastic impacts.
    restitution_velocity_threshold: float = 0.0
    # Distance [m] below which a contact point enters the solver (PyBullet: 1e30, every point
    # the narrowphase reports). Meant to keep "speculative" points of bodies still apart out of
    # the solver; this sphere-on-box model reports none (checked up to 0.1 m), so here it
    # changes nothing, but 0 keeps it safe for other shapes.
    contact_processing_threshold: float = 0.0
    # Baumgarte factor pushing penetrating contacts apart, 0..1 (PyBullet: 0.2). Above 0 the
    # push adds separating speed contact_erp * depth / dt on top of R: a 1 m/s impact at
    # dt = 1e-4 (depth 1e-4 m) rebounds with 0.70 instead of R = 0.5.
    contact_erp: float = 0.0
    # Penetration [m] the solver tolerates (PyBullet: 1e-5). Bounces whose one-step
    # penetration is near this size lose their rebound: from the 4th impact on the bouncing
    # ball lands early (by 8 ms, then 12, 31 ms) and comes to rest at 1.30 s, before Zeno.
    contact_slop: float = 0.0
    # Share of the last step's contact impulse used as the solver's start, 0..1 (PyBullet:
    # 0.85). Can carry a bounce's impulse into the next step; with these prismatic multibodies
    # it changed nothing measurable (identical trajectories), 0 keeps it out of the question.
    warm_starting_factor: float = 0.0
    num_solver_iterations: int = 50  # numSolverIterations, >= 1 (PyBullet: 50)
    solver_residual_threshold: float = 1e-7  # solverResidualThreshold, >= 0 (PyBullet: 1e-7)
    erp: float = 0.2  # joint (non-contact) error reduction, 0..1 (PyBullet: 0.2)
    use_split_impulse: bool = True  # useSplitImpulse (PyBullet: True)
    split_impulse_penetration_threshold: float = -0.04  # [m], <= 0 (PyBullet: -0.04)
    contact_breaking_threshold: float = 0.02  # distance [m] a manifold point survives, > 0
    # Joint speed clamp [m/s] (PyBullet's maxJointVelocity: 100). Velocities above it are cut
    # silently, so free flight faster than 100 m/s would be wrong; 1e10 means no clamp.
    max_joint_velocity: float = 1e10
    mass1_inf: float = 1e6  # mass [kg] standing in for a prescribed infinite body 1, > 0

    def __post_init__(self) -> None:
        def number(name: str, **limits) -> None:
            object.__setattr__(self, name, check_number(f"pybullet.{name}", getattr(self, name), error=SettingsError, **limits))

        number("dt", lo=0.0, lo_open=True, unit=" [s]")
        number("restitution_velocity_threshold", lo=0.0, unit=" [m/s]")
        number("contact_processing_threshold", lo=0.0, unit=" [m]")
        number("contact_erp", lo=0.0, hi=1.0)
        number("contact_slop", lo=0.0, unit=" [m]")
        number("warm_starting_factor", lo=0.0, hi=1.0)
        check_integer("pybullet.num_solver_iterations", self.num_solver_iterations, lo=1, error=SettingsError)
        number("solver_residual_threshold", lo=0.0)
        number("erp", lo=0.0, hi=1.0)
        check_bool("pybullet.use_split_impulse", self.use_split_impulse, error=SettingsError)
        number("split_impulse_penetration_threshold", hi=0.0, unit=" [m]")
        number("contact_breaking_threshold", lo=0.0, lo_open=True, unit=" [m]")
        number("max_joint_velocity", lo=0.0, lo_open=True, unit=" [m/s]")
        number("mass1_inf", lo=0.0, lo_open=True, unit=" [kg]")

    def engine_parameters(self) -> dict[str, Any]:
        """Keyword arguments for ``p.setPhysicsEngineParameter``."""
        return {
            "fixedTimeStep": self.dt,
            "numSubSteps": 0,
            "numSolverIterations": self.num_solver_iterations,
            "solverResidualThreshold": self.solver_residual_threshold,
            "restitutionVelocityThreshold": self.restitution_velocity_threshold,
            "erp": self.erp,
            "contactERP": self.contact_erp,
            "contactSlop": self.contact_slop,
            "warmStartingFactor": self.warm_starting_factor,
            "useSplitImpulse": int(self.use_split_impulse),
            "splitImpulsePenetrationThreshold": self.split_impulse_penetration_threshold,
            "contactBreakingThreshold": self.contact_breaking_threshold,
        }

    def dynamics(self, restitution: float) -> dict[str, Any]:
        """Keyword arguments for ``p.changeDynamics`` on a colliding link.

        ``maxJointVelocity`` is not among them: PyBullet 3.2.7 then drops the restitution
        (rebound 0); it goes in a call of its own, ``joint_limits``.
        """
        return {
            "restitution": restitution,
            "lateralFriction": 0.0,
            "rollingFriction": 0.0,
            "spinningFriction": 0.0,
            "linearDamping": 0.0,
            "angularDamping": 0.0,
            "contactProcessingThreshold": self.contact_processing_threshold,
            # A sleeping body ignores small forces: a resting ball would not feel a later push.
            "activationState": p.ACTIVATION_STATE_DISABLE_SLEEPING,
        }


    def joint_limits(self) -> dict[str, Any]:
        """Keyword arguments for a separate ``p.changeDynamics`` call on each prismatic link."""
        return {"maxJointVelocity": self.max_joint_velocity}


PLACEHOLDERS = {
    "BALL_ID": "the body unique id of the moving body (what p.createMultiBody or p.loadURDF returned)",
    "BALL_LINK": "the link index of its colliding shape: -1 for a base body (a body without joints), else the "
                 "joint index of that link (p.getJointInfo lists them)",
    "WALL_ID": "the body unique id of what it strikes (a wall, the floor, the other body)",
    "WALL_LINK": "the link index of the wall's colliding shape: -1 for a base body, else its joint index",
}


def settings_snippet(settings: PybulletSettings, restitution: float = 0.5, names: dict[str, str] | None = None) -> str:
    """The PyBullet calls these settings make, as Python a user pastes into their own setup.

    ``names`` fills the placeholders (``PLACEHOLDERS``: the two bodies' ids and link indices; a
    wrong link index is ignored by PyBullet without a word, so the snippet says what goes there);
    without it the snippet keeps them and explains each. The combined restitution is the product
    of the two bodies' values, so the moving body carries R and the wall 1.
    """
    def call(fn: str, head: str, kwargs: dict[str, Any]) -> str:
        consts = {p.ACTIVATION_STATE_DISABLE_SLEEPING: "p.ACTIVATION_STATE_DISABLE_SLEEPING"}
        args = "".join(
            f"\n    {k}={consts[v] if k == 'activationState' else repr(v)}," for k, v in kwargs.items()
        )
        return f"p.{fn}({head}{args}\n)"

    n = {key: key for key in PLACEHOLDERS} | dict(names or {})
    ball, wall = f"{n['BALL_ID']}, {n['BALL_LINK']},", f"{n['WALL_ID']}, {n['WALL_LINK']},"
    head = [] if names else ["# Replace the placeholders before running:"] + [f"#   {k}: {v}" for k, v in PLACEHOLDERS.items()] + [
        "# PyBullet ignores a link index the body does not have, silently: check with",
        "#   p.getDynamicsInfo(BALL_ID, BALL_LINK)[5] == restitution after these calls."]
    return "\n".join(
        [
            "import pybullet as p",
            *head,
            "",
            call("setPhysicsEngineParameter", "", settings.engine_parameters()),
            call("changeDynamics", ball, settings.dynamics(restitution)),
            call("changeDynamics", wall, settings.dynamics(1.0)),
            "# separately: passed together with restitution, PyBullet 3.2.7 drops the restitution",
            call("changeDynamics", ball, settings.joint_limits()),
            call("changeDynamics", wall, settings.joint_limits()),
            "",
        ]
    )


def measurement() -> str:
    """Python that measures one impact's e = -v_out / v_in in the user's own setup (the body flying towards the
    wall; SPEED() its velocity along the wall's normal): the guide's check that the pasted settings give R."""
    return "\n".join([
        "pushed = lambda: any(c[9] > 0 for c in p.getContactPoints(BALL_ID, WALL_ID))  # normal force in the last step",
        "v_in = SPEED(); p.stepSimulation()",
        "while not pushed(): v_in = SPEED(); p.stepSimulation()  # fly to the wall",
        "while pushed(): p.stepSimulation()  # through the contact",
        'print("e =", -SPEED() / v_in)  # compare with R at this v_in',
        "# SPEED: e.g. lambda: p.getBaseVelocity(BALL_ID)[0][2] for a base body moving along z",
    ]) + "\n"
