"""The searched lattice of a tune and a candidate's neighbourhood: dt and knob values, the band of dts, the knobs' neighbours.

    >>> from chatterbench.comparisons.studies.tune.grid import Grid, band_dts
    >>> grid = Grid.make({"dt": (4e-3, 1e-3), "pybullet.restitution_velocity_threshold": (0.0, 0.1)}, depth=1)
    >>> grid.dt, grid.knob_values
    ((0.004, 0.002, 0.001), (0.0, 0.05, 0.1))
    >>> groups = grid.neighbourhood(grid.params(0, 1, 2), phases=(0.25, 0.5, 0.75))
    >>> [n["dt"] for n in groups[0]], len(band_dts(0.0016, 0.0025)), len(groups[3])   # ends; the band; 3 phases x (18 + its own)
    ([0.0016, 0.0025], 18, 57)

``Grid.make`` turns a search space (``"dt"`` -> coarse timesteps [s], ``"engine.field"`` ->
values, the default first) into a lattice: dt split geometrically between the coarse values
(3 significant digits, ``DT_RATIO`` 1.25 apart at ``depth`` 2), the first real-valued knob (the
map's) split the same way, every other setting's values as slices. ``neighbourhood`` is what a
pass must survive to be *band-robust* (issue 41): every dt of [0.8, 1.25] x dt (``BAND``; the
ends exact to 6 digits, the inner dts the powers of ``BAND_RATIO`` = 1.25^(1/8), 2.8% apart,
one global lattice that neighbouring candidates share: ``band_dts``), at every impact phase
(``studies.phases``), and the knobs' neighbours (the map's knob: its adjacent lattice values;
every other real-valued knob: half-way to its adjacent searched values), grouped so that the
likeliest failures run first. Without phases it is the three-point rule of before: dt x 0.8
and x 1.25 and the knobs.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from ..axes import axis_scale
from ..sweep.refine import lattice

SIG_DIGITS = 3  # a dt is rounded to this many significant digits (it is printed and pasted)
KNOB_DIGITS = 4  # and a knob value between two searched ones to this many
DT_RATIO = 1.25  # [-] adjacent dt of the finest lattice: the neighbourhood's dt x 0.8 and x 1.25
DEPTH = 2  # refinement levels: the finest dt lattice is DT_RATIO apart, the coarse grid DT_RATIO ** 4
BAND = (0.8, 1.25)  # [-] a band-robust setting passes at every checked dt of [0.8, 1.25] x its dt
FINEST = 1e-3  # [-] the finest dt searched, as a fraction of the coarsest (the tightest timing tolerance in s)
FLIGHT_STEPS = 4  # the coarsest dt takes at least this many steps across the gap at the fastest strike
BAND_RATIO = DT_RATIO ** (1 / 8)  # [-] the band's inner dts: the powers of this (2.8% apart) inside it, one global
# lattice (rounded to 6 digits) that neighbouring candidates share, so a bisection's trials rerun little


def round_dt(dt: float) -> float:
    return float(f"{dt:.{SIG_DIGITS}g}")


def band_dts(lo: float, hi: float) -> list[float]:
    """The band's dts from ``lo`` to ``hi`` [s], both included: the powers of ``BAND_RATIO`` strictly inside
    (6 significant digits: one lattice for every candidate), ascending."""
    n0 = math.floor(math.log(lo) / math.log(BAND_RATIO)) + 1
    n1 = math.ceil(math.log(hi) / math.log(BAND_RATIO)) - 1
    inner = {float(f"{BAND_RATIO ** n:.6g}") for n in range(n0, n1 + 1)}
    return sorted({lo, hi, *(d for d in inner if lo < d < hi)})


def _rounded(fine: tuple, coarse: tuple) -> tuple:
    """A knob's fine lattice with the values between the coarse ones at ``KNOB_DIGITS`` significant digits (pasted)."""
    return tuple(v if v in coarse else float(f"{v:.{KNOB_DIGITS}g}") for v in fine)


def _real(values) -> bool:
    return all(isinstance(v, float) for v in values)


@dataclass(frozen=True)
class Grid:
    """The searched lattice (module docstring): fine dt (coarse to fine), the main knob's fine values, the slices."""

    dt: tuple[float, ...]  # [s] every value of the finest lattice, descending; coarse ones at multiples of 2**depth
    knob: str | None  # the main knob's key ("engine.field"), None when no setting is real-valued
    knob_values: tuple  # its finest lattice, ascending (one None when there is no main knob)
    slices: tuple[dict[str, Any], ...]  # each combination of the other settings' values
    others: dict[str, tuple]  # the other settings' searched values, as given
    depth: int  # refinement levels
    defaults: dict[str, Any] = field(default_factory=dict)  # each setting's default: its first value as given

    @classmethod
    def make(cls, space: dict[str, tuple], depth: int) -> "Grid":
        """From a search space: ``"dt"`` -> coarse timesteps [s], ``"engine.field"`` -> values (the default first)."""
        coarse_dt = sorted({float(v) for v in space["dt"]})
        steps = 2 ** depth  # dt is split geometrically whatever its span (cost is 1 / dt): the lattice's log rule
        fine_dt = [a * (b / a) ** (k / steps) for a, b in zip(coarse_dt, coarse_dt[1:]) for k in range(steps)] + coarse_dt[-1:]
        dt = tuple(sorted({round_dt(v) for v in fine_dt}, reverse=True))
        knobs = {k: tuple(v) for k, v in space.items() if k != "dt"}
        knob = next((k for k, v in knobs.items() if _real(v) and len(set(v)) > 1), None)
        values = (None,) if knob is None else (tuple(sorted(set(knobs[knob]))) if len(set(knobs[knob])) < 2
                                                 else _rounded(lattice(tuple(sorted(set(knobs[knob]))), depth), knobs[knob]))
        others = {k: v for k, v in knobs.items() if k != knob}
        slices = tuple(dict(zip(others, combo)) for combo in itertools.product(*others.values()))
        return cls(dt=dt, knob=knob, knob_values=tuple(values), slices=slices, others=others,
                   depth=depth if len(coarse_dt) > 1 or knob is not None else 0, defaults={k: v[0] for k, v in knobs.items()})

    def params(self, s: int, i: int, j: int) -> dict[str, Any]:
        p = {"dt": self.dt[i], **self.slices[s]}
        if self.knob is not None:
            p[self.knob] = self.knob_values[j]
        return p

    def coarse(self, axis: tuple) -> list[int]:
        return list(range(0, len(axis), 2 ** self.depth)) if len(axis) > 1 else [0]

    def place(self, p: dict[str, Any]) -> tuple[int, int, int] | None:
        """(slice, dt index, knob index) of a candidate on the lattice, None off it (a moved start is off it)."""
        if "phase" in p:
            return None
        try:
            i = self.dt.index(p["dt"])
            j = 0 if self.knob is None else self.knob_values.index(p[self.knob])
            s = self.slices.index({k: p[k] for k in self.others})
        except ValueError:
            return None
        return s, i, j

    def neighbours(self, p: dict[str, Any], phases: tuple[float, ...] = ()) -> list[dict[str, Any]]:
        """The neighbourhood of a candidate (module docstring), itself excluded: ``neighbourhood``'s groups in one."""
        return [n for group in self.neighbourhood(p, phases) for n in group]

    def neighbourhood(self, p: dict[str, Any], phases: tuple[float, ...] = ()) -> list[list[dict[str, Any]]]:
        """The neighbourhood of a candidate in the order it is run, the likeliest failures first: the band's ends
        (dt x 0.8 and x 1.25), the knobs' neighbours, the band's inner dts, then every dt of the band and the
        candidate's own at each other impact phase of ``phases`` (module docstring; ``phases`` empty: the ends and
        the knobs, the three-point rule of before). A moved start is ``phase`` (a fraction of a step,
        ``studies.phases``); every band run carries its ``phase``, so none is a lattice setting."""
        dt = p["dt"]
        # exactly x 0.8 and x 1.25, as a user checks it: not the lattice's adjacent values (3 significant digits,
        # x 1.2535 say), for the landscape is fragmented enough that the two can differ (bouncing-ball, PyBullet:
        # 0.00758 passes where 0.007575 = 0.00606 x 1.25 is late)
        ends = [{**p, "dt": float(f"{dt * factor:.6g}")} for factor in (1.0 / DT_RATIO, DT_RATIO)]
        groups = [ends, self._knob_neighbours(p)]
        if phases:
            lo, hi = ends[0]["dt"], ends[1]["dt"]
            inner = [d for d in band_dts(lo, hi) if d not in (lo, hi, dt)]
            groups.append([{**p, "dt": d, "phase": 0.0} for d in inner])
            groups.append([{**p, "dt": d, "phase": float(ph)} for ph in phases if ph != 0.0
                           for d in sorted({lo, *inner, dt, hi})])
        return groups

    def _knob_neighbours(self, p: dict[str, Any]) -> list[dict[str, Any]]:
        """The main knob's adjacent values, and half-way to the adjacent values of every other real-valued knob."""
        out: list[dict[str, Any]] = []
        if self.knob is not None:
            v, vals = p[self.knob], self.knob_values
            out += [{**p, self.knob: w} for w in ([max((u for u in vals if u < v), default=None),
                                                    min((u for u in vals if u > v), default=None)]) if w is not None]
        for k, vals in self.others.items():
            if not _real(vals) or len(set(vals)) < 2:
                continue
            ordered = sorted(set(vals))
            log = axis_scale(ordered) == "log"
            for w in (max((u for u in ordered if u < p[k]), default=None), min((u for u in ordered if u > p[k]), default=None)):
                if w is not None:
                    mid = math.sqrt(w * p[k]) if log else 0.5 * (w + p[k])
                    out.append({**p, k: float(f"{mid:.6g}")})
        return out

    def describe(self) -> dict[str, Any]:
        """The searched space in numbers: ranges, the coarse grid's shape and the refinement (``recommended.json``)."""
        out: dict[str, Any] = {"dt": [min(self.dt), max(self.dt)], "dt_coarse": len(self.coarse(self.dt)),
                               "dt_finest_ratio": DT_RATIO if len(self.dt) > 1 else None}
        if self.knob is not None:
            out[self.knob] = [min(self.knob_values), max(self.knob_values)]
            out[f"{self.knob}_coarse"] = len(self.coarse(self.knob_values))
        out.update({k: list(v) for k, v in self.others.items()})
        out["refine_depth"] = self.depth
        return out


def band_rule(phases: tuple[float, ...], fraction: float) -> dict[str, Any]:
    """How robustness was checked (``recommended.json``'s ``searched.band``): the band of dt factors, how finely its
    dts and the bisection below the lattice are spaced, the impact phases and the share that must pass."""
    return {"dt_factors": list(BAND), "dt_ratio": BAND_RATIO if phases else None, "phases": sorted({0.0, *phases}),
            "robust_fraction": fraction, "bisection_ratio": BAND_RATIO if phases else None,
            "rule": (f"every dt of [{BAND[0]:g}, {BAND[1]:g}] x dt ({BAND_RATIO:.4f}x apart, both ends included) at "
                     f"phases {', '.join(f'{p:g}' for p in sorted({0.0, *phases}))} of a step, and the knobs' neighbours"
                     if phases else "dt x 0.8 and x 1.25 and the knobs' neighbours")
            + ("" if fraction >= 1 else f"; {fraction:.0%} of them must pass")}


def dt_range(solution: ReferenceSolution, tol: Tolerances) -> tuple[float, float]:
    """The coarsest dt worth trying and the finest needed [s], from the scene's own scales (``tune.space``'s module docstring).

    The tightest timing tolerance in seconds: each episode's sticking and first-impact tolerance
    (fractions of its chatter duration, or of its sliding for a visit that starts in contact) and
    exit tolerance (of its sliding duration); the flight: the length scale at the fastest strike.
    """
    eps = solution.episodes
    limits = [tol.stick * eps["stick_scale"], tol.first_impact * eps["stick_scale"], tol.exit * eps["sliding_duration"]]
    timing = pd.concat(limits).astype(float)
    timing = timing[(timing > 0) & timing.map(math.isfinite)]
    flight = solution.length_scale / solution.v_max if solution.v_max > 0 else math.nan
    scales = ([float(timing.min())] if len(timing) else []) + ([flight / FLIGHT_STEPS] if math.isfinite(flight) else [])
    coarse = min(scales, default=solution.scene.time_scale / 100)
    return coarse * FINEST, coarse
