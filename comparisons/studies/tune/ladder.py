"""The tolerance ladder of ``tune``'s frontier: timing and restitution levels, and each run judged at every level.

    >>> from chatterbench.comparisons.pipeline.tolerances import Tolerances
    >>> from chatterbench.comparisons.studies.tune.ladder import Ladder, level_text
    >>> points = Ladder(timing=(0.02, 0.05), restitution=(0.1,)).points(Tolerances(stick=0.05, exit=0.02))
    >>> [level_text(p) for p in points]       # the asked tolerances are a point of the ladder
    ['stick 2% (exit 0.8%, first impact 2%), restitution 5%', 'stick 2% (exit 0.8%, first impact 2%), restitution 10%', \
'stick 5% (exit 2%, first impact 5%), restitution 5%', 'stick 5% (exit 2%, first impact 5%), restitution 10%']

Two axes, since they fail for different reasons: **timing** (the sticking, exit and
first-impact tolerances together: a level is the sticking tolerance, and the exit and
first-impact tolerances scale with it in the proportions asked, so a bare ``--tolerance T``
moves all three as one) and **restitution**. A ladder point is one ``Tolerances``: the asked
ones with the timing tolerances scaled and the restitution tolerance replaced (every other
field as asked); the points are every pair of a timing level and a restitution level, the
asked values added to each axis. Values are rounded to ``DIGITS`` significant digits, so
that ``compare --tolerance stick=... --tolerance exit=...`` with the printed numbers judges
with exactly these.

Each run is judged at every point by the judge itself (``judge_levels``: what ``pipeline.compare.
judge_run`` on the run's trajectory gives with the point's tolerances; the run prepared once per
extraction, ``pipeline.prepared``, and each point judged from it; ``reference_levels`` judges one
point at a time), never from errors measured at another tolerance, because the judge's
measurements depend on the tolerances: the
extraction ignores bounces too short to matter against the sticking tolerance (a looser one
moves the detected sticking start), and an impact counts for restitution only where the
step measures it to the restitution tolerance (a looser one admits slower impacts with
larger errors). So a point's verdict is what ``compare`` says at that point. One shortcut,
from the judge's rule order (``pipeline.judge``: a failure of the run, a penetration, a
missing, extra or endless episode and a timing error are decided before, and without, the
restitution tolerance): once a run fails that way at a timing level, it fails at that
level whatever the restitution level, and the other restitution levels are not judged
(``tests/comparisons/studies/test_tune_frontier.py`` checks the shortcut against judging
every point).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...pipeline.compare import judge_run
from ...pipeline.extract import extract, flight_floor
from ...pipeline.judge import judge
from ...pipeline.prepared import PreparedRun
from ...pipeline.solution import ReferenceSolution
from ...pipeline.tolerances import Tolerances
from ...pipeline.vocabulary import VERDICTS
from .checks import CHECK_COLUMNS, check_ratios, margin_and_check, ratios_of, values_of

TIMING_LEVELS = (0.01, 0.02, 0.05, 0.1, 0.2)  # [-] sticking tolerances (fractions of the chatter)
RESTITUTION_LEVELS = (0.02, 0.05, 0.1, 0.2, 0.3)  # [-] |e / R - 1|
DIGITS = 6  # significant digits of a scaled tolerance (printed, pasted into --tolerance)
# verdict groups the judge decides before the restitution tolerance enters (pipeline.judge's rules 1-5)
BEFORE_RESTITUTION = ("failure", "broken", "physics", "timing")


def _round(v: float) -> float:
    return float(f"{v:.{DIGITS}g}")


@dataclass(frozen=True)
class Ladder:
    """The levels of each axis (module docstring); the asked tolerances' own levels are added to them."""

    timing: tuple[float, ...] = TIMING_LEVELS  # sticking tolerances, in (0, 1]
    restitution: tuple[float, ...] = RESTITUTION_LEVELS  # restitution tolerances, in (0, 1]

    def __post_init__(self) -> None:
        for name in ("timing", "restitution"):
            values = tuple(float(v) for v in getattr(self, name))
            if not values or not all(0 < v <= 1 for v in values):
                raise ValueError(f"Ladder.{name} = {values!r}: needs at least one level, each in (0, 1]")
            object.__setattr__(self, name, values)

    def points(self, asked: Tolerances) -> tuple[Tolerances, ...]:
        """Every (timing level, restitution level) as ``Tolerances``, timing then restitution ascending."""
        timing = sorted({*self.timing, asked.stick})
        restitution = sorted({*self.restitution, asked.restitution})
        return tuple(at_level(asked, t, r) for t in timing for r in restitution)


def at_level(asked: Tolerances, stick: float, restitution: float) -> Tolerances:
    """``asked`` with the sticking tolerance ``stick`` (exit and first impact scaled with it) and ``restitution``."""
    if stick == asked.stick:
        timing = {"stick": asked.stick, "exit": asked.exit, "first_impact": asked.first_impact}
    else:
        k = stick / asked.stick
        timing = {"stick": stick, "exit": min(1.0, _round(asked.exit * k)),
                  "first_impact": min(1.0, _round(asked.first_impact * k))}
    return dataclasses.replace(asked, **timing, restitution=restitution)


def level_text(tol: Tolerances) -> str:
    """A point as the frontier names it: ``stick 5%, restitution 20%`` (exit and first impact when they differ)."""
    pct = lambda v: f"{100 * v:.3g}%"  # noqa: E731
    same = tol.exit == tol.stick and tol.first_impact == tol.stick
    timing = f"stick {pct(tol.stick)}" + ("" if same else f" (exit {pct(tol.exit)}, first impact {pct(tol.first_impact)})")
    return f"{timing}, restitution {pct(tol.restitution)}"


def tolerance_items(tol: Tolerances) -> list[str]:
    """The ``--tolerance KEY=VALUE`` items of a point's four varied tolerances, as ``compare`` takes them."""
    return [f"{k}={getattr(tol, k)!r}" for k in ("stick", "exit", "first_impact", "restitution")]


def _fails_before_restitution(verdicts) -> bool:
    return any(VERDICTS[v].group in BEFORE_RESTITUTION for v in verdicts if v in VERDICTS)


def _agrees(verdicts) -> bool:
    return len(verdicts) > 0 and all(v in VERDICTS and VERDICTS[v].group == "agree" for v in verdicts)


def judge_levels(ref: ReferenceSolution, engine: str, settings: Any, trajectory, points: tuple[Tolerances, ...],
                 known: dict[int, tuple] | None = None, shortcut: bool = True, only=None) -> dict[str, Any]:
    """Judge one run at every ladder point (module docstring).

    ``known``: point index -> ``judge_run``'s (run, table, impacts) there, already judged (the asked
    point's): its extraction is reused. The run is extracted once per timing level, or once for the levels whose
    sticking tolerances give one f_min (the extraction reads the sticking tolerance only through f_min,
    ``extract.flight_floor``: at a coarse dt the sampling floor decides it for every level), prepared once per
    extraction (``pipeline.prepared.PreparedRun``: the episodes paired, the visits' impacts, the penetration) and
    judged at each point from that (what the point's tolerances move: the rest window, the impacts' pairing, the
    verdicts), with no table built. Returns ``passes``, the indices of the points where every episode agrees
    (``match`` or ``none``), and at each of them ``margins``, the judged checks' worst measured error over tolerance
    (``tune.checks.judged_margin``), ``limits``, the check that sets it, and ``rests``, the contact's largest open
    share after a stick and its onsets per second (``persistence``); and ``unjudged``, the points left out: not in
    ``only`` (the points where the run can still matter: ``tune.passes.need``; None: all). ``shortcut`` False judges
    every point (the shortcut's check). The same, value for value, as ``reference_levels`` (``judge_run`` at each
    point: ``tests/comparisons/studies/test_tune_ladder_judge.py``).
    """
    wanted = set(range(len(points)) if only is None else only)
    passes, margins, limits, rests, failed_timing = [], [], [], [], set()
    dt = trajectory.dt

    def floor(tol: Tolerances) -> float:  # what the extraction reads of a timing level: levels of one f_min share it
        return flight_floor(dt, ref.scene.restitution, ref.stick_tolerance(tol.stick))

    contacts = {}  # the contact over each rest window, shared by the extractions (``PreparedRun``)
    walls = {}  # each wall's impacts, found once for every f_min's extraction (``extract``'s cache)
    prepared = {floor(points[i]): PreparedRun(ref, run.found, trajectory, contacts) for i, (run, _, _) in (known or {}).items()}
    for i, tol in enumerate(points):
        if i not in wanted or shortcut and tol.stick in failed_timing:
            continue
        f_min = floor(tol)
        if f_min not in prepared:  # one extraction per f_min, as ``judge_run`` makes it
            found = extract(trajectory, ref.scene, ref.stick_tolerance(tol.stick), walls=walls)
            prepared[f_min] = PreparedRun(ref, found, trajectory, contacts)
        level = prepared[f_min].verdicts(tol, complete=False)  # a passing point's rows are whole
        if _agrees(level.verdicts):
            passes.append(i)
            columns = {c: level.column(c) for c in CHECK_COLUMNS}
            ratios = ratios_of(values_of(columns, level.excess, tol.penetration * ref.length_scale), tol, level.verdicts)
            margin, check = margin_and_check(ratios)
            margins.append(margin)
            limits.append(check)
            rests.append(_rest_of(columns["wall"], level.column("open_fraction"), level.column("onset_rate")))
        elif _fails_before_restitution(level.verdicts):
            failed_timing.add(tol.stick)
    return {"passes": tuple(passes), "margins": tuple(margins), "limits": tuple(limits), "rests": tuple(rests),
            "unjudged": tuple(i for i in range(len(points)) if i not in wanted)}


def reference_levels(ref: ReferenceSolution, engine: str, settings: Any, trajectory, points: tuple[Tolerances, ...],
                     known: dict[int, tuple] | None = None, shortcut: bool = True, only=None) -> dict[str, Any]:
    """``judge_levels`` one point at a time, as it was first written: ``judge_run`` where a point's f_min has no
    extraction yet, else ``judge.judge`` on it, each point's tables built and checked (``tune.checks.check_ratios``);
    ``known``'s tables taken as they are. The check of ``judge_levels`` (same arguments, same values) and the
    baseline of its benchmark (``bench_tune.bench_ladder``).
    """
    known = dict(known or {})
    wanted = set(range(len(points)) if only is None else only)
    passes, margins, limits, rests, failed_timing = [], [], [], [], set()
    dt = trajectory.dt

    def floor(tol: Tolerances) -> float:  # what the extraction reads of a timing level: levels of one f_min share it
        return flight_floor(dt, ref.scene.restitution, ref.stick_tolerance(tol.stick))

    found = {floor(points[i]): run.found for i, (run, _, _) in known.items()}  # one extraction per f_min
    for i, tol in enumerate(points):
        if i not in wanted or shortcut and tol.stick in failed_timing:
            continue
        f_min = floor(tol)
        if i in known:
            _, table, impacts = known[i]
        elif f_min in found:
            judged = judge(ref, found[f_min], trajectory, tol)
            table, impacts = judged.table, judged.impacts
        else:
            run, table, impacts = judge_run(ref, engine, settings, tol, trajectory=trajectory)
            found[f_min] = run.found
        if _agrees(table["verdict"]):
            passes.append(i)
            margin, check = margin_and_check(check_ratios(table, impacts, tol, tol.penetration * ref.length_scale))
            margins.append(margin)
            limits.append(check)
            rests.append(_rest(table))
        elif _fails_before_restitution(table["verdict"]):
            failed_timing.add(tol.stick)
    return {"passes": tuple(passes), "margins": tuple(margins), "limits": tuple(limits), "rests": tuple(rests),
            "unjudged": tuple(i for i in range(len(points)) if i not in wanted)}


def _rest(table) -> tuple[float, float]:
    """A passing run's persistence: its episodes' largest open share of the rest after the stick [1] and contact
    onsets per second there [1/s] (NaN, NaN where no episode has a rest window)."""
    eps = table[table["wall"] != ""] if len(table) else table
    share = eps["open_fraction"].dropna() if "open_fraction" in eps else []
    rate = eps["onset_rate"].dropna() if "onset_rate" in eps else []
    return (float(share.max()) if len(share) else math.nan, float(rate.max()) if len(rate) else math.nan)


def _rest_of(wall: np.ndarray, open_fraction: np.ndarray, onset_rate: np.ndarray) -> tuple[float, float]:
    """``_rest`` of a judged table's columns as arrays (shape (n_rows,)): the episodes' (wall not "")."""
    eps = wall != ""
    share, rate = (np.asarray(c, dtype=float)[eps] for c in (open_fraction, onset_rate))
    share, rate = share[~np.isnan(share)], rate[~np.isnan(rate)]
    return (float(share.max()) if len(share) else math.nan, float(rate.max()) if len(rate) else math.nan)


def at_point(row: dict[str, Any], key: str, point: int, default: Any = math.nan) -> Any:
    """A row's per-pass value ``key`` (``margins``, ``limits``, ``rests``) at ladder point ``point``; ``default``
    where it does not pass there or the row has none."""
    passes = list(row.get("passes") or ())
    values = row.get(key)
    if point not in passes or not isinstance(values, tuple) or len(values) != len(passes):
        return default
    return values[passes.index(point)]


def margin_at(row: dict[str, Any], point: int) -> float:
    """A row's margin at ladder point ``point`` (NaN where it does not pass there)."""
    return float(at_point(row, "margins", point))
