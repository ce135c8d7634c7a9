"""Where a sampled trajectory sticks and leaves a wall, and how far the samples let each time be off.

    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons.pipeline.extract import extract
    >>> from chatterbench.comparisons import reference_trajectory
    >>> scene = load_scene("bouncing-ball")
    >>> found = extract(reference_trajectory(scene, dt=1e-3), scene, stick_tolerance=0.045)
    >>> found.sticks[["t_stick", "stick_bound", "stick_from"]].round(4).values.tolist()   # Zeno point 1.3546 s
    [[1.3546, 0.0004, 'landing']]

Rules 3 and 4 of ``extract.py`` (which bounces matter, the engine's own ladder), with the
*bound* of each time: how far the samples let the true time lie from the one given [s],
which the judge holds against the tolerance (``judge.py``: a bound over the tolerance makes
the criterion ``unresolved`` unless the error is beyond the tolerance even so).

- **Sticking start** (``stick_from``): ``ladder``, the engine's own ladder extrapolated,
  t_release[K] + f_K / (1 - rho); its bound is the extrapolated part, f_K rho / (1 - rho)
  (the samples see the ladder up to t_release[K] + f_K; exact for a geometric ladder, and
  what an engine could do otherwise is unseen). ``feigin``: Feigin's ladder from the
  onset, t_on + f / (1 - R) with f = 2 v+ / |a| the onset's own flight (its measured rebound
  under the scene's y''); bound the part past that flight, f R / (1 - R), which the samples
  do not resolve. ``contact``: a single contact that sticks at its onset,
  bound the onset time's own (0 where the free parabola reaches the wall, else a step).
  ``rest``: the samples at rest overrule an extrapolation: the stuck stretch ends in a
  contact that lasts until the exit or the end of the data (the body rests on the wall), so
  the sticking start is no later than that contact's first sample, whatever the ladder says;
  where the ladder said later, it is that contact's onset, bound the step it lies in.
  ``landing`` (issue 45): where a ladder (``ladder``, ``feigin``) ends in that rest and the
  last free sample before it is in flight, the samples show more than the ladder: that
  sample's own state (d [m], u [m/s], the pressing y'' a [m/s^2]) lands the body at t_in (the
  free parabola's root) with speed w = sqrt(u^2 + 2 |a| d), after a flight f = 2 w / |a|;
  the next sample is at rest (t_rest). The sticking start is t_in + f rho / (1 - rho), the
  ladder's tail after that landing (rho: its ratio), at most t_rest; its bound is what the
  samples leave open, max(t - t_in, t_rest - t) < t_rest - t_in <= one step: the unseen
  bounces may end at the landing or go on to the rest, nothing in the samples says which.
  (The extrapolated part, f_K rho / (1 - rho) or f R / (1 - R), stays the bound where no
  sample at rest closes the ladder; on the shaker at 1 ms it was 4 ms, 150x the error.)
  Taken only where t_in lies within the ladder's own tail (its time +- its bound): a landing
  later than that is a bounce after the rest (a buzz), not the ladder's last.
- **Exit**: the release of the stretch's last contact; bound the step it lies in (half a
  step at its middle), or where the force decays smoothly, how far a quadratic through the
  last three force samples puts the zero from the linear one (``wall_impacts._release_times``).

Times in seconds throughout; the bound is symmetric (the true time within t +- bound).

Whether a flight is shorter than the one before, and the flights shrank by more than a step, are judged on the step
grid (``sample_grid``: two flights of the same steps are equal, a shrink of one step is not more than one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .sample_grid import more_than_a_step, shorter

STICK_COLUMNS = ["wall", "t_stick", "stick_bound", "stick_from", "t_exit", "exit_bound"]


@dataclass(frozen=True)
class Stick:
    """A sticking start [s], how far the samples let it be off [s], and how it was found (module docstring)."""

    t: float
    bound: float
    source: str  # ladder | feigin | contact | rest | landing
    ratio: float = math.nan  # the ladder's ratio the time was extrapolated with (ladder: rho; feigin: R), NaN: none


def stuck_stretches(imp: dict, band: np.ndarray, held: np.ndarray, f_min: float) -> list[tuple[int, int, bool]]:
    """(onset, last, released) of every stuck stretch (``extract.py``, rule 3): impact indices,
    and whether the bodies separate after ``last`` (False: the data end inside the band).

    A stretch starts at a slow impact (pressing, flight within its band) and takes the
    following impacts while each flight stays within the stretch's band, which never
    shrinks below the onset's (near an exit |a| -> 0, but the bodies have not moved apart).
    """
    out, m, i = [], len(band), 0
    apex, a_on = imp["apex"], imp["a_onset"]
    n_s = imp["n_samples"]
    while i < m:
        # a flight cut short by the end of the data cannot start a stretch (a bounce may be under
        # way), nor can a contact the data end in unless the bodies are at rest in it (too slow
        # to fly, as for a single contact below) or it is the initial rest
        judged = imp["next_first"][i] < n_s
        resting = a_on[i] < 0.0 and abs(imp["u_last"]) <= -a_on[i] * f_min / 2.0
        if (band[i] > 0 and apex[i] <= band[i] and judged) or (held[i] and (imp["first"][i] == 0 or resting)):
            j, h = i, band[i]
            while j < m and (held[j] or apex[j] <= max(h, band[j])):
                h = max(h, band[j])
                j += 1
            out.append((i, min(j, m - 1), j < m and not held[j]))
            i = j + 1
            continue
        # one contact that starts pressing and lets go where the pressing has ended, too slowly
        # to fly: perfectly inelastic, or a soft contact that never rebounds
        if imp["contact"][i] and a_on[i] < 0.0 and imp["a_release"][i] >= 0.0 and np.isfinite(imp["v_plus"][i]) and \
                imp["v_plus"][i] <= -a_on[i] * f_min / 2.0:
            out.append((i, i, True))
        i += 1
    return out


def sticking_start(imp: dict, i: int, j: int, restitution: float, dt: float) -> Stick:
    """When the stuck stretch of impacts ``i`` .. ``j`` (one wall) starts sticking, from its ladder (module docstring).

    The engine's own ladder: from the onset, the run of bounces (a contact shorter than the
    flight after it) whose flights keep shrinking, i .. K. When they shrank by more than a
    step (what a flight is measured to), their mean ratio rho = (f_K / f_i)^(1 / (K - i))
    extrapolates the rest: t_release[K] + f_K / (1 - rho), with f_K no longer than K's rebound
    implies (2 v+ / |a|: the last flight the samples see may span bounces too short to see). Otherwise Feigin's ladder from the onset:
    t_i + 2 v+ / ((1 - R) |a|) (the onset itself for a held contact).
    """
    t_on = float(imp["t"][i])
    flight = imp["flight"]
    k = i
    bounce = imp["t_release"] - imp["t"] <= flight  # a contact as long as the flight after it is a rest, not a bounce
    while k < j and np.isfinite(flight[k + 1]) and 0.0 < flight[k + 1] and shorter(flight[k + 1], flight[k], dt) \
            and bounce[k + 1]:
        k += 1
    if k > i and np.isfinite(flight[i]) and more_than_a_step(flight[i] - flight[k], dt):
        # the last flight the samples see may span bounces too short to see: no longer than its rebound implies
        a_k, v_k = float(imp["a_release"][k]), float(imp["v_plus"][k])
        f_k = min(float(flight[k]), 2.0 * v_k / -a_k) if a_k < 0 and v_k > 0 else float(flight[k])
        rho = (f_k / flight[i]) ** (1.0 / (k - i))
        rest = f_k * rho / (1.0 - rho)  # the extrapolated part, past what the samples see
        return Stick(max(t_on, float(imp["t_release"][k]) + f_k + rest), rest, "ladder", rho)
    v_plus, a = imp["v_plus"][i], imp["a_release"][i]
    if j > i and a < 0.0 and np.isfinite(v_plus) and v_plus > 0 and restitution < 1:
        flight = 2.0 * float(v_plus) / float(-a)  # the onset's own flight: its rebound speed under the scene's y''
        return Stick(t_on + flight / (1.0 - restitution), flight * restitution / (1.0 - restitution), "feigin", restitution)
    return Stick(t_on, float(imp["t_bound"][i]), "contact")


def at_rest(stick: Stick, imp: dict, i: int, j: int, t: np.ndarray, held: np.ndarray, released: bool) -> Stick:
    """``stick`` no later than the samples at rest (module docstring): the stretch ``i`` .. ``j`` ending in a
    contact that lasts until the exit (``released``) or the end of the data (``held``)."""
    if not (imp["contact"][j] and (released or held[j])):
        return stick
    cap = float(t[int(imp["first"][j])])  # the first sample of the rest
    if stick.t <= cap:
        return stick
    # the ladder would have the body bounce on while the samples show it resting: it rests from that
    # contact's onset, known to the step it lies in (0 where the free parabola reaches the wall)
    t_in = float(imp["t"][j])
    return Stick(t_in, max(float(imp["t_bound"][j]), cap - t_in), "rest")


def _tail(flight: float, ratio: float) -> float:
    """The chatter after a flight of ``flight`` [s] of a geometric ladder of ``ratio``: flight rho / (1 - rho) [s]."""
    return flight * ratio / (1.0 - ratio) if ratio < 1.0 else math.inf


def last_landing(stick: Stick, imp: dict, i: int, j: int, t: np.ndarray, held: np.ndarray, released: bool) -> Stick:
    """``stick`` (``at_rest``'s) placed from the last landing the samples show (module docstring, ``landing``), or
    as it is where they show none: a single contact, a time without a ladder ratio (``contact``, ``rest``), a
    stretch that does not end at rest, a last free sample whose parabola misses the wall."""
    w, a = float(imp["land_speed"][j]), float(imp["a_onset"][j])
    if j == i or not math.isfinite(stick.ratio) or not (imp["contact"][j] and (released or held[j])) \
            or float(imp["t_bound"][j]) > 0 or not (w > 0 and a < 0):
        return stick
    cap = float(t[int(imp["first"][j])])  # the first sample of the rest
    t_in = float(imp["t"][j])  # where the flight of the last free sample lands
    if abs(t_in - stick.t) > stick.bound:
        return stick  # a landing outside the ladder's own tail (a bounce after the rest, a buzz): not its last
    flight = 2.0 * w / -a  # that flight's length [s], from the sample's own state
    t_est = min(t_in + _tail(flight, stick.ratio), cap)
    # the samples show the body landing at t_in and at rest at cap: the true start is in between, whatever the
    # unseen bounces did (they may stop at the landing or go on until the rest)
    return Stick(t_est, max(t_est - t_in, cap - t_est), "landing", stick.ratio)


def stick_rows(wall: str, stretches: list, imp: dict) -> list[dict]:
    """``STICK_COLUMNS`` rows of one wall's stuck stretches ((i, j, released, Stick, end) each)."""
    rows = []
    for i, j, released, stick, end in stretches:
        rows.append({"wall": wall, "t_stick": stick.t, "stick_bound": stick.bound, "stick_from": stick.source,
                     "t_exit": end if released else math.nan,
                     "exit_bound": float(imp["release_bound"][j]) if released else math.nan})
    return rows


def stick_frame(rows: list[dict]) -> pd.DataFrame:
    """The sticks of every wall, by time (``STICK_COLUMNS``)."""
    frame = pd.DataFrame(rows, columns=STICK_COLUMNS)
    return frame.sort_values("t_stick", kind="stable").reset_index(drop=True)
