"""Pair an engine's episodes with the reference's and give each a verdict from the physics of that visit.

    >>> from chatterbench.comparisons.pipeline.judge import Tolerances, judge
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import reference_trajectory
    >>> from chatterbench.comparisons.pipeline.extract import extract
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> tol = Tolerances()
    >>> ref = solve(load_scene("bouncing-ball"))
    >>> traj = reference_trajectory(ref.scene, 1e-3, ref.exhaustive)        # or an engine's
    >>> judged = judge(ref, extract(traj, ref.scene, ref.stick_tolerance(tol.stick)), traj, tol)
    >>> judged.table[["wall", "verdict", "resolved_impacts", "ref_resolved_impacts"]].values.tolist()
    [['lower', 'match', 6, 6]]

Pairing: an engine episode belongs to the reference episode on the same wall whose visit
(first impact to exit) overlaps its own the most; each is used once. Errors are engine
minus reference: in seconds, as a fraction of the visit's scale (``_rel``; ``tolerances.py``)
and in timesteps (``_steps``):

- ``stick_error_zeno``: sticking start against the Zeno point (the true start; judged);
  ``stick_error_plate`` against Feigin's plate entry (the idealised model; reported);
- ``exit_error``: separation; ``first_impact_error``: the visit's first impact;
- ``restitution_error``: the relative error of the visit's worst measurable resolved impact
  (``impacts.py``), with ``resolved_impacts``, ``ref_resolved_impacts`` and
  ``unmeasured_impacts`` (paired resolved impacts the step cannot measure to the tolerance);
- ``penetration_max`` [m]: the deepest penetration of any wall from the end of the
  previous reference visit to this one's exit;
- ``first_impact_bound``, ``stick_bound``, ``exit_bound`` [s]: how far the samples let the
  engine's time be off (``sticking.py``): the extrapolated part of a ladder, the step an
  exit or an impact lies in;
- ``reason``: why the episode is not ``match``, in one line ("" when it is).

Verdicts (``vocabulary.py``; each row's in ``verdict_rules.py``), the first that applies:

1. the run's failure: ``diverged`` from the time the state went non-finite or the energy
   passed (1 + ``energy_gain``) x the reference's largest; ``error``, ``timeout``,
   ``crashed`` for episodes the run did not finish;
2. ``penetrated``: ``penetration_max`` > ``penetration`` x the scene's length scale;
3. the reference sticks, the engine does not: ``endless`` (``endless_impacts`` or more
   engine impacts inside the reference's sliding), ``unresolved`` where the reference's
   sliding is shorter than the samples can show (``sliding_min``), else ``missed``;
4. the engine sticks, the reference does not: ``spurious``;
5. ``early`` / ``late``: |stick_error_rel| > ``stick``, |first_impact_error_rel| >
   ``first_impact``, |exit_error_rel| > ``exit``, or one of the two stays stuck to the end
   of the run and the other does not (the sign says which). Where a time's bound exceeds its
   tolerance, only an error beyond the tolerance with the bound taken off counts (``timing``):
   never a confident early or late that the step cannot tell;
6. ``rebound``: timing within tolerance (or unresolved), but a measurable resolved impact's
   |e / R - 1| exceeds ``restitution`` (the allowance is the tolerance, whatever the step), or
   the resolved impact counts differ by more than ``impact_count`` (``reason`` says which);
7. ``buzz``: it sticks on time, but after the stick its contact is open more than
   ``persistence`` of the rest (``persistence.py``: the rest window, onsets per second, the
   open share, the largest gap and the force's swing, all in ``reason``);
8. ``unresolved``: a time's bound exceeds its tolerance, and its error is neither beyond
   the tolerance with the bound taken off nor within it with the bound added: the samples
   cannot say (a finer step can: ``reason`` gives the bound and the step that would resolve
   it; the step is the sampling's times the tolerance over the bound, as the bounds scale);
   or the contact after the stick is read from positions too coarse to show a one-step flicker;
9. ``unmeasured``: all of the above holds, but the visit's paired resolved impacts are all
   unmeasured (their uncertainty exceeds ``restitution``: ``impacts.py``), so nothing says
   whether they follow R; unmeasured impacts beside measured ones are counted, not judged;
10. ``match``.

A failure never agrees: when the run failed (status, divergence, penetration) and no
episode row says so, a run row (wall "") carries the failure verdict. Engine episodes that
start after the run diverged are not rows: a diverged run's later samples are no evidence.
"""

from __future__ import annotations

import collections
import functools
import math
from dataclasses import dataclass
from typing import Iterator

import numpy as np
import pandas as pd

from chatterbench.engines.trajectory import Trajectory

from .extract import Extraction
from .impacts import PAIR_COLUMNS, ImpactPairs, pair_impacts, reference_flights
from .persistence import NO_REST, REST_COLUMNS, contact_rest, rest_window
from .solution import ReferenceSolution, overlaps, reduced_mass
from .tolerances import Tolerances
from .verdict_rules import RunFacts, run_failure, run_failure_words, timing, verdict, verdict_reason  # noqa: F401  (the rules: there)
from .vocabulary import combine, rank

ERROR_COLUMNS = ["first_impact_error", "stick_error_plate", "stick_error_zeno", "exit_error",
                 "first_impact_error_rel", "stick_error_rel", "exit_error_rel", "stick_error_steps", "exit_error_steps"]
BOUND_COLUMNS = ["first_impact_bound", "stick_bound", "exit_bound"]  # [s] how far the samples let each time be off
TABLE_COLUMNS = [
    "wall", "ref_t_first_impact", "ref_t_plate_entry", "ref_t_stick", "ref_t_exit", "t_first_impact", "t_stick", "t_exit",
    "n_impacts", "ref_n_impacts", "resolved_impacts", "ref_resolved_impacts",
    "chatter_duration", "sliding_duration", "ref_v_first_impact",
    *ERROR_COLUMNS, *BOUND_COLUMNS, "restitution_error", "unmeasured_impacts", "penetration_max", *REST_COLUMNS,
    "verdict", "reason",
]
IMPACT_PAIR_COLUMNS = ["episode", "wall", *PAIR_COLUMNS]


@dataclass(frozen=True)
class Judgement:
    """The judged episodes (``TABLE_COLUMNS``), their paired impacts, and the run's failure times."""

    table: pd.DataFrame
    impacts: pd.DataFrame  # IMPACT_PAIR_COLUMNS: ``episode`` is the row of ``table``
    t_diverged: float  # [s] NaN if the run never diverged
    t_penetrated: float  # [s] first time past the allowance, NaN if never
    penetration_allowance: float  # [m]


def relative_energy(scene, traj: Trajectory) -> np.ndarray:
    """Kinetic energy of the relative motion, m_red vy^2 / 2 [J], per sample (the divergence alarm's measure)."""
    return 0.5 * reduced_mass(scene) * traj.vy**2


def penetration(scene, y: np.ndarray) -> np.ndarray:
    """How far past a wall each sample is [m] (0 inside the gap)."""
    gap = scene.gap
    with np.errstate(invalid="ignore"):
        out = np.maximum(gap.lower - y, 0.0)
        if gap.upper is not None:
            out = np.maximum(out, y - gap.upper)
    return out


def time_diverged(ref: ReferenceSolution, traj: Trajectory, tol: Tolerances) -> float:
    """First time the state is non-finite or the energy passes its bound [s]; the end of a ``diverged`` run; NaN."""
    t = traj.t
    times = []
    if traj.status == "diverged":
        times.append(float(t[-1]) if len(t) else 0.0)
    bad = ~(np.isfinite(traj.y) & np.isfinite(traj.vy))
    if bad.any():
        times.append(float(t[np.argmax(bad)]))
    with np.errstate(invalid="ignore", over="ignore"):
        grown = relative_energy(ref.scene, traj) > ref.energy_max * (1.0 + tol.energy_gain) + 1e-12
    if grown.any():
        times.append(float(t[np.argmax(grown)]))
    return min(times) if times else math.nan


@functools.lru_cache(maxsize=64)
def _row_type(columns: tuple[str, ...]) -> type:
    return collections.namedtuple("Row", columns, rename=True)


def rows_of(frame: pd.DataFrame) -> Iterator[tuple]:
    """``frame``'s rows as named tuples, the values ``itertuples`` gives (without the index): its row class made once
    per set of columns, not once per call, and its values read as one object array, not a Series per column (a judge
    iterates small tables often: each cost more than the rest of it)."""
    kind = _row_type(tuple(frame.columns))
    return map(kind._make, frame.to_numpy(dtype=object).tolist())


def _pairs(ref_eps: pd.DataFrame, eng_rows: list[tuple]) -> dict[int, int]:
    """Reference row -> engine row (of ``eng_rows``, the engine episodes' ``rows_of``): same wall, largest overlap of
    the visits, each used once."""
    cands = []
    for i, r in enumerate(rows_of(ref_eps)):
        for j, e in enumerate(eng_rows):
            if e.wall != r.wall:
                continue
            e0 = e.t_first_impact if not math.isnan(e.t_first_impact) else e.t_stick
            o = overlaps(r.t_first_impact, r.t_exit, e0, e.t_exit)
            if o >= 0:
                cands.append((-o, abs(e.t_stick - r.t_stick), i, j))
    out, used = {}, set()
    for _, _, i, j in sorted(cands):
        if i not in out and j not in used:
            out[i] = j
            used.add(j)
    return out


class _Found:
    """An extraction's impacts and sticks as arrays, for a judge's per-episode questions (which impacts a visit holds,
    how many count, an episode's bounds): one pandas mask per question cost more than the rest of the judging."""

    def __init__(self, found: Extraction):
        self.impacts, self.sticks = found.impacts, found.sticks
        self.wall = self.impacts["wall"].to_numpy(dtype=object)
        self.t = self.impacts["t"].to_numpy(dtype=float)
        self.stuck = self.impacts["stuck"].to_numpy(dtype=bool)
        self.stick_wall = self.sticks["wall"].to_numpy(dtype=object)
        self.t_stick = self.sticks["t_stick"].to_numpy(dtype=float)
        self.paired = {c: self.impacts[c].to_numpy(dtype=float) for c in ("t", "v_minus", "v_plus", "v_error", "flight_seen")}
        self.stick_bound = self.sticks["stick_bound"].to_numpy(dtype=float)
        self.exit_bound = self.sticks["exit_bound"].to_numpy(dtype=float)
        self.t_bound = self.impacts["t_bound"].to_numpy(dtype=float)

    def _on(self, wall: str, t0: float, t1: float) -> np.ndarray:
        t1 = math.inf if math.isnan(t1) else t1
        return (self.wall == wall) & (self.t >= t0) & (self.t <= t1)

    def visit_columns(self, wall: str, t0: float, t1: float) -> dict[str, np.ndarray]:
        """Every engine impact on ``wall`` in [t0, t1] (NaN t1: to the end), stuck micro-bounces included (which of
        them are resolved is the flight's business, ``impacts.pair_impacts``, not the stick's): the columns
        ``pair_impacts`` reads, as arrays."""
        on = self._on(wall, t0, t1)
        return {c: values[on] for c, values in self.paired.items()}

    def count(self, wall: str, t0: float, t1: float) -> int:
        """Engine impacts on ``wall`` in [t0, t1] that are not unresolved micro-bounces of a stuck stretch."""
        return int((self._on(wall, t0, t1) & ~self.stuck).sum())

    def bounds(self, episode) -> dict[str, float]:
        """``BOUND_COLUMNS`` of one engine episode (a row of ``found.episodes``, ``rows_of``): its times' bounds from
        the extraction (the first stick and the first impact that are the episode's)."""
        stick = np.flatnonzero((self.stick_wall == episode.wall) & (self.t_stick == episode.t_stick))
        first = np.flatnonzero((self.wall == episode.wall) & (self.t == episode.t_first_impact))
        return {"stick_bound": float(self.stick_bound[stick[0]]) if len(stick) else math.nan,
                "exit_bound": float(self.exit_bound[stick[0]]) if len(stick) else math.nan,
                "first_impact_bound": float(self.t_bound[first[0]]) if len(first) else math.nan}


def reference_row(r) -> dict:
    """A judged row's start from reference episode ``r`` (a row of ``ref.episodes``): its times, counts and scales,
    no engine time yet, no rest window."""
    return {"wall": r.wall, "ref_t_first_impact": r.t_first_impact, "ref_t_plate_entry": r.t_plate_entry,
            "ref_t_stick": r.t_stick, "ref_t_exit": r.t_exit, "ref_n_impacts": int(r.n_impacts),
            "chatter_duration": r.chatter_duration, "sliding_duration": r.sliding_duration,
            "ref_v_first_impact": r.v_first_impact, "stick_scale": r.stick_scale,
            "t_first_impact": math.nan, "t_stick": math.nan, "t_exit": math.nan, **_NO_REST}


def engine_times(e, imps: _Found) -> dict:
    """Engine episode ``e``'s times [s], impact count and their bounds (``_Found.bounds``), as a judged row holds them."""
    return {"t_first_impact": e.t_first_impact, "t_stick": e.t_stick, "t_exit": e.t_exit, "n_impacts": int(e.n_impacts),
            **imps.bounds(e)}


def unpaired_row(e, imps: _Found) -> dict:
    """The judged row of engine episode ``e`` that no reference episode pairs: no reference time, no measured impact."""
    return {"wall": e.wall, "ref_t_first_impact": math.nan, "ref_t_plate_entry": math.nan, "ref_t_stick": math.nan,
            "ref_t_exit": math.nan, "ref_n_impacts": 0, "chatter_duration": math.nan, "sliding_duration": math.nan,
            "ref_v_first_impact": math.nan, "stick_scale": math.nan, **engine_times(e, imps), "resolved_impacts": 0,
            "ref_resolved_impacts": 0, "restitution_error": math.nan, "restitution_excess": math.nan,
            "unmeasured_impacts": 0, "measured_impacts": 0, **_NO_REST}


def judge(ref: ReferenceSolution, found: Extraction, traj: Trajectory, tol: Tolerances | None = None) -> Judgement:
    """Judge one engine run (module docstring): one row per reference episode and per unpaired engine episode."""
    tol = tol or Tolerances()
    scene = ref.scene
    t = np.asarray(traj.t, dtype=float)
    dt = traj.dt
    t_end = float(t[-1]) if len(t) else -math.inf
    ref_eps, eng_eps, imps = ref.episodes, found.episodes, _Found(found)
    eng_rows = list(rows_of(eng_eps))
    paired = _pairs(ref_eps, eng_rows)
    pen = penetration(scene, np.asarray(traj.y, float)) if len(t) else np.empty(0)
    allowance = tol.penetration * ref.length_scale

    rows, visit_pairs, windows = [], [], []
    prev_end = scene.initial.t
    for i, r in enumerate(rows_of(ref_eps)):
        row = reference_row(r)
        j = paired.get(i)
        if j is not None:
            e = eng_rows[j]
            row.update(engine_times(e, imps))
            visit = imps.visit_columns(r.wall, e.t_first_impact, e.t_exit)
            if not math.isnan(e.t_stick):
                window = rest_window(e.t_stick, r.t_stick, tol.stick * r.stick_scale, e.t_exit, r.t_exit,
                                     tol.exit * r.sliding_duration, t_end)
                rest = contact_rest(traj, scene, found, r.wall, *window)
                row.update(rest.columns(), rest_resolved=rest.resolved)
        else:
            row["n_impacts"] = imps.count(r.wall, r.t_first_impact, r.t_exit)
            visit = imps.visit_columns(r.wall, r.t_first_impact, r.t_exit)
        ref_visit = ref.visit_impacts(r)
        pairs = pair_impacts(ref_visit, reference_flights(ref_visit, r.t_stick), visit, dt, tol.resolved_steps,
                             scene.restitution, tol.restitution)
        row.update(resolved_impacts=pairs.resolved, ref_resolved_impacts=pairs.ref_resolved,
                   restitution_error=pairs.worst_error, restitution_excess=pairs.worst_excess,
                   unmeasured_impacts=pairs.unmeasured, measured_impacts=pairs.measured)
        visit_pairs.append((len(rows), r.wall, pairs))
        rows.append(row)
        windows.append((prev_end, r.t_exit))
        prev_end = r.t_stick if math.isnan(r.t_exit) else r.t_exit
    used = set(paired.values())
    t_div = time_diverged(ref, traj, tol)
    for j, e in enumerate(eng_rows):
        start = e.t_first_impact if not math.isnan(e.t_first_impact) else e.t_stick
        if j in used or start >= t_div:  # what a diverged run makes afterwards is no episode (its run row says so)
            continue
        rows.append(unpaired_row(e, imps))
        windows.append((e.t_first_impact if not math.isnan(e.t_first_impact) else e.t_stick, e.t_exit))
    beyond = pen > allowance
    facts = RunFacts(status=traj.status, t_end=t_end, t_diverged=t_div,
                     t_penetrated=float(t[np.argmax(beyond)]) if beyond.any() else math.nan,
                     penetration_allowance=allowance, inside_impacts=imps.count,
                     sliding_min=sliding_min(found.flight_min, scene.restitution), dt=dt)
    deepest = float(pen.max()) if len(pen) else math.nan
    penetration_max = [_window_max(t, pen, w0, w1, traj.index) for w0, w1 in windows]
    if rows:
        table, order = _judged_table(rows, penetration_max, dt, tol, facts, deepest)
    else:
        table, order = _empty_table(dt, tol, facts, deepest), []
    renumber = {int(old): new for new, old in enumerate(order)}
    impacts = _joined_pairs([(renumber[k], w, p) for k, w, p in visit_pairs if len(p)])
    return Judgement(table=table[TABLE_COLUMNS], impacts=impacts, t_diverged=facts.t_diverged,
                     t_penetrated=facts.t_penetrated, penetration_allowance=allowance)


def _empty_table(dt: float, tol: Tolerances, run: RunFacts, deepest: float) -> pd.DataFrame:
    """The judged table where neither side has an episode: no row, or the failed run's row (``assign_verdicts``),
    with the columns and types pandas gives them."""
    table = pd.DataFrame(columns=[*TABLE_COLUMNS, "stick_scale", "restitution_excess"])
    table["penetration_max"] = []
    errors(table, dt)
    table = assign_verdicts(table, tol, run, deepest)
    for c in _COUNT_COLUMNS:
        table[c] = table[c].fillna(0).astype(int)
    return table


def _joined_pairs(kept: list[tuple[int, str, ImpactPairs]]) -> pd.DataFrame:
    """The paired impacts of every visit with pairs (its row of the judged table, its wall, its ``ImpactPairs``) as
    one table (``IMPACT_PAIR_COLUMNS``), made once from the joined columns (a table per visit cost a quarter of a
    judge)."""
    if not kept:
        return pd.DataFrame(columns=IMPACT_PAIR_COLUMNS)
    counts = [len(p) for _, _, p in kept]
    return pd.DataFrame({"episode": np.repeat(np.array([k for k, _, _ in kept], dtype=np.int64), counts),
                         "wall": [w for (_, w, _), n in zip(kept, counts) for _ in range(n)],
                         **{c: np.concatenate([p.columns[c] for _, _, p in kept]) for c in PAIR_COLUMNS}})


_COUNT_COLUMNS = ("n_impacts", "ref_n_impacts", "resolved_impacts", "ref_resolved_impacts", "unmeasured_impacts",
                  "contact_onsets")
_JUDGED_COLUMNS = (tuple(c for c in TABLE_COLUMNS if c not in ("verdict", "reason"))
                   + ("stick_scale", "restitution_excess", "measured_impacts", "rest_resolved"))  # what ``verdict_reason`` reads
_NO_REST = {**NO_REST.columns(), "rest_resolved": True}  # an episode without a rest window: nothing to judge there


def _judged_table(rows: list[dict], penetration_max: list[float], dt: float, tol: Tolerances, run: RunFacts,
                  deepest: float) -> tuple[pd.DataFrame, np.ndarray]:
    """The judged table of ``judge``'s episode rows (at least one), made once from columns: each row's errors
    (``error_values``), verdict and reason (``verdict_reason``), the run's row when it failed and no row says so
    (``run_row``), in the order of the sticking starts (reference, else engine; none: last); and that order (the
    rows' positions). The table ``pd.DataFrame(rows)`` with ``errors`` and ``assign_verdicts`` gives, built without a
    pandas column assignment per column (they cost most of a judge)."""
    cols = {c: [row.get(c, math.nan) for row in rows] for c in _JUDGED_COLUMNS if c != "penetration_max"}
    for c in ("unmeasured_impacts", "measured_impacts"):
        cols[c] = [0 if v != v else v for v in cols[c]]  # NaN -> 0: fillna(0)
    cols["penetration_max"] = penetration_max
    floats = {k: np.asarray(cols[k], dtype=float) for k in _ERROR_INPUTS}
    cols.update({k: v.tolist() for k, v in error_values(floats, dt).items()})
    kind = _row_type(_JUDGED_COLUMNS)
    cols["verdict"], cols["reason"], extra = _verdicts(map(kind._make, zip(*(cols[c] for c in _JUDGED_COLUMNS))),
                                                       tol, run, deepest)
    if extra is not None:
        for c, v in extra.items():
            cols.setdefault(c, [math.nan] * len(rows)).append(v)
        for c in cols:
            if len(cols[c]) == len(rows):
                cols[c].append(math.nan)
    start = np.asarray(cols["ref_t_stick"], dtype=float)
    start = np.where(np.isnan(start), np.asarray(cols["t_stick"], dtype=float), start)
    order = np.argsort(np.where(np.isnan(start), math.inf, start), kind="stable")
    table = pd.DataFrame({c: [cols[c][k] for k in order] for c in TABLE_COLUMNS})
    for c in _COUNT_COLUMNS:
        if table[c].isna().any() or table[c].dtype != np.int64:
            table[c] = table[c].fillna(0).astype(int)
    return table, order


def assign_verdicts(table: pd.DataFrame, tol: Tolerances, run: RunFacts, penetration_max: float = math.nan) -> pd.DataFrame:
    """``table`` (``TABLE_COLUMNS`` but ``verdict``, plus ``restitution_excess``) with each row's verdict
    (``verdict``), and a run row when the run failed and no row says so (module docstring)."""
    table = table.copy()
    verdicts, reasons, extra = _verdicts(rows_of(table), tol, run, penetration_max)
    table["verdict"] = verdicts if len(table) else pd.Series(dtype=object)
    table["reason"] = reasons if len(table) else pd.Series(dtype=object)
    if extra is not None:
        table = pd.concat([table, pd.DataFrame([extra])], ignore_index=True) if len(table) else pd.DataFrame([extra])
    return table


def _verdicts(rows, tol: Tolerances, run: RunFacts, penetration_max: float) -> tuple[list[str], list[str], dict | None]:
    """Each judged row's verdict and reason (``verdict_reason``), and the failed run's row (``run_row``) where the run
    failed and no row says so (None otherwise); ``penetration_max`` [m]: the run's deepest penetration."""
    judged = [verdict_reason(r, tol, run) for r in rows]
    verdicts, reasons = [v for v, _ in judged], [why for _, why in judged]
    failure = run_failure(run)
    if failure and rank(failure) < rank(combine(verdicts)):
        return verdicts, reasons, run_row(run, failure, penetration_max)
    return verdicts, reasons, None


def run_row(run: RunFacts, failure: str, penetration_max: float) -> dict:
    """The row (``TABLE_COLUMNS``) that carries a failed run's verdict ``failure`` (``run_failure``) where no episode
    row says it: wall "", no times, no impacts, the run's deepest penetration [m]."""
    row = {c: math.nan for c in TABLE_COLUMNS}
    row.update(wall="", n_impacts=0, ref_n_impacts=0, resolved_impacts=0, ref_resolved_impacts=0, unmeasured_impacts=0,
               contact_onsets=0, penetration_max=penetration_max, verdict=failure, reason=f"the run {run_failure_words(run)}")
    return row


def _window_max(t: np.ndarray, values: np.ndarray, t0: float, t1: float, index: np.ndarray | None = None) -> float:
    """max of ``values`` over the samples in [t0, t1] (NaN: none). A compact trajectory (``index``) left out
    samples only clear of the walls, where the penetration is 0: a window holding only those gives 0."""
    t1 = math.inf if math.isnan(t1) else t1
    sel = (t >= t0) & (t <= t1)
    if sel.any():
        return float(values[sel].max())
    k = int(np.searchsorted(t, t0))
    if index is not None and 0 < k < len(t) and index[k] - index[k - 1] > 1:
        step = (t[k] - t[k - 1]) / (index[k] - index[k - 1])  # the left-out samples between kept ones k - 1 and k
        first, last = math.ceil((t0 - t[k - 1]) / step), math.floor((t1 - t[k - 1]) / step)
        if max(first, 1) <= min(last, index[k] - index[k - 1] - 1):
            return 0.0
    return math.nan


_ERROR_INPUTS = ("t_first_impact", "ref_t_first_impact", "t_stick", "ref_t_plate_entry", "ref_t_stick", "t_exit",
                 "ref_t_exit", "stick_scale", "sliding_duration")


def errors(table: pd.DataFrame, dt: float) -> None:
    """Errors in seconds, relative to their scales and in timesteps (in place): ``error_values`` of its columns."""
    for k, v in error_values({k: table[k].to_numpy() for k in _ERROR_INPUTS}, dt).items():
        table[k] = v


def error_values(c: dict[str, np.ndarray], dt: float) -> dict[str, np.ndarray]:
    """``ERROR_COLUMNS`` from the times and scales of ``_ERROR_INPUTS`` (arrays [s]) and the sampling step ``dt``
    [s]: engine minus reference in seconds, over the visit's scale (chatter for the first impact and the stick,
    sliding for the exit) and in steps; NaN where a time or a scale is missing (a scale <= 0 is missing), as pandas'
    own column arithmetic gives."""
    with np.errstate(divide="ignore", invalid="ignore"):
        first = c["t_first_impact"] - c["ref_t_first_impact"]
        zeno = c["t_stick"] - c["ref_t_stick"]
        exit_ = c["t_exit"] - c["ref_t_exit"]
        scale = np.where(c["stick_scale"] > 0, c["stick_scale"], np.nan)
        sliding = np.where(c["sliding_duration"] > 0, c["sliding_duration"], np.nan)
        return {"first_impact_error": first, "stick_error_plate": c["t_stick"] - c["ref_t_plate_entry"],
                "stick_error_zeno": zeno, "exit_error": exit_, "first_impact_error_rel": first / scale,
                "stick_error_rel": zeno / scale, "exit_error_rel": exit_ / sliding, "stick_error_steps": zeno / dt,
                "exit_error_steps": exit_ / dt}


def sliding_min(flight_min: float, restitution: float) -> float:
    """The shortest sliding [s] samples can show: f_min (``extract.py``, rule 3) past a sticking start that
    Feigin's ladder places to within f_min / (1 - R) (``sticking.py``); 0 when nothing was extracted."""
    return flight_min * (1.0 + 1.0 / (1.0 - restitution)) if math.isfinite(flight_min) else 0.0
