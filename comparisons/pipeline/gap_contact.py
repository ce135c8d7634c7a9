"""Contact read from the gap alone, for samples without a contact force: the positions' precision and where they rest.

    >>> import numpy as np
    >>> from chatterbench.comparisons.pipeline.gap_contact import infer_precision
    >>> x = np.array([19.861952, 0.1, -3.25])                  # what a float32 exporter writes
    >>> infer_precision(x), infer_precision(x + 1e-9)
    ('float32', 'float64')

A file's samples say where body 2 is, not whether a wall holds it. Rule 1 of ``extract.py``
takes a sample as in contact with a wall when y = x2 - x1 is on the wall or past it; this
module says what "on" means for the numbers in the file:

- **Precision.** Positions pass through the exporter's floating-point type: x2 - x1 of a body
  resting on a wall comes out within a few roundings of the wall, not on it. The slack is
  ``ROUNDING`` roundings of the largest of |x1|, |x2| and |wall| (16 x 2.2e-16 relative for
  float64; 16 x 1.2e-7 for float32: 3.8e-5 m at 20 m, where feigin-pair's x1 drifts). A
  sample within the slack but moving away from the wall faster than its velocities' own
  rounding is free: a zero-speed lift-off rises as t^3, far below a float32 slack, while its
  speed rises as t^2, well above its rounding. The precision is declared (``--precision``) or
  inferred: positions that are all float32 numbers (their float32 rounding, or the shortest
  text of it, as numpy and pandas write float32) are float32.
- **Resting offset.** An engine may hold a resting body off the wall: a contact skin (Box2D's
  polygon radius keeps a ball about 1 cm above its floor) or a steady penetration (a position
  correction that leaves some overlap). A body *held* against the free motion (y'' of the
  scene presses it into the wall, yet its velocity stays under |y''| dt / 2 for at least
  ``HELD_SAMPLES`` samples in a row) rests; the median of its distance from the wall over those
  samples is the offset, reported when it is beyond both the rounding and a one-step flight's
  apex (|y''| dt^2 / 8: a chatter too fine to sample looks held at that height). A skin (> 0)
  moves the wall's surface there for everything the extraction measures, with or without
  force columns; a steady penetration (< 0, spread under a quarter of it) moves where a
  gap-only file's contact ends, so the body leaves the wall where it leaves its resting level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chatterbench.reference.scene import Scene

ROUNDING = 16.0  # [roundings] y within this many of a wall is on it
PRECISIONS = {"float64": float(np.finfo(np.float64).eps), "float32": float(np.finfo(np.float32).eps)}
HELD_SAMPLES = 4  # [samples] in a row held against the free motion: a rest (extract.py's floor of 4 steps)
_PROBE = 4096  # values of each column examined for the precision


def infer_precision(*columns: np.ndarray) -> str:
    """``float32`` when every finite value (up to ``_PROBE`` per column, spread over it) is a float32 number
    or the shortest text of one; else ``float64``."""
    for values in columns:
        v = np.asarray(values, dtype=float)
        v = v[np.isfinite(v)]
        if len(v) > _PROBE:
            v = v[np.linspace(0, len(v) - 1, _PROBE).astype(np.int64)]
        with np.errstate(over="ignore", invalid="ignore"):
            v32 = v.astype(np.float32)
        if not np.all((v32.astype(float) == v) | (v32.astype(str).astype(float) == v)):
            return "float64"
    return "float32"


def rounding(precision: str, *values: np.ndarray) -> np.ndarray:
    """``ROUNDING`` roundings of the largest magnitude among ``values`` at each sample (arrays or scalars)."""
    largest = np.abs(np.asarray(values[0], dtype=float))
    for v in values[1:]:
        largest = np.maximum(largest, np.abs(np.asarray(v, dtype=float)))
    return ROUNDING * PRECISIONS[precision] * largest


@dataclass(frozen=True)
class RestingOffset:
    """Where body 2 rests on a wall, as its distance from the wall [m] (> 0 outside the gap), measured on
    ``samples`` held samples whose distances spread ``spread`` [m] around it."""

    wall: str
    offset: float
    spread: float
    samples: int

    @property
    def skin(self) -> bool:
        """A skin: the body rests outside the gap, off the wall (the wall's surface moves there)."""
        return self.offset > 0

    @property
    def steady(self) -> bool:
        """A steady offset: its spread under a quarter of it (a slop or skin, not a load-dependent spring)."""
        return self.spread < abs(self.offset) / 4

    def describe(self) -> str:
        """One line: where the body rests, and what the judge does with it."""
        where = "above" if self.skin else "inside"
        what = ("a contact skin: the wall's surface is taken there" if self.skin else
                "a steady penetration: contact ends where the body leaves it" if self.steady else
                "a penetration that changes with the load (a soft contact): contact ends at the wall")
        return (f"body 2 rests {_length(abs(self.offset))} {where} the {self.wall} wall ({self.samples} held samples, "
                f"spread {_length(self.spread)}): {what}")


def _length(metres: float) -> str:
    """A length for a message: in mm from 0.1 mm up, else in micrometres."""
    return f"{metres * 1e3:.3g} mm" if metres >= 1e-4 or metres == 0 else f"{metres * 1e6:.3g} um"


def _held(u: np.ndarray, a: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Samples in runs of at least ``HELD_SAMPLES`` pressed into the wall (a < 0) yet moving under |a| h / 2."""
    held = (a < 0.0) & (np.abs(u) <= 0.5 * np.abs(a) * h)
    edges = np.diff(np.concatenate(([0], held.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    long = stops - starts >= HELD_SAMPLES
    marks = np.zeros(len(u) + 1, np.int64)  # +1 where a long run starts, -1 past its end: their running sum
    np.add.at(marks, starts[long], 1)
    np.add.at(marks, stops[long], -1)
    return np.cumsum(marks[:-1]) > 0


def resting_offsets(scene: Scene, t: np.ndarray, y: np.ndarray, vy: np.ndarray, acc: np.ndarray,
                    slack: np.ndarray) -> dict[str, RestingOffset]:
    """Per wall, where body 2 rests when it is held off the wall or in it (module docstring); walls it
    rests on, within the rounding ``slack`` [m] and a one-step flight's apex, are left out.

    ``t``, ``y``, ``vy``, ``acc`` (the scene's free y'' [m/s^2]), ``slack``: per sample, shape (n,).
    """
    h = np.gradient(t) if len(t) > 1 else np.ones_like(t)
    out = {}
    for wall in scene.gap.walls:
        n = 1.0 if wall == "lower" else -1.0
        d = n * (y - scene.gap.position(wall))
        a = n * acc
        held = _held(n * vy, a, h) & (np.abs(d) < 0.5 * _span(scene, y))
        if not held.any():
            continue
        offset = float(np.median(d[held]))
        chatter = float(np.median(np.abs(a[held]) * h[held] ** 2)) / 8.0
        if abs(offset) <= max(float(np.median(slack[held])), 2.0 * chatter):
            continue
        spread = float(np.percentile(np.abs(d[held] - offset), 90))
        out[wall] = RestingOffset(wall, offset, spread, int(held.sum()))
    return out


def _span(scene: Scene, y: np.ndarray) -> float:
    """The room body 2 has: the gap's width, or for a one-sided gap its largest distance from the wall [m]."""
    if scene.gap.upper is not None:
        return scene.gap.upper - scene.gap.lower
    return float(np.nanmax(np.abs(y - scene.gap.lower))) if len(y) else 0.0


def on_wall(scene: Scene, x1: np.ndarray, x2: np.ndarray, v1: np.ndarray, v2: np.ndarray, precision: str = "float64",
            offsets: dict[str, RestingOffset] | None = None) -> dict[str, np.ndarray]:
    """Contact inferred from the gap, per wall (module docstring): y on the wall or past it to the positions'
    rounding, unless moving away from it faster than the velocities' rounding; a skin or a steady penetration
    moves "on the wall" to the resting level (its spread, or the rounding, around it)."""
    out = {}
    vel_slack = rounding(precision, v1, v2)
    for wall in scene.gap.walls:
        y_wall = scene.gap.position(wall)
        n = 1.0 if wall == "lower" else -1.0
        slack = rounding(precision, x1, x2, y_wall)
        d = (x2 - x1 - y_wall) * n
        rest = (offsets or {}).get(wall)
        if rest is not None and (rest.skin or rest.steady):
            d = d - rest.offset
            slack = np.maximum(slack, 2.0 * rest.spread)
        moving = np.abs(v2 - v1) > vel_slack  # arriving or leaving: within the rounding, in flight
        out[wall] = (d < -slack) | ((d <= slack) & ~moving)
    return out
