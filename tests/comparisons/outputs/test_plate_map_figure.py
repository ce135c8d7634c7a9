"""The plate map's legend leaves the map readable: it covers none of the sliding region."""

from chatterbench.comparisons.outputs.plate_map_figure import plate_map_figure
from chatterbench.comparisons.studies.plate_map import plate_map
from chatterbench.reference import load_scene


def test_the_legend_covers_nothing_of_the_map():
    scene = load_scene("feigin-pair")
    table = plate_map(scene, "lower", n_phase=24, n_speed=16)
    assert table["reference"].any()  # there is a sliding region to cover
    fig = plate_map_figure(table, scene)
    fig.canvas.draw()
    (ax,) = fig.axes
    legends = [*fig.legends, *([ax.get_legend()] if ax.get_legend() else [])]
    assert len(legends) == 1
    # before: inside the axes' upper right corner, over the region that slides at phases near 2 pi
    assert not legends[0].get_window_extent().overlaps(ax.get_window_extent())
    width = fig.bbox.width
    assert all(0 <= t.get_window_extent().x0 and t.get_window_extent().x1 <= width for t in legends[0].get_texts())
