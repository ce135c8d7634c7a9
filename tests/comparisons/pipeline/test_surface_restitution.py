"""The judge measures a soft contact's restitution where the body crosses the wall's surface (pipeline/surface.py).

Known answers both ways on a synthetic soft contact under gravity: the ball dropped on the floor
of the bouncing-ball scene, each contact 5 ms long and letting go of the ball *below* the floor,
rising at w_r, from where the free flight still slows it before it crosses the surface. The
true restitution (the one the bounce heights give) is e = sqrt(w_r^2 - 2 g |d_r|) / v-; the
speed at release says w_r / v-, which is optimistic.
"""

import math

import numpy as np
import pandas as pd

from chatterbench.comparisons.pipeline.extract import extract
from chatterbench.comparisons.pipeline.impacts import pair_impacts
from chatterbench.engines.trajectory import Trajectory
from chatterbench.reference.scene import load_scene

G, DT, CONTACT, DEPTH = 9.81, 1e-4, 5e-3, 1e-3  # [m/s^2], [s], contact duration [s], release depth below the floor [m]


def soft_bounces(e_true: float, v_first: float = 1.0, bounces: int = 4):
    """Samples of the ball bouncing with surface-crossing restitution ``e_true``; the release speeds w_r."""
    scene = load_scene("bouncing-ball")
    t = np.arange(0.0, 1.2, DT)
    y, vy, flag = np.full(t.shape, np.nan), np.full(t.shape, np.nan), np.zeros(t.shape, bool)
    # free flight from rest, from the height that hits the floor at v_first
    t0, y0, v0, releases = 0.0, v_first**2 / (2 * G), 0.0, []
    v_in = v_first
    for _ in range(bounces + 1):
        t_hit = t0 + (v0 + math.sqrt(v0**2 + 2 * G * y0)) / G
        free = (t >= t0) & (t < t_hit)
        s = t[free] - t0
        y[free], vy[free] = y0 + v0 * s - G * s**2 / 2, v0 - G * s
        w_r = math.sqrt((e_true * v_in) ** 2 + 2 * G * DEPTH)
        releases.append(w_r / v_in)
        inside = (t >= t_hit) & (t < t_hit + CONTACT)  # the contact: any motion, flagged
        y[inside], vy[inside], flag[inside] = -DEPTH, 0.0, True
        t0, y0, v0, v_in = t_hit + CONTACT, -DEPTH, w_r, e_true * v_in
    free = t >= t0
    s = t[free] - t0
    y[free], vy[free] = y0 + v0 * s - G * s**2 / 2, v0 - G * s
    keep = np.isfinite(y) & (t < t0 + 0.5 * v0 / G)
    zero = np.zeros(int(keep.sum()))
    traj = Trajectory(engine="soft", t=t[keep], x1=zero, x2=y[keep], v1=zero, v2=vy[keep],
                      contact={"lower": flag[keep]}, normal_force={"lower": flag[keep].astype(float)}, wall_time=0.0)
    return scene, traj, releases


def measured(e_true: float):
    scene, traj, releases = soft_bounces(e_true)
    imp = extract(traj, scene).impacts
    return (-imp["v_plus"] / imp["v_minus"]).to_numpy(), imp, releases


def test_a_soft_contact_released_below_the_surface_is_measured_at_the_surface():
    e, _, releases = measured(0.5)                   # the known answer: R itself at every bounce
    assert len(e) == 5 and np.allclose(e, 0.5, atol=2e-4), e
    assert min(releases[1:]) > 0.52                  # the release speeds say more (0.52-0.6): the old measure


def test_a_soft_contact_that_loses_more_than_its_release_says_is_caught():
    # the optimistic case: released at w_r = 0.5 v- or more (within 5% of R by the release speed), truly e = 0.45
    e, imp, releases = measured(0.45)
    assert np.allclose(e, 0.45, atol=2e-4), e
    assert sum(r / 0.5 - 1 > -0.05 for r in releases) >= 3  # the release speeds would pass the 5% tolerance
    ref = pd.DataFrame({"t": imp["t"], "v_minus": imp["v_minus"], "v_plus": -0.5 * imp["v_minus"]})
    flights = np.append(np.diff(imp["t"].to_numpy()), 0.1)
    pairs = pair_impacts(ref, flights, imp, dt=DT, resolved_steps=10, restitution=0.5, tolerance=0.05)
    assert pairs.measured >= 3 and pairs.worst_error < -0.05  # -10%: the judge sees the loss


def test_the_judges_e_is_what_the_bounce_heights_of_a_real_run_say():
    # MuJoCo (soft) and PyBullet (rigid) dropping the ball: e of impact k from the apex heights around it,
    # sqrt(H_k / H_k-1), against the judge's e of impact k. Before: MuJoCo's 4th impact (0.52 m/s) was
    # 0.4993 by the judge, 0.4768 by its bounce heights; PyBullet's 6th (0.14 m/s) 0.4964 against 0.5048.
    from chatterbench.engines.registry import make_settings, run_engine

    scene = load_scene("bouncing-ball")
    for engine, dt, sets in (("mujoco", 3e-4, ["mujoco.w0_dt=0.1"]), ("pybullet", 1e-4, [])):
        traj = run_engine(engine, scene, make_settings(engine, dt, sets))
        imp = extract(traj, scene).impacts
        t, d = traj.t, traj.y - scene.gap.position("lower")
        ti = imp["t"].to_numpy()
        apex = np.array([d[(t > ti[i]) & (t < ti[i + 1])].max() for i in range(6)])
        by_height = np.sqrt(apex[1:] / apex[:-1])  # impacts 1..5, flights of 20 ms or more
        judged = (-imp["v_plus"] / imp["v_minus"]).to_numpy()[1:6]
        assert np.allclose(judged, by_height, atol=5e-4), (engine, judged, by_height)
