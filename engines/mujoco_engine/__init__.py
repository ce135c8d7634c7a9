"""The MuJoCo adapter: a scene as a two-slide-joint MjSpec model, rolled out with ``mujoco.rollout`` chunk by chunk.

    >>> from chatterbench.engines.mujoco_engine import MujocoEngine, MujocoSettings
    >>> from chatterbench.reference.scene import load_scene
    >>> traj = MujocoEngine().run(load_scene("bouncing-ball"), MujocoSettings(dt=1e-4, w0_dt=0.03))
    >>> traj.status, bool(traj.contact["lower"].any()), round(traj.settings["zeta"], 4)
    ('ok', True, 0.2553)

Modules: ``settings`` (``MujocoSettings``, the integrators' stability limits), ``model``
(the MjSpec model of a scene), ``run`` (the adapter: a whole run as rollout chunk by chunk,
batches; the base class records and classifies),
``snippet`` (the settings as MJCF attributes a user pastes: ``<option>``, joint limit, geom pair),
``export`` (the scene as a complete MJCF file and a runner script for plain MuJoCo).

The model (built with ``mujoco.MjSpec``; ``export_mjcf`` gives it as a complete MJCF file):

- ``body1`` on a slide joint ``x1`` along world x (finite mass); for ``mass1 = inf`` a
  static body at x1, or a mocap body when ``scene.prescribed`` moves it.
- ``body2`` a child of ``body1`` on a slide joint ``y``, so qpos = (x1, y) and y = x2 - x1
  is a coordinate, not a difference of two large numbers.
- The gap: ``gap_model = "limit"`` makes it the range of joint ``y`` (one limit row,
  ``jointlimitfrc`` sensor); ``"geom"`` puts box walls on body 1 and a sphere on body 2
  (a sphere so that a wall contact is one row: a box-box face contact gives four
  identical rows, which changes the effective impedance), read by ``contact`` sensors.
- No gravity, no friction (condim 1), contacts only wall-ball (contype/conaffinity);
  ``filterparent`` is disabled because the walls belong to body 2's parent.

Contact law. MuJoCo's direct ``solref = (-k, -b)`` with constant ``solimp`` d gives the
reference acceleration a_ref = -(b/d) v - (k/d^2) d r, and for one constraint row the
solver returns a = d a_ref + (1 - d) a_free, i.e. a = -b v - k r + (1 - d) a_free:
MuJoCo already divides by d (d = dmax) in the direct form. The one remaining scaling:
MuJoCo's regulariser uses an approximate diagA, so the realised d' = A / (A + efc_R)
differs from d (exactly equal for the joint limit, ~0.7% for the sphere-box contact);
``build`` measures d' on the compiled model and rescales solref by d / d'. The realised
relative oscillator is then x'' + 2 zeta w0 x' + w0^2 x = 0 for any impedance and either
gap model (both checked in the tests). What the impedance still does: external forces reach
the relative motion scaled by (1 - d) while the contact pushes, so a resting body sinks
(1 - d) a_free / w0^2, not a_free / w0^2. Here k = w0^2, b = 2 zeta w0 with
w0 = w0_dt / dt and zeta = ``damping_ratio_from_restitution(R)`` (force-only contact, so
R is not exp(-pi zeta / sqrt(1 - zeta^2))). The contact row is unilateral: the force is
clamped at zero, which is exactly where the force-only restitution ends the contact.

Forces (the scene's one force model, ``reference.forces.ForceModel``). Springs and dampers
become joint stiffness/damping/springref (body 1 on ``x1``,
coupling on ``y``) and a fixed tendon x2 = x1 + y (body 2 to ground). Constant and
harmonic forces become motor actuators on ``x1`` (F1 + F2) and ``y`` (F2 - F12) whose
controls are precomputed at t_k (the start of step k; the step midpoint for ``rk4``,
which holds ctrl over its stages). A prescribed body 1 enters the relative motion through
the exact inertial force -m2 x1''(t) on ``y``: MuJoCo gives mocap bodies zero velocity
and acceleration, so moving the mocap alone would leave y'' and the contact damping blind
to it. The mocap is still moved (through rollout's ``mjSTATE_MOCAP_POS`` controls) so the
model looks right; x1, v1 of an infinite body are reported from ``Prescribed.position`` /
``velocity``.

"""

from __future__ import annotations

from .export import export_mjcf
from .model import build, build_spec, controls
from .run import MujocoEngine, rollout_steps_per_s
from .settings import GAP_MODELS, INTEGRATORS, SOLVERS, MujocoSettings, stability_limit

__all__ = ["GAP_MODELS", "INTEGRATORS", "SOLVERS", "MujocoEngine", "MujocoSettings", "build", "build_spec", "controls",
           "export_mjcf", "rollout_steps_per_s", "stability_limit"]
