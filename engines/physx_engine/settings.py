"""PhysX's settings for a scene (through SAPIEN 3): the knobs that change a bounce, each checked when made.

    >>> from chatterbench.engines.physx_engine.settings import PhysxSettings
    >>> PhysxSettings().bounce_threshold                      # PhysX's (and SAPIEN's) own default is 2.0 m/s
    0.001
    >>> PhysxSettings(enable_tgs=False).enable_tgs            # the PGS solver instead of TGS
    False

Every field is checked when the settings are made (``SettingsError`` naming the field as
``physx.FIELD``, the value and the allowed range). Where each one goes in SAPIEN: the scene
fields (``bounce_threshold``, ``enable_tgs``, ``enable_pcm``) into ``sapien.physx.set_scene_config``
before the scene's ``PhysxCpuSystem`` is made (``world.scene_config``); the body fields
(iterations, ``sleep_threshold``) onto each rigid body; the shape fields (``contact_offset``,
``rest_offset``) onto each collision shape.
"""

from __future__ import annotations

from dataclasses import dataclass

from chatterbench.reference.errors import check_bool, check_integer, check_number

from ..settings import SettingsError


@dataclass(frozen=True)
class PhysxSettings:
    """PhysX parameters that change a bounce, under SAPIEN's names (``PhysxSceneConfig``, ``PhysxBodyConfig``,
    ``PhysxShapeConfig``).

    The defaults make one impact follow Newton's law with the scene's R (within 1 %, see the
    tests). SAPIEN 3.0.3's own defaults (PhysX 5's but for the iterations) are in the comments.
    """

    dt: float = 1e-4  # the scene's timestep [s], > 0 (SAPIEN: 0.01)
    # Relative normal speed [m/s] below which an impact gets no restitution, > 0 (PhysX: 2.0).
    # At 2.0 the bouncing ball rebounds twice, its third impact (1.1 m/s) is plastic and it rests
    # at 1.1285 s instead of chattering up to its Zeno point 1.3546 s (README: PhysX departures).
    # 1e-3 m/s: every bounce the scenes reach keeps R, while a body resting on a wall under
    # gravity at dt <= 1e-4 (g dt = 1e-3 m/s) stays at rest.
    bounce_threshold: float = 1e-3
    # TGS (temporal Gauss-Seidel) rather than PGS (SAPIEN: True; PhysX's own PxSceneDesc: PGS).
    # PGS with a small bounce threshold never lets a resting body rest (README: PhysX departures).
    enable_tgs: bool = True
    enable_pcm: bool = True  # persistent contact manifolds (SAPIEN: True)
    # Per body, 1..255 (SAPIEN: 10; PhysX: 4). TGS runs its position iterations as substeps, and in a
    # resting contact between two moving bodies the relative speed then creeps up each step until it
    # passes the bounce threshold and bounces: feigin-pair at dt = 1e-3 is 13 matching episodes at 1
    # and endless at 2, 4 and 10 (README: PhysX departures).
    solver_position_iterations: int = 1
    solver_velocity_iterations: int = 1  # per body, 0..255 (SAPIEN: 1; PhysX: 1)
    # Sleep below this mass-normalised kinetic energy [m^2/s^2] (SAPIEN: 0.005). A sleeping body
    # is frozen: the chatter of a slow bounce would stop; 0 never sleeps.
    sleep_threshold: float = 0.0
    # Distance [m] at which PhysX makes a (speculative) contact for a shape pair, > rest_offset
    # (SAPIEN: 0.01). The solver keeps the bodies from closing more than the gap in a step.
    contact_offset: float = 0.01
    # Separation [m] at which two shapes touch, each shape's counting, >= 0 (SAPIEN: 0). The walls are
    # set back by twice this, so that the bodies still touch when y reaches the gap.
    rest_offset: float = 0.0

    def __post_init__(self) -> None:
        def number(name: str, **limits) -> None:
            object.__setattr__(self, name, check_number(f"physx.{name}", getattr(self, name), error=SettingsError, **limits))

        number("dt", lo=0.0, lo_open=True, unit=" [s]")
        number("bounce_threshold", lo=0.0, lo_open=True, unit=" [m/s]")
        check_bool("physx.enable_tgs", self.enable_tgs, error=SettingsError)
        check_bool("physx.enable_pcm", self.enable_pcm, error=SettingsError)
        check_integer("physx.solver_position_iterations", self.solver_position_iterations, lo=1, hi=255, error=SettingsError)
        check_integer("physx.solver_velocity_iterations", self.solver_velocity_iterations, lo=0, hi=255, error=SettingsError)
        number("sleep_threshold", lo=0.0, unit=" [m^2/s^2]")
        number("rest_offset", lo=0.0, unit=" [m]")
        number("contact_offset", lo=self.rest_offset, lo_open=True, unit=" [m]")

    def scene_config(self) -> dict[str, object]:
        """Keyword arguments for ``sapien.physx.set_scene_config`` (no gravity: the adapter applies every force)."""
        return {"bounce_threshold": self.bounce_threshold, "enable_tgs": self.enable_tgs, "enable_pcm": self.enable_pcm}

    def body_config(self) -> dict[str, object]:
        """Attributes set on each rigid dynamic body."""
        return {"solver_position_iterations": self.solver_position_iterations,
                "solver_velocity_iterations": self.solver_velocity_iterations,
                "sleep_threshold": self.sleep_threshold, "linear_damping": 0.0, "angular_damping": 0.0}

    def shape_config(self) -> dict[str, object]:
        """Attributes set on each collision shape."""
        return {"contact_offset": self.contact_offset, "rest_offset": self.rest_offset}
