"""What the sweep charts share: the dataset's parameters, the slices a chart draws, and their refusals.

    >>> from chatterbench.reference.scene import load_scene
    >>> import pandas as pd
    >>> from chatterbench.comparisons.outputs.sweep_data import parameter_columns, at_defaults
    >>> from chatterbench.comparisons import compare
    >>> from chatterbench.engines.registry import settings_for
    >>> from chatterbench.comparisons.pipeline.summary import summarize
    >>> rows = pd.DataFrame([summarize(compare(load_scene("bouncing-ball", [f"restitution={r}"]),
    ...                                        settings=settings_for(("pybullet",), dt=dt)), "pybullet", {"dt": dt, "restitution": r})
    ...                      for dt in (1e-3, 3e-4) for r in (0.3, 0.5)])          # a small sweep's rows
    >>> parameter_columns(rows)                          # dt, mass_ratio and every swept key
    ['dt', 'mass_ratio', 'restitution']
    >>> sub, held = at_defaults(rows, "pybullet", ("dt",))   # what is not drawn, held at the scene's default
    >>> len(sub), held
    (2, {'restitution': 0.5})

Charts read only a sweep dataset (``pipeline/summary.py`` documents its columns); nothing is
rerun. A column or engine that is not in the rows is a ``ChartError`` naming the nearest
valid name.
"""

from __future__ import annotations

import math
import textwrap
from typing import TYPE_CHECKING, Any, Iterable, Sequence

import numpy as np
import pandas as pd

from chatterbench.comparisons.pipeline.summary import DERIVED_PARAMETERS, REFINE_LEVEL, ROW_COLUMNS, mass_ratio
from chatterbench.engines.registry import ENGINE_NAMES, make_settings, settings_dict
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import load_scene
from chatterbench.comparisons.pipeline.vocabulary import ABBREVIATIONS, COLOURS, MEANINGS, NAMES
from chatterbench.comparisons.pipeline.vocabulary import PASSING as PASSING_VERDICTS
from chatterbench.reference.errors import InputError, did_you_mean
from chatterbench.reference.tables import flatten

if TYPE_CHECKING:  # annotations only: importing this module loads no matplotlib
    from matplotlib.figure import Figure

# verdict names, colours, abbreviations and meanings: the one vocabulary (pipeline/vocabulary.py)
VERDICT_ORDER = NAMES  # best first, "none" first of all: nothing to judge
PASSING = PASSING_VERDICTS  # the run reproduced the episodes; only their timing or impacts may be off
VERDICT_COLOURS = COLOURS
VERDICT_ABBREV = ABBREVIATIONS
VERDICT_MEANING = MEANINGS
# hollow markers of the failure classes on the work-precision chart
FAIL_MARKERS = {"missed": "v", "spurious": "^", "endless": "D", "penetrated": "s",
                "diverged": "X", "error": "P", "timeout": "*", "crashed": "X"}
METRIC_LABELS = {
    "exit_error_rel_max": "exit time (fraction of the sliding duration)",
    "stick_error_rel_max": "sticking start (fraction of the chatter duration)",
    "restitution_error_max": "restitution of the resolved impacts (relative)",
    "exit_error_max": "exit time",
    "stick_error_max": "sticking start (vs the Zeno point)",
    "stick_error_plate_max": "sticking start (vs Feigin's plate entry)",
    "first_impact_error_max": "first impact",
}
COST = "cost_per_sim_s"


class ChartError(InputError):
    """Chart input that cannot be drawn (unknown column or engine, no rows); exit code 2 in the CLI."""


def parameter_columns(rows: pd.DataFrame) -> list[str]:
    """The parameters of a dataset: ``dt``, ``mass_ratio`` (when present) and every column not in ``summary.ROW_COLUMNS``.

    A refined sweep's ``refine_level`` says when a point was run, not where: it is no parameter.
    """
    derived = [c for c in DERIVED_PARAMETERS if c == "dt" or c in rows.columns]
    return derived + [c for c in rows.columns if c not in ROW_COLUMNS and c != REFINE_LEVEL]


def folded_parameters(frame: pd.DataFrame, shown: Sequence[str], candidates: Iterable[str]) -> list[str]:
    """The ``candidates`` that vary in ``frame`` and are not drawn (``shown``): what a chart folds.

    ``mass_ratio`` is derived from ``mass1`` and ``mass2``: it is named only when it is not
    drawn and neither mass varies, and the masses are not named when it is drawn.
    """
    skip = set(shown)
    if "mass_ratio" in skip:
        skip |= {"mass1", "mass2"}
    changing = varying(frame, [c for c in candidates if c not in skip])
    if {"mass1", "mass2"} & set(changing):
        changing = [c for c in changing if c != "mass_ratio"]
    return changing


def default_values(rows: pd.DataFrame, engine: str) -> dict[str, Any]:
    """The default of each parameter a sweep of ``engine`` may vary, as dotted keys.

    The engine's settings (``mujoco.w0_dt`` = 0.03, ``pybullet.restitution_velocity_threshold``
    = 0, ...) and, when the rows are of one built-in scene, that scene's fields
    (``restitution``, ``mass2``, ``gap.lower``, ``initial.t`` ...) and its ``mass_ratio``.
    """
    out: dict[str, Any] = {}
    if engine in ENGINE_NAMES:
        out.update({f"{engine}.{k}": v for k, v in settings_dict(make_settings(engine)).items() if k != "dt"})
    scenes = rows["scene"].astype(str).unique() if "scene" in rows else []
    if len(scenes) == 1 and scenes[0] in CATALOGUE:
        scene = load_scene(scenes[0], {})
        fields = flatten(scene.to_dict(), lists=True)
        fields["mass1"] = scene.mass1
        out.update({k: v for k, v in fields.items() if k not in ("name", "description")})
        out["mass_ratio"] = mass_ratio(scene)
    return out


def equals(column: pd.Series, value: Any) -> pd.Series:
    """Where ``column`` holds ``value`` (numbers to 1e-9 relative, infinities exactly)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        num = pd.to_numeric(column, errors="coerce").astype(float)
        if math.isinf(value):
            return num == value
        return (num - value).abs() <= 1e-9 * max(abs(value), 1e-300)
    return column.astype(str) == str(value)


def at_defaults(rows: pd.DataFrame, engine: str, shown: Sequence[str], candidates: Iterable[str] | None = None
                ) -> tuple[pd.DataFrame, dict[str, Any]]:
    """``engine``'s rows with the parameters not ``shown`` held at their defaults, where the sweep ran them.

    A report cannot ask which slice a reader wants; the defaults are the settings a user
    starts from. A parameter whose default the sweep did not run stays folded (worst case).

    Parameters
    ----------
    shown : the parameters the chart draws (its axes, or the curves' settings).
    candidates : the parameters that may be held; default every parameter column.

    Returns
    -------
    (rows, held): the slice, and each held parameter with its value.
    """
    sub = rows[rows["engine"] == engine]
    defaults = default_values(rows, engine)
    held: dict[str, Any] = {}
    for col in folded_parameters(sub, shown, parameter_columns(rows) if candidates is None else candidates):
        if col in defaults:
            keep = equals(sub[col], defaults[col])
            if keep.any():
                sub, held[col] = sub[keep], defaults[col]
    return sub, held


def check_columns(rows: pd.DataFrame, names: Iterable[str], allowed: Sequence[str] | None = None, what: str = "column") -> None:
    """Raise ``ChartError`` for the first name not in ``allowed`` (default: the rows' columns)."""
    allowed = list(rows.columns) if allowed is None else list(allowed)
    for name in names:
        if name not in allowed:
            raise ChartError(f"{what} {name!r} is not in the dataset{did_you_mean(name, allowed)}; "
                             f"available: {', '.join(allowed)}")


def engines_of(rows: pd.DataFrame, engine: str | None) -> list[str]:
    """The engines of the rows, or ``[engine]`` if it is one of them (else ChartError)."""
    present = sorted(rows["engine"].astype(str).unique())
    if engine is None:
        return present
    check_columns(rows, [engine], present, what="engine")
    return [engine]


def varying(frame: pd.DataFrame, columns: Iterable[str]) -> list[str]:
    """The columns that take more than one value (NaN aside) in ``frame``."""
    return [c for c in columns if c in frame and frame[c].dropna().nunique() > 1]


def fmt(v) -> str:
    """A parameter value as a label: numbers compactly (``1e-04``, ``0.5``), anything else as text."""
    return f"{v:g}" if isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) else str(v)


def suptitle(fig: Figure, text: str, size: float = 11.0) -> None:
    """The figure's title, wrapped to its width (a one-panel map is narrower than its longest title)."""
    chars = max(30, int(fig.get_figwidth() * 72.0 / (0.6 * size)))
    fig.suptitle(textwrap.fill(text, chars), fontsize=size)
