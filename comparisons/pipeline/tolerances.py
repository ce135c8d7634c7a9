"""What the judge accepts: tolerances as fractions of each reference episode's own physical scales.

    >>> from chatterbench.comparisons.pipeline.tolerances import Tolerances, tolerances_from_items
    >>> tolerances_from_items(["stick=0.1", "exit=0.01"]).stick
    0.1
    >>> Tolerances().describe()
    'stick within 5% of the chatter, exit within 2% of the sliding, first impact within 5% of the chatter, restitution within 5%, resolved impacts within 1, penetration under 10% of the length scale, contact open under 1% of the rest after the stick'

Scales come from the physics of each reference visit to a wall, never from the run
(its duration, the forcing period, the engine's settings):

- chatter duration: Zeno point - first impact of the visit [s]; the sticking start and the
  first impact are judged against it (a visit that starts in contact has no chatter: its
  sliding duration stands in);
- sliding duration: exit - Zeno point [s]; the exit is judged against it (no exit, no check);
- first impact speed: |y'| at the visit's first impact [m/s] (reported as a scale);
- length scale: the gap width, or for a one-sided gap the reference's largest distance from
  its wall [m]; penetration is judged against it, the same for every engine.

The resolved impacts of a visit (those whose flight lasts at least ``resolved_steps``
timesteps: ``pipeline.impacts``) must follow R to ``restitution`` (relative) and agree in
number to ``impact_count``. ``energy_gain`` bounds the relative kinetic energy (a
blow-up alarm, relative to the reference's largest), ``endless_impacts`` the impacts an
engine may make inside a reference sliding stretch before it counts as chattering through.
``persistence`` bounds the share of an episode's rest after the stick that its contact is open
(``persistence.py``): 1% by default, a contact a user would call at rest. Every engine measured
at rest holds its contact for all of it (0%: PyBullet with a restitution threshold, PhysX, DART,
Siconos, the exact reference), while every flicker measured on the bouncing ball opens it for
3% or more (MuJoCo's limit cycles 4.8-12.5%, PyBullet's bounce at |y''| dt 67%); a rare late
settling bounce of a resting soft contact (MuJoCo, 2 in 8 s: 0.02%) stays well inside it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

from chatterbench.reference.errors import InputError, check_integer, check_number, did_you_mean
from chatterbench.reference.scene import TIME_RESOLUTION, split_assignment


class ToleranceError(InputError):
    """A tolerance that is unknown or out of range; the message names it and what is allowed."""


# the smallest fraction tolerance: the scene's times resolve to 1 / TIME_RESOLUTION of a run (reference/scene.py)
MIN_FRACTION = 1.0 / TIME_RESOLUTION
_FRACTIONS = ("stick", "exit", "first_impact", "restitution", "penetration", "persistence")


@dataclass(frozen=True)
class Tolerances:
    """Verdict tolerances; fractions of the episode's scales unless noted (module docstring)."""

    stick: float = 0.05  # |sticking start - Zeno point| <= stick x chatter duration, in (0, 1]
    exit: float = 0.02  # |exit error| <= exit x sliding duration, in (0, 1]
    first_impact: float = 0.05  # |first impact error| <= first_impact x chatter duration, in (0, 1]
    restitution: float = 0.05  # |effective R / R - 1| of every resolved impact, in (0, 1]
    impact_count: int = 1  # |resolved impacts - the reference's| allowed, integer >= 0
    penetration: float = 0.1  # largest penetration <= penetration x length scale, in (0, 1]
    resolved_steps: float = 10.0  # a flight this many timesteps long or longer is resolved, > 1
    energy_gain: float = 1.0  # kinetic energy above (1 + energy_gain) x the reference's largest: diverged, > 0
    endless_impacts: int = 10  # engine impacts inside a reference sliding stretch that make it endless, >= 1
    # largest share of an episode's rest window (after the stick, ``persistence.py``) its contact may be open, in (0, 1]
    persistence: float = 0.01

    def __post_init__(self) -> None:
        err = ToleranceError
        for name in _FRACTIONS:
            value = check_number(f"tolerance {name}", getattr(self, name), lo=0.0, hi=1.0, lo_open=True, error=err)
            if value < MIN_FRACTION:
                raise err(f"tolerance {name} = {value!r}: must be in (0, 1] and at least {MIN_FRACTION:g} (event "
                          f"times resolve to {MIN_FRACTION:g} of a run, TIME_RESOLUTION: a finer tolerance judges rounding)")
        check_number("tolerance resolved_steps", self.resolved_steps, lo=1.0, lo_open=True, hi=1e6, error=err)
        check_number("tolerance energy_gain", self.energy_gain, lo=0.0, lo_open=True, hi=1e6, error=err)
        check_integer("tolerance impact_count", self.impact_count, lo=0, hi=10**9, error=err)
        check_integer("tolerance endless_impacts", self.endless_impacts, lo=1, hi=10**9, error=err)
        for name in ("stick", "exit", "first_impact", "restitution", "penetration", "resolved_steps", "energy_gain",
                     "persistence"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def as_dict(self) -> dict[str, Any]:
        """Plain data (provenance, sweep rows, gate run keys)."""
        return dataclasses.asdict(self)

    def describe(self) -> str:
        """One line for reports and guides."""
        pct = lambda v: f"{100 * v:g}%"  # noqa: E731
        return (f"stick within {pct(self.stick)} of the chatter, exit within {pct(self.exit)} of the sliding, "
                f"first impact within {pct(self.first_impact)} of the chatter, restitution within {pct(self.restitution)}, "
                f"resolved impacts within {self.impact_count}, penetration under {pct(self.penetration)} of the length scale, "
                f"contact open under {pct(self.persistence)} of the rest after the stick")


TOLERANCE_KEYS = tuple(f.name for f in dataclasses.fields(Tolerances))
# what each tolerance bounds, as the judge applies it (judge.py): the provenance of reports reads this
_MEANINGS = {
    "stick": "|sticking start - Zeno point| <= {pct} of the episode's chatter duration",
    "exit": "|exit error| <= {pct} of the episode's sliding duration",
    "first_impact": "|first impact error| <= {pct} of the episode's chatter duration",
    "restitution": "|e / R - 1| <= {pct} at every resolved impact measured to {pct} (others: unmeasured, not passed)",
    "impact_count": "resolved impacts within {v} of the reference's",
    "penetration": "deepest penetration <= {pct} of the scene's length scale",
    "resolved_steps": "an impact is resolved when its flight, as the samples see it on both sides, lasts {v} timesteps or more",
    "energy_gain": "diverged above (1 + {v}) x the reference's largest kinetic energy",
    "endless_impacts": "{v} engine impacts inside a reference sliding make the episode endless",
    "persistence": "after the stick (from the sticking tolerance past it to the exit tolerance before the exit), the "
                   "contact is open at most {pct} of the time (else buzz)",
}
SCALES = ("each reference episode's own chatter duration = Zeno point - first impact of its visit (a visit that starts "
          "in contact: its sliding duration) and sliding duration = exit - Zeno point of that visit; the scene's length "
          "scale = the gap width, or for a one-sided gap the reference's largest distance from its wall")


def explain(tol: Tolerances) -> str:
    """Every tolerance with its value and what it bounds, against which scale (the reports' provenance).

    Scales are each reference episode's own (module docstring), never the run's or the scene's duration.
    """
    parts = [f"{key} = {getattr(tol, key):g}: " + _MEANINGS[key].format(v=f"{getattr(tol, key):g}",
                                                                          pct=f"{100 * getattr(tol, key):g}%")
             for key in TOLERANCE_KEYS]
    return "; ".join(parts) + f". Scales: {SCALES}"
TIMING_KEYS = ("stick", "exit", "first_impact")  # what a single ``--tolerance T`` sets (tune)


def make_tolerances(values: Mapping[str, Any] | None = None, base: Tolerances | None = None, where: str = "tolerances") -> Tolerances:
    """``base`` (default ``Tolerances()``) with ``values`` replaced; unknown keys refused with a suggestion."""
    values = dict(values or {})
    for key in values:
        if key not in TOLERANCE_KEYS:
            name = f"{where} {key}" if where.startswith("--") else f"{where}.{key}"
            raise ToleranceError(f"{name}: unknown tolerance{did_you_mean(str(key), TOLERANCE_KEYS)}; "
                                 f"allowed: {', '.join(TOLERANCE_KEYS)}")
    return dataclasses.replace(base or Tolerances(), **values)


def tolerance_values(items: Iterable[str]) -> dict[str, Any]:
    """The values ``--tolerance`` items give, by key (validated: unknown keys and bad values are refused);
    a bare number stands for the timing tolerances (stick, exit, first_impact) at once.

    Each key gets one value: two items that set it to two values (``stick=0.3`` and a bare ``0.2``, or two bare
    numbers) are refused naming both, whatever their order (before, the last one won without a word)."""
    values: dict[str, Any] = {}
    given: dict[str, str] = {}  # key -> the item that set it
    for item in items:
        text = str(item).strip()
        if "=" not in text:
            try:
                number = float(text)
            except ValueError:
                raise ToleranceError(f"--tolerance {text!r}: expected KEY=VALUE with KEY one of {', '.join(TOLERANCE_KEYS)}, "
                                     "or one number for stick, exit and first_impact together") from None
            pairs = {k: number for k in TIMING_KEYS}
        else:
            key, value = split_assignment(text)
            pairs = {key: value}
        for key, value in pairs.items():
            if key in values and values[key] != value:
                both = " and ".join(f"--tolerance {t}" + ("" if "=" in t else f" (sets {', '.join(TIMING_KEYS)})")
                                    for t in (given[key], text))
                raise ToleranceError(f"{both}: two values for {key}; give each tolerance once (a bare number, or "
                                     f"{', '.join(f'{k}=' for k in TIMING_KEYS)} each)")
            values[key], given[key] = value, text
    make_tolerances(values, where="--tolerance")
    return values


def tolerances_from_items(items: Iterable[str], base: Tolerances | None = None) -> Tolerances:
    """Tolerances from ``--tolerance`` items (``tolerance_values``) over ``base`` (default ``Tolerances()``)."""
    return make_tolerances(tolerance_values(items), base, where="--tolerance")
