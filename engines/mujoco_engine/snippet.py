"""MuJoCo settings as a user pastes them into their own MJCF: ``<option>``, a joint limit and a geom pair.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.engines.mujoco_engine.snippet import contact_law, mjcf_snippet, MujocoSettings
    >>> law = contact_law(load_scene("feigin-pair"), MujocoSettings(dt=1e-4, w0_dt=0.1))
    >>> law.solref, law.solimp                       # MuJoCo's direct form: (-K, -B) and a constant impedance
    ('-1000000 -510.55127529707534', '0.99 0.99 0.001 0.5 2')
    >>> [line.split()[0] for line in mjcf_snippet(load_scene("feigin-pair"), MujocoSettings()).splitlines()
    ...  if line.startswith("<") and not line.startswith("<!--")]
    ['<option', '<joint', '<pair']

Promises: the numbers are the ones ``build`` puts in the scene's own model (the same
``build_spec``), written so that they read back to the same doubles, so the pasted law is the
tuned law bit for bit (chatter amplifies a change in the 10th digit of B into another last bounce): the
joint limit's ``solreflimit`` is exactly (-w0^2, -2 zeta w0) (for a joint limit MuJoCo's
regulariser is exact); the pair's ``solref`` carries the model's impedance correction d / d'
(``model._impedance_factor``) for a sphere on a box with the scene's masses, so in a model with
other bodies it is right to that factor (0.7% at d = 0.99). Every other line is an XML comment.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from chatterbench.reference.scene import Scene

from ..export import printable
from .export import comment_text
from .model import build_spec
from .settings import SOLVERS, MujocoSettings

# MJCF's spelling of each integrator (``<option integrator=...>``)
MJCF_INTEGRATORS = {"euler": "Euler", "implicitfast": "implicitfast", "rk4": "RK4"}
DEFAULT_SOLVER = next(iter(SOLVERS))  # MuJoCo's own default, left out of <option>


def _num(v: float) -> str:
    """A number as MJCF text that reads back to the same double (``repr``; ``to_xml`` keeps 6 digits)."""
    v = float(v)
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def _vec(values) -> str:
    return " ".join(_num(v) for v in values)


@dataclass(frozen=True)
class ContactLaw:
    """The tuned contact as MJCF attribute values and what they mean (units in the field comments)."""

    solref: str  # "-K -B" for the joint limit (direct form)
    solimp: str  # "d d width midpoint power": constant impedance d
    pair_solref: str  # "-K' -B'": the geom pair's, with MuJoCo's impedance correction for a sphere on a box
    stiffness: float  # K = w0^2 [1/s^2]: contact acceleration per metre of penetration
    damping: float  # B = 2 zeta w0 [1/s]: contact acceleration per m/s of approach
    w0: float  # contact natural frequency [rad/s] = w0_dt / dt
    zeta: float  # contact damping ratio [-] that gives one impact Newton's R
    contact_time: float  # one bounce lasts about pi / (w0 sqrt(1 - zeta^2)) [s] (inf for zeta >= 1)
    pair_factor: float  # K' / K = d / d' [-]


def contact_law(scene: Scene, settings: MujocoSettings | None = None) -> ContactLaw:
    """The contact attributes ``build`` gives ``scene`` with ``settings`` (module docstring)."""
    s = settings or MujocoSettings()
    limit = build_spec(scene, dataclasses.replace(s, gap_model="limit")).joint("y")
    pair = build_spec(scene, dataclasses.replace(s, gap_model="geom")).geom("ball")
    zeta = s.zeta(scene.restitution)
    k, b = -float(limit.solref_limit[0]), -float(limit.solref_limit[1])
    ring = math.pi / (s.w0 * math.sqrt(1.0 - zeta * zeta)) if zeta < 1.0 else math.inf
    return ContactLaw(solref=_vec(limit.solref_limit), solimp=_vec(limit.solimp_limit), pair_solref=_vec(pair.solref),
                      stiffness=k, damping=b, w0=s.w0, zeta=zeta, contact_time=ring,
                      pair_factor=-float(pair.solref[0]) / k)


def option_line(settings: MujocoSettings) -> str:
    """``<option timestep=... integrator=...>`` (and the solver when it is not MuJoCo's default)."""
    solver = f' solver="{settings.solver}"' if settings.solver != DEFAULT_SOLVER else ""
    return f'<option timestep="{_num(settings.dt)}" integrator="{MJCF_INTEGRATORS[settings.integrator]}"{solver}/>'


PLACEHOLDERS = {
    "GAP_JOINT": "the name of your slide joint whose position is the gap y (the moving body's joint, relative to the "
                 "body that carries the walls or to the world); keep your joint's axis (with the geom pair the "
                 "moving body may be on a free joint instead: the check below measures along the contact normal)",
    "WALL_GEOM": "the name of your wall's geom (one <pair> per wall)",
    "BALL_GEOM": "the name of the moving body's geom that strikes it",
}


def mjcf_snippet(scene: Scene, settings: MujocoSettings | None = None) -> str:
    """What to paste into an MJCF model: the option line, the gap as a joint limit, the gap as a geom pair.

    The placeholders (``PLACEHOLDERS``: the gap's slide joint, the wall's and the moving body's
    geoms) are named in the text with what to put there; ``range`` is in the joint's own
    coordinate (the positions at which the bodies touch the walls). Keep one of the two forms.
    """
    s = settings or MujocoSettings()
    law = contact_law(scene, s)
    upper = scene.gap.upper
    rng = f"{_num(scene.gap.lower)} {_num(upper) if upper is not None else _num(scene.gap.lower + 1e9)}"
    contact_time = f"{law.contact_time:.3g} s ({law.contact_time / s.dt:.3g} timesteps)" if math.isfinite(law.contact_time) else "no rebound (overdamped)"
    walls = "the lower wall (and upper)" if upper is not None else "the wall"
    lines = [
        f"<!-- chatterbench: MuJoCo settings for scene {comment_text(printable(scene.name))} (Newton's R = "
        f"{scene.restitution:g}),",
        f"     timestep dt = {_num(s.dt)} s, contact stiffness w0 dt = {_num(s.w0_dt)}, integrator {s.integrator}.",
        '     solref="-K -B" is MuJoCo\'s direct form: the contact drives the relative acceleration to -K r - B v',
        "     (r the penetration [m], v its rate [m/s]), the same for any masses:",
        f"       K = w0^2 = {_num(law.stiffness)} 1/s^2, w0 = w0_dt / dt = {_num(law.w0)} rad/s, the contact's natural frequency;",
        f"       B = 2 zeta w0 = {_num(law.damping)} 1/s, zeta = {law.zeta:.6g}, the damping ratio whose single impact rebounds",
        f"       with R = {scene.restitution:g} (a force-only contact: it ends when the force reaches zero); one impact lasts {contact_time}.",
        f'     solimp="{law.solimp}": dmin = dmax = d = {_num(s.impedance)}, a constant impedance (width, midpoint and',
        "     power then do nothing); while the contact pushes, the other forces reach the gap scaled by 1 - d.",
        "     Replace the placeholders:",
        *[f"       {k}: {v}" for k, v in PLACEHOLDERS.items()],
        f'     range="{rng}": the positions of GAP_JOINT at which the bodies touch {walls} (this scene\'s gap; use yours). -->',
        option_line(s),
        "<!-- the gap as the range of your slide joint (the attributes after name go on your joint): -->",
        f'<joint name="GAP_JOINT" type="slide" axis="1 0 0" limited="true" range="{rng}" solreflimit="{law.solref}" '
        f'solimplimit="{law.solimp}"/>',
        f"<!-- or the gap as a geom pair (inside <contact>, once per wall; condim 1: no friction); K and B times {law.pair_factor:.6g},",
        "     MuJoCo's impedance correction d / d' for a sphere on a box with these masses: -->",
        f'<pair geom1="WALL_GEOM" geom2="BALL_GEOM" condim="1" margin="0" gap="0" solref="{law.pair_solref}" solimp="{law.solimp}"/>',
    ]
    return "\n".join(lines) + "\n"


def measurement() -> str:
    """Python that measures one impact's e = -v_out / v_in in the user's own model (``model``, ``data`` loaded,
    the body flying towards the wall): the guide's check that the pasted settings give R.

    GAP_JOINT is the moving body's slide joint (its velocity along its own axis) or free joint
    (its linear velocity, world frame, along the contact's normal at the first contact step): a
    free joint's first dof is its x velocity, 0 for a ball dropped along z, so e = 0 / 0 read there.
    Needs only ``mujoco`` (and the numpy it brings); the printed comment says which velocity is used.
    """
    return "\n".join([
        'joint = model.joint("GAP_JOINT")  # the moving body\'s joint: a slide joint or a free joint',
        "dof, n = joint.dofadr[0], (3 if joint.type == mujoco.mjtJoint.mjJNT_FREE else 1)  # free: its 3 linear dofs",
        "while not data.nefc: v = data.qvel[dof:dof + n].copy(); mujoco.mj_step(model, data)  # fly to the wall",
        "normal = data.contact.frame[0, :3] if n == 3 else [1.0]  # free: along the contact normal; slide: its axis",
        "v_in = v @ normal",
        "while data.nefc: mujoco.mj_step(model, data)  # through the contact",
        'print("e =", -(data.qvel[dof:dof + n] @ normal) / v_in)  # compare with R at this v_in',
    ]) + "\n"
