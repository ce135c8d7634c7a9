"""The plate map: the reference's true region, Feigin's sufficient region, an engine's region."""

import math

import numpy as np

from chatterbench.engines.registry import settings_for
from chatterbench.comparisons.outputs.plate_map_figure import plate_map_figure
from chatterbench.comparisons.studies.plate_map import plate_map
from chatterbench.reference import load_scene


def test_plate_map_regions_on_feigin_pair_with_mujoco():
    scene = load_scene("feigin-pair")
    table = plate_map(scene, "lower", n_phase=10, n_speed=4, engines=("mujoco",), settings=settings_for(("mujoco",), 1e-4))
    assert len(table) == 40
    # sufficient conditions: no strike inside Feigin's plate may leave in the reference
    assert not (table["feigin"] & ~table["reference"]).any()
    # the paper's plate: R = 0.5 strikes with phase in (pi/2, pi) below 0.2083 sin^2 are inside
    inside_42 = (table["phase"] > math.pi / 2) & (table["phase"] < math.pi) & (table["speed"] < 5 / 24 * np.sin(table["phase"]) ** 2)
    assert (table["feigin"] == inside_42).all()
    # MuJoCo at dt = 1e-4, w0 dt = 0.03 follows the reference's region on most strikes;
    # strikes near the region's edge can go either way within the contact's own time scale
    assert (table["mujoco"] == table["reference"]).mean() >= 0.85
    fig = plate_map_figure(table, scene)
    assert fig.axes[0].get_xlabel().startswith("strike phase")


def test_an_engines_strikes_go_as_batches_with_the_column_of_single_runs(monkeypatch):
    # MuJoCo Warp steps a batch of strikes as the worlds of one model (runs of different lengths, each read to its
    # own end): the column is that of the strikes run one at a time
    import pytest

    pytest.importorskip("mujoco_warp", reason="the warp extra is not installed: pip install \".[warp]\"")
    from chatterbench.comparisons.studies import plate_map as pm

    scene = load_scene("feigin-pair")
    engines = ("mujoco_warp", "mujoco")
    args = dict(n_phase=4, n_speed=4, engines=engines, settings=settings_for(engines, 1e-3, ["mujoco_warp.device='cpu'"]))
    together = plate_map(scene, "lower", **args)
    monkeypatch.setattr(pm, "STRIKES_PER_BATCH", 1)
    alone = plate_map(scene, "lower", **args)
    assert together.equals(alone) and together["mujoco_warp"].any() and not together["mujoco_warp"].all()
