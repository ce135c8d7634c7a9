"""``add_many``: a chunk recorded for many runs at once gives each run what its own ``Recording.add`` gives it."""

import numpy as np
import pytest

from chatterbench.engines.base import MAXVAL, Recording
from chatterbench.engines.batch_recording import add_many
from chatterbench.engines.mujoco_engine import MujocoSettings
from chatterbench.reference.scene import load_scene

DT, C = 1e-3, 40  # [s] step; samples per chunk
PRESCRIBED = ["mass1=inf", "prescribed.amplitude=0.05", "prescribed.omega=2.0", "initial.v1=0.1", "forces.0.on=coupling"]
SCENES = [("feigin-pair", []), ("feigin-pair", PRESCRIBED), ("bouncing-ball", []), ("feigin-pair", ["initial.t=0.3"]),
          ("spring-pair", []), ("feigin-pair", [])]
# per run, what goes wrong in its chunks: nothing, a NaN y, a huge x1 of an infinite body 1 (not the run's: the base's
# rest stands for it, no cut), a sample the engine marks bad, a NaN force, a huge v1 of a finite body 1
FAULTS = [None, ("y", 57, np.nan), ("x1", 5, 2 * MAXVAL), ("bad", 70, True), ("force", 3, np.nan), ("v1", 12, 2 * MAXVAL)]


def _runs():
    s = MujocoSettings(dt=DT)
    return [Recording("x", load_scene(name, o + ["duration=0.2"]), s, {}, None, (0.0, 1.0)) for name, o in SCENES]


def _chunks(runs):
    """Three chunks of made-up samples for every run, each (nworld, C), with FAULTS in them."""
    rng = np.random.default_rng(7)
    for k0 in (0, C, 2 * C):
        cols = {k: rng.normal(size=(len(runs), C)) for k in ("y", "vy", "x1", "v1")}
        force = {w: np.abs(rng.normal(size=(len(runs), C))) * (rng.random((len(runs), C)) < 0.3)
                 for w in ("lower", "upper")}
        bad = np.zeros((len(runs), C), bool)
        for w, fault in enumerate(FAULTS[:len(runs)]):
            if fault is not None and k0 <= fault[1] < k0 + C:
                name, at, value = fault
                target = bad if name == "bad" else force["lower"] if name == "force" else cols[name]
                target[w, at - k0] = value
        t = np.array([r.scene.initial.t + DT * np.arange(k0, k0 + C) for r in runs])
        yield t, force, cols, bad


def test_each_run_gets_what_its_own_add_gives_it():
    together, alone = _runs(), _runs()
    for t, force, cols, bad in _chunks(together):
        add_many(together, t, force, bad=bad, **cols)
        for w, r in enumerate(alone):
            if r.stopped:
                continue
            body1 = {} if r.scene.body1_infinite else {"x1": cols["x1"][w], "v1": cols["v1"][w]}
            r.add(t[w], {wall: force[wall][w] for wall in r.scene.gap.walls}, y=cols["y"][w], vy=cols["vy"][w],
                  bad=bad[w], **body1)
    cuts = [r.cut for r in alone]
    assert [bool(c) for c in cuts] == [False, True, False, True, True, True]  # the faults were seen, both ways
    assert cuts[1] == "non-finite or huge state at t = 0.057 s (sample 57)"
    for a, b in zip(together, alone):
        ta, tb = a.trajectory(), b.trajectory()
        assert (ta.status, ta.message, len(ta.t)) == (tb.status, tb.message, len(tb.t))
        for k in ("t", "x1", "x2", "v1", "v2"):
            np.testing.assert_array_equal(getattr(ta, k), getattr(tb, k))
        for wall in ta.contact:
            np.testing.assert_array_equal(ta.contact[wall], tb.contact[wall])
            np.testing.assert_array_equal(ta.normal_force[wall], tb.normal_force[wall])


def test_samples_off_the_time_grid_are_refused_as_add_refuses_them():
    runs = _runs()[:1]
    t, force, cols, bad = next(_chunks(runs))
    with pytest.raises(ValueError, match="sample 0: t = 0.0005 s, not t0 \\+ k dt = 0 s"):
        add_many(runs, t + 0.5 * DT, force, bad=bad, **cols)


def test_a_run_that_ends_inside_the_chunk_takes_its_samples_only():
    runs, alone = _runs()[:3], _runs()[:3]
    t, force, cols, bad = next(_chunks(runs))
    add_many(runs, t, force, bad=bad, lengths=np.array([C, 7, 0]), **cols)
    for w, n in enumerate((C, 7)):
        body1 = {} if alone[w].scene.body1_infinite else {"x1": cols["x1"][w, :n], "v1": cols["v1"][w, :n]}
        alone[w].add(t[w, :n], {wall: force[wall][w, :n] for wall in alone[w].scene.gap.walls}, y=cols["y"][w, :n],
                     vy=cols["vy"][w, :n], bad=bad[w, :n], **body1)
    assert [r.recorder.count for r in runs] == [C, 7, 0]
    for a, b in zip(runs[:2], alone[:2]):
        np.testing.assert_array_equal(a.trajectory().x2, b.trajectory().x2)
