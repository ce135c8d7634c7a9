"""The frontier chart: each engine's cheapest robust cost against the tolerance it reaches, per axis, from recommended.json."""

from __future__ import annotations

import json
import re

import pytest

from chatterbench.comparisons.outputs.frontier_chart import frontier_figure, read_frontiers, scene_frontiers, staircase
from chatterbench.reference.errors import InputError


def point(stick: float, restitution: float, cost: float) -> dict:
    return {"tolerances": {"stick": stick, "exit": stick, "first_impact": stick, "restitution": restitution},
            "dt": 1.0 / cost, "settings": {}, "cost_steps_per_s": cost, "margin": 0.5}


# a frontier as tune writes it (PyBullet on the ball, measured): cheaper where looser, on either axis
FRONTIER = [point(0.1, 0.1, 85.0), point(0.2, 0.05, 206.0), point(0.1, 0.05, 258.0), point(0.05, 0.05, 323.0),
            point(0.02, 0.02, 505.0), point(0.01, 0.02, 787.0)]


def test_staircase_keeps_the_cheapest_point_reaching_each_tolerance():
    # timing: 1% costs 787, 2% 505, 5% 323, 10% 85 (the 10% / 5% point at 258 is dearer than 85: left off the stairs)
    assert [(e["tolerances"]["stick"], e["cost_steps_per_s"]) for e in staircase(FRONTIER, "stick")] == \
        [(0.01, 787.0), (0.02, 505.0), (0.05, 323.0), (0.1, 85.0)]
    # restitution: 2% costs 505 (787 is dearer at the same 2%), 5% 206, 10% 85
    assert [(e["tolerances"]["restitution"], e["cost_steps_per_s"]) for e in staircase(FRONTIER, "restitution")] == \
        [(0.02, 505.0), (0.05, 206.0), (0.1, 85.0)]


def test_one_line_per_engine_on_each_axis_and_an_engine_with_nothing_robust_is_named():
    fig = frontier_figure({"pybullet": FRONTIER, "mujoco": []}, "bouncing-ball", {"stick": 0.05, "restitution": 0.05})
    timing, restitution = fig.axes
    for ax, axis in ((timing, "stick"), (restitution, "restitution")):
        stairs = [line for line in ax.lines if line.get_label().startswith("pybullet: the cheapest")]
        assert len(stairs) == 1  # one line per engine
        x, y = stairs[0].get_data()
        assert list(y) == [e["cost_steps_per_s"] for e in staircase(FRONTIER, axis)]
        assert list(x) == [e["tolerances"][axis] for e in staircase(FRONTIER, axis)]
        asked = [line for line in ax.lines if line.get_label() == "asked: 5%"]
        assert len(asked) == 1 and list(asked[0].get_xdata()) == [0.05, 0.05]
        assert ax.get_xscale() == ax.get_yscale() == "log"
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "mujoco: nothing robust in the searched space" in labels
    # every frontier point is drawn and labelled with the other axis's tolerance and its cost (the joint trade-off
    # stays visible); the point at the asked tolerances says so (issue 41: it was a hollow dot without a label)
    asked = {"stick": 0.05, "restitution": 0.05}
    assert sorted(t.get_text() for t in timing.texts) == sorted(
        f"r {100 * e['tolerances']['restitution']:.3g}%, {e['cost_steps_per_s']:,.0f}/s"
        + (" (asked)" if all(e["tolerances"][a] == asked[a] for a in asked) else "") for e in FRONTIER)
    assert sum(t.get_text().endswith("(asked)") for t in timing.texts) == sum(
        all(e["tolerances"][a] == asked[a] for a in asked) for e in FRONTIER) >= 1


def test_frontiers_are_read_from_the_tune_folders_one_or_several_engines(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    (two / "mujoco").mkdir(parents=True)
    one.mkdir()
    rec = {"scene": "bouncing-ball", "engine": "pybullet", "frontier": FRONTIER, "tolerances": {"stick": 0.05}}
    (one / "recommended.json").write_text(json.dumps(rec))
    (two / "mujoco" / "recommended.json").write_text(json.dumps({**rec, "engine": "mujoco", "frontier": []}))
    (two / "recommended.json.bak").write_text("not read")
    found = read_frontiers([one, two])
    assert [(f.engine, len(f.frontier)) for f in found] == [("pybullet", 6), ("mujoco", 0)]
    assert list(scene_frontiers(found, "bouncing-ball")) == ["pybullet", "mujoco"]
    assert scene_frontiers(found, "feigin-pair") == {}
    (one / "recommended.json").write_text("{not json")
    with pytest.raises(InputError, match=r"--tune .*one: recommended.json is not the JSON"):
        read_frontiers([one])


@pytest.mark.parametrize("change, field", [
    (lambda e: {**e, "cost_steps_per_s": "cheap"}, "frontier[1].cost_steps_per_s"),
    (lambda e: {**e, "cost_steps_per_s": -5.0}, "frontier[1].cost_steps_per_s"),
    (lambda e: {**e, "tolerances": {**e["tolerances"], "stick": float("inf")}}, "frontier[1].tolerances.stick"),
    (lambda e: {k: v for k, v in e.items() if k != "tolerances"}, "frontier[1]: not an entry"),
    (lambda e: "a string", "frontier[1]: not an entry"),
])
def test_a_frontier_the_chart_cannot_draw_is_refused_by_field(tmp_path, change, field):
    # a hand-edited or foreign recommended.json given to `report --tune`: one line naming the file and the field,
    # not a failure inside matplotlib; the file as tune wrote it is read (the other way)
    frontier = [FRONTIER[0], change(FRONTIER[1])]
    (tmp_path / "recommended.json").write_text(json.dumps({"scene": "bouncing-ball", "engine": "pybullet",
                                                          "frontier": frontier}))
    with pytest.raises(InputError, match=rf"--tune .*: recommended.json: {re.escape(field)}"):
        read_frontiers([tmp_path])
    (tmp_path / "recommended.json").write_text(json.dumps({"scene": "bouncing-ball", "engine": "pybullet",
                                                          "frontier": FRONTIER}))
    assert len(read_frontiers([tmp_path])[0].frontier) == len(FRONTIER)


def test_a_recommended_json_that_is_not_a_regular_file_or_too_large_is_refused(tmp_path):
    import os

    fifo, big = tmp_path / "fifo", tmp_path / "big"
    fifo.mkdir(), big.mkdir()
    os.mkfifo(fifo / "recommended.json")  # before: read_text waited for a writer
    with pytest.raises(InputError, match="recommended.json: not a regular file"):
        read_frontiers([fifo])
    with open(big / "recommended.json", "wb") as f:
        f.truncate(64 * 2**20)  # a sparse 64 MiB file: refused without reading it whole
    with pytest.raises(InputError, match="recommended.json: larger than 4 MiB"):
        read_frontiers([big])


def test_two_engines_at_one_point_both_show():
    # issue 41: MuJoCo's 20% / 206 point was hidden under PyBullet's marker (same colour-less dot, same size); each
    # engine now has its own marker shape, a later one smaller, so a point under another engine's still shows
    same = [point(0.2, 0.05, 206.0)]
    fig = frontier_figure({"pybullet": same, "mujoco": same}, "bouncing-ball", {"stick": 0.05, "restitution": 0.05})
    drawn = [line for line in fig.axes[0].lines if line.get_marker() not in ("None", None, "") and len(line.get_xdata())]
    markers = {(line.get_marker(), line.get_markersize()) for line in drawn if list(line.get_ydata()) == [206.0]}
    assert len(markers) == 2 and len({m for m, _ in markers}) == 2 and len({s for _, s in markers}) == 2
    # the other way: one engine alone draws one marker there
    fig = frontier_figure({"pybullet": same}, "bouncing-ball", {"stick": 0.05, "restitution": 0.05})
    drawn = [line for line in fig.axes[0].lines if line.get_marker() not in ("None", None, "") and len(line.get_xdata())]
    assert len({line.get_marker() for line in drawn if list(line.get_ydata()) == [206.0]}) == 1


def test_the_labels_of_one_tolerance_neither_overlap_nor_leave_the_axes():
    # the atlas's impact-damper chart (7 engines, PhysX and Siconos with points): each engine's labels were a fixed
    # 11 points lower than the one before, so Siconos' (the seventh) fell 61 points below its points, over PhysX's
    # labels and under the axes; now one tolerance's labels are stacked from the lowest, none over another
    physx = [point(0.05, 0.05, 2997.0), point(0.05, 0.02, 4682.0), point(0.1, 0.05, 2342.0)]
    siconos = [point(0.05, 0.05, 2834.0), point(0.05, 0.02, 4566.0), point(0.1, 0.05, 2342.0), point(0.1, 0.02, 4188.0)]
    frontiers = {"mujoco": [], "pybullet": [], "dart": [], "physx": physx, "drake": [], "mujoco_warp": [],
                 "siconos": siconos}
    fig = frontier_figure(frontiers, "impact-damper", {"stick": 0.05, "restitution": 0.05})
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    for ax in fig.axes:
        boxes = [(t.xy[0], t.get_window_extent(renderer)) for t in ax.texts]
        assert len(boxes) == len(physx) + len(siconos)
        inside = ax.get_window_extent(renderer)
        for x, box in boxes:
            assert inside.y0 <= box.y0 and box.y1 <= inside.y1, box  # within the axes' height
        for i, (x, a) in enumerate(boxes):
            for y, b in boxes[i + 1:]:
                assert x != y or not a.overlaps(b), (a, b)  # the labels of one tolerance apart
