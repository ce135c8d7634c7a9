"""A chart's files: the PNG as drawn alone, the SVG with the layout that drawing computed, the figure left as it was."""

from __future__ import annotations

import re

from matplotlib.figure import Figure

from chatterbench.comparisons.outputs.figures import figure_bytes, figure_files, write_figure


def _chart() -> Figure:
    """A constrained-layout chart whose labels move its axes well away from matplotlib's default place."""
    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [0.0, 1e6])
    ax.set_ylabel("a long label\non two lines [m/s]")
    ax.set_title("a title")
    return fig


def _svg_axes_box(svg: bytes) -> tuple[float, ...]:
    """The axes background rectangle of a one-axes SVG [pt]: x0, y0, x1, y1 of its path."""
    path = re.search(rb'<g id="patch_2">\s*<path d="([^"]+)"', svg).group(1).decode()
    xy = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", path)]
    xs, ys = xy[0::2], xy[1::2]
    return min(xs), min(ys), max(xs), max(ys)


def test_the_png_is_the_figures_own_and_the_svg_keeps_its_layout(tmp_path):
    alone, fig = _chart(), _chart()
    png = figure_bytes(alone, "png")  # the PNG as drawn by itself: constrained layout run
    files = figure_files(fig)
    assert files["png"] == png
    # the SVG's axes sit where the PNG's drawing put them: the constrained place, not matplotlib's default subplot
    placed = alone.axes[0].get_position().bounds
    assert fig.axes[0].get_position().bounds == placed and placed[0] > 0.15  # default left: 0.125
    x0, y0, x1, y1 = _svg_axes_box(files["svg"])
    width, height = 4 * 72, 3 * 72  # [pt]
    assert abs(x0 / width - placed[0]) < 1e-3 and abs((x1 - x0) / width - placed[2]) < 1e-3
    assert abs((y1 - y0) / height - placed[3]) < 1e-3
    # the figure keeps its layout engine: drawn again alone, it is laid out as before
    assert fig.get_layout_engine() is not None and type(fig.get_layout_engine()).__name__ == "ConstrainedLayoutEngine"
    assert figure_bytes(fig, "png") == png
    # written: both files, the bytes above
    paths = write_figure(fig, tmp_path, "chart", files)
    assert [p.name for p in paths] == ["chart.png", "chart.svg"] and paths[0].read_bytes() == png
