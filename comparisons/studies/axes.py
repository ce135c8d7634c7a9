"""How a swept parameter's values are spaced: ``log``, ``linear`` or ``category``, one rule for every user.

    >>> from chatterbench.comparisons.studies.axes import axis_scale
    >>> axis_scale([1e-4, 1e-3, 1e-2]), axis_scale([0.1, 0.5, 0.9]), axis_scale([0, 0.1, 1, 10])
    ('log', 'linear', 'category')

A refined sweep splits a cell in its axes' scale (``sweep/refine.py``), tune steps its knobs in it
(``tune.search``) and the stability map draws its axes in it (``outputs/stability_map.py``): the
rule lives here, in the lowest stage that needs it, so that none of them imports a stage above.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

LOG_SPAN = 10.0  # an axis whose positive values span this ratio (a decade) or more is log-scaled
IRREGULAR = 2.0  # a linear axis whose steps differ by more than this factor is drawn as equal cells


def axis_scale(values: Sequence) -> str:
    """How a map axis (and a refined sweep's cell split) treats these values: ``log``, ``linear`` or ``category``.

    Positive numbers spanning a decade or more (``LOG_SPAN``): ``log``. Other numbers:
    ``linear`` when evenly enough spaced (largest step at most ``IRREGULAR`` times the
    smallest), else ``category`` (equal cells in value order, like strings: 0, 0.1, 1, 10
    would otherwise squeeze the small values into slivers).
    """
    vals = list(values)
    if not all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) for v in vals):
        return "category"
    v = np.sort(np.asarray(vals, float))
    if v.min() > 0 and v.max() / v.min() >= LOG_SPAN:
        return "log"
    if len(v) > 2 and np.diff(v).max() > IRREGULAR * np.diff(v).min():
        return "category"
    return "linear"
