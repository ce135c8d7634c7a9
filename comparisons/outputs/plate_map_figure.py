"""The sliding-plate map as a figure: the true sliding region filled, Feigin's sufficient plate hatched, engines as contours.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.outputs.plate_map_figure import plate_map_figure
    >>> from chatterbench.comparisons.studies.plate_map import plate_map
    >>> scene = load_scene("feigin-pair")
    >>> fig = plate_map_figure(plate_map(scene, "lower", n_phase=12, n_speed=8), scene)
    >>> fig.axes[0].get_xlabel()
    'strike phase omega t mod 2 pi [rad]'
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from chatterbench.reference.scene import Scene

from .style import engine_colour


def plate_map_figure(table: pd.DataFrame, scene: Scene, wall: str = "lower") -> Figure:
    """The map: true sliding region filled, Feigin's sufficient region hatched, engines as contours."""
    phases = np.unique(table["phase"].round(12))
    speeds = np.unique(table["speed"].round(15))
    shape = (len(phases), len(speeds))
    order = table.sort_values(["phase", "speed"])
    P = order["phase"].to_numpy().reshape(shape)
    V = order["speed"].to_numpy().reshape(shape)
    fig = Figure(figsize=(9, 6.0), layout="constrained")
    ax = fig.subplots()
    ref = order["reference"].to_numpy().reshape(shape).astype(float)
    ax.contourf(P, V, ref, levels=[0.5, 1.5], colors=["#c7e9c0"]).set_gid("reference-region")
    ax.contour(P, V, ref, levels=[0.5], colors=["black"], linewidths=1.5)
    fe = order["feigin"].to_numpy().reshape(shape).astype(float)
    ax.contourf(P, V, fe, levels=[0.5, 1.5], colors="none", hatches=["///"])
    ax.contour(P, V, fe, levels=[0.5], colors=["#2ca02c"], linewidths=1.2, linestyles="--")
    handles = [
        Rectangle((0, 0), 1, 1, fc="#c7e9c0", ec="black", label="slides: reference (every impact, Zeno point)"),
        Rectangle((0, 0), 1, 1, fc="white", ec="#2ca02c", hatch="///", ls="--", label="Feigin's sufficient plate (2.1)-(2.2)"),
    ]
    if scene.name == "feigin-pair" or "feigin" in scene.name:
        R = scene.restitution
        tau = np.linspace(0, 2 * math.pi, 400)
        bound = 5 * (1 - R) / (24 * R) * np.sin(tau) ** 2
        ok = (-np.cos(tau) > max(0.0, (9 * R - 5) / (12 * R))) & (np.sin(tau) > 0) if wall == "lower" else \
             (np.cos(tau) > max(0.0, (9 * R - 5) / (12 * R))) & (np.sin(tau) < 0)
        ax.plot(np.where(ok, tau, np.nan), np.where(ok, bound, np.nan), color="#2ca02c", lw=2.5,
                label=f"(4.2): {5 * (1 - R) / (24 * R):.3g} sin^2(tau)")
        handles.append(Line2D([], [], color="#2ca02c", lw=2.5, label=f"(4.2) boundary: {5 * (1 - R) / (24 * R):.3g} sin^2(tau)"))
    for name in [c for c in table.columns if c not in ("t", "phase", "speed", "reference", "feigin")]:
        grid = order[name].to_numpy().reshape(shape).astype(float)
        if grid.min() == grid.max():
            continue
        ax.contour(P, V, grid, levels=[0.5], colors=[engine_colour(name)], linewidths=1.6)
        handles.append(Line2D([], [], color=engine_colour(name), lw=1.6, label=f"{name}: edge of its sliding region"))
    ax.set_xlabel("strike phase omega t mod 2 pi [rad]")
    ax.set_ylabel("incoming speed |y'| [m/s]")
    ax.set_xlim(0, 2 * math.pi)
    ax.set_title(f"{scene.name}, {wall} wall, R = {scene.restitution:g}: which strikes end in sliding")
    # below the axes: the sliding region reaches every corner of the map, a legend inside would cover it
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    return fig
