"""One run judged at many tolerances: the judge's work that no tolerance moves done once, each level's verdicts from it.

    >>> from chatterbench.comparisons.pipeline.prepared import PreparedRun, Tolerances
    >>> from chatterbench.reference.scene import load_scene
    >>> from chatterbench.comparisons import reference_trajectory
    >>> from chatterbench.comparisons.pipeline.extract import extract
    >>> from chatterbench.comparisons.pipeline.solution import solve
    >>> ref = solve(load_scene("bouncing-ball"))
    >>> traj = reference_trajectory(ref.scene, 1e-3, ref.exhaustive)        # or an engine's
    >>> prepared = PreparedRun(ref, extract(traj, ref.scene, ref.stick_tolerance(0.05)), traj)
    >>> [prepared.verdicts(Tolerances(stick=s, restitution=0.02)).verdicts for s in (0.01, 0.05)]
    [('match',), ('match',)]

``tune`` judges each run at every point of its tolerance ladder (``studies.tune.ladder``): some 25
tolerances for one trajectory and one extraction. ``judge.judge`` at each would pair the episodes,
find each visit's impacts, measure the penetration and build its tables again every time. Here that is
done once per run and extraction (``PreparedRun``), and at each tolerance only what the tolerance moves:

- the rest window (``stick``, ``exit``) and the contact over it (``persistence.contact_rest``, kept per window);
- the pairing of each visit's impacts (``impacts.pair_impacts`` at ``restitution`` and ``resolved_steps``,
  kept per pair of them);
- the penetration allowance (``penetration``) and the divergence's energy bound (``energy_gain``: which
  engine episodes count), kept per pair of them;
- each row's verdict (``verdict_rules.verdict_reason``), from the same row ``judge`` builds.

Promise: ``verdicts(tol)`` is the verdict column of ``judge(ref, found, traj, tol).table``, in its order,
and ``verdicts(tol).column(c)`` that table's column ``c``, value for value; ``judgement(tol)`` is
``judge(ref, found, traj, tol)`` itself (its tables made by ``judge``'s own functions). No DataFrame is
built by ``verdicts``. ``tests/comparisons/pipeline/test_prepared.py`` and the ladder's test
(``tests/comparisons/studies/test_tune_ladder_judge.py``) check it against ``judge`` on real engines'
runs, passing and failing.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from chatterbench.engines.trajectory import Trajectory

from .extract import Extraction
from .impacts import ImpactPairs, measured_at, pair_impacts, reference_flights
from .judge import (_ERROR_INPUTS, _JUDGED_COLUMNS, TABLE_COLUMNS, Judgement, RunFacts, _empty_table, _Found,
                    _joined_pairs, _judged_table, _pairs, _row_type, _window_max, engine_times, error_values, penetration,
                    reference_row, rows_of, run_row, sliding_min, time_diverged, unpaired_row)
from .persistence import ContactRest, contact_rest, rest_window
from .solution import ReferenceSolution
from .tolerances import Tolerances
from .verdict_rules import run_failure, verdict_reason
from .vocabulary import FAILURES, combine, rank

# verdicts the rules give before they read the contact after the stick (``judge``'s rules 1 to 6: the run's failure,
# a penetration, the pairing of the episodes, timing, restitution): a row judged so without it is judged so with it
DECIDED_BEFORE_REST = frozenset((*FAILURES, "penetrated", "endless", "missed", "spurious", "early", "late", "rebound"))

__all__ = ["PreparedRun", "LevelVerdicts", "Tolerances"]


@dataclass(frozen=True)
class _Visit:
    """One reference episode as ``judge`` begins its row: the row without what a tolerance moves, the paired engine
    episode (None: none), and the impacts its pairing reads (the engine's, as arrays; the reference's and their
    flights)."""

    row: dict
    ref: tuple  # the reference episode (``rows_of``)
    eng: tuple | None  # the paired engine episode
    visit: dict  # ``_Found.visit_columns``
    ref_visit: dict  # ``ReferenceSolution.visit_impacts``' t, v_minus, v_plus as arrays
    ref_flights: np.ndarray


@dataclass(frozen=True)
class _RunPart:
    """What the penetration allowance and the energy bound decide: the engine episodes that are rows of their own,
    every row's penetration, the run's facts, and the rows' order in the table."""

    engine_rows: list  # rows of the unpaired engine episodes that start before the run diverged
    penetration_max: list  # [m] per row: reference episodes, then those engine episodes
    facts: RunFacts
    errors: list  # per row: ``error_values`` (the times do not move with a tolerance)
    order: np.ndarray  # the table's order of the rows (without a run row; a run row comes last)


@dataclass(frozen=True)
class LevelVerdicts:
    """The verdicts of one run at one tolerance, and the rows they were made from, in the judged table's order."""

    verdicts: tuple[str, ...]  # the table's ``verdict`` column
    rows: tuple  # the table's rows (named tuples of ``judge._JUDGED_COLUMNS``; a failed run's row: a dict)
    excess: np.ndarray  # shape (n_pairs,): the paired impacts' ``excess`` (|e / R - 1|, NaN: unmeasured), in order

    def column(self, name: str) -> np.ndarray:
        """The table's column ``name`` (one of ``judge._JUDGED_COLUMNS``), shape (n_rows,), as objects."""
        return np.array([r.get(name, math.nan) if isinstance(r, dict) else getattr(r, name) for r in self.rows],
                        dtype=object)


class PreparedRun:
    """A run's trajectory and extraction, prepared once for ``judge`` at many tolerances (module docstring).

    ``ref``: the reference; ``found``: the extraction of ``traj`` (its sticking tolerance is the caller's: the
    extraction reads it through f_min only, ``extract.flight_floor``); ``traj``: the run's samples; ``memo``: what
    no extraction moves, shared by the runs prepared from other extractions of ``traj`` (one per f_min) and filled
    here: the contact over each rest window (``persistence.contact_rest``, by wall, window and contact skin) and the
    reference's impacts of each visit.
    """

    def __init__(self, ref: ReferenceSolution, found: Extraction, traj: Trajectory,
                 memo: dict[tuple, Any] | None = None):
        self.ref, self.found, self.traj = ref, found, traj
        self.memo = {} if memo is None else memo
        scene = ref.scene
        self.t = np.asarray(traj.t, dtype=float)
        self.dt = traj.dt
        self.t_end = float(self.t[-1]) if len(self.t) else -math.inf
        self.imps = _Found(found)
        self.eng_rows = list(rows_of(found.episodes))
        paired = _pairs(ref.episodes, self.eng_rows)
        self.used = set(paired.values())
        self.pen = penetration(scene, np.asarray(traj.y, float)) if len(self.t) else np.empty(0)
        self.deepest = float(self.pen.max()) if len(self.pen) else math.nan
        self.visits: list[_Visit] = []
        self.windows = []  # [s] each reference episode's penetration window
        prev_end = scene.initial.t
        for i, r in enumerate(rows_of(ref.episodes)):  # as ``judge`` does, without what a tolerance moves
            row = reference_row(r)
            j = paired.get(i)
            e = self.eng_rows[j] if j is not None else None
            if e is not None:
                row.update(engine_times(e, self.imps))
                visit = self.imps.visit_columns(r.wall, e.t_first_impact, e.t_exit)
            else:
                row["n_impacts"] = self.imps.count(r.wall, r.t_first_impact, r.t_exit)
                visit = self.imps.visit_columns(r.wall, r.t_first_impact, r.t_exit)
            self.visits.append(_Visit(row, r, e, visit, *self._reference_visit(i, r)))
            self.windows.append((prev_end, r.t_exit))
            prev_end = r.t_stick if math.isnan(r.t_exit) else r.t_exit
        self._pairs: dict[tuple, ImpactPairs] = {}
        self._parts: dict[tuple, _RunPart] = {}

    def _reference_visit(self, i: int, r) -> tuple[dict, np.ndarray]:
        """The reference's impacts of episode ``i`` (``r``) as the columns ``pair_impacts`` reads (arrays: a column of
        the reference's table costs more than the pairing), and the flight after each."""
        key = ("visit", i)
        if key not in self.memo:
            impacts = self.ref.visit_impacts(r)
            self.memo[key] = ({c: impacts[c].to_numpy(dtype=float) for c in ("t", "v_minus", "v_plus")},
                              reference_flights(impacts, r.t_stick))
        return self.memo[key]

    # -- what a tolerance moves, each kept per the tolerances it reads ----------------------------------------------

    def _rest(self, wall: str, window: tuple[float, float]) -> ContactRest:
        key = ("rest", wall, *window, self.found.offsets.get(wall, 0.0))  # all ``contact_rest`` reads of the extraction
        if key not in self.memo:
            self.memo[key] = contact_rest(self.traj, self.ref.scene, self.found, wall, *window)
        return self.memo[key]

    def _pairing(self, k: int, tol: Tolerances) -> ImpactPairs:
        key = (k, tol.resolved_steps, tol.restitution)
        if key not in self._pairs:
            paired = (k, tol.resolved_steps)  # the pairing reads the step count; the tolerance only measures it
            if paired not in self._pairs:
                v = self.visits[k]
                self._pairs[paired] = pair_impacts(v.ref_visit, v.ref_flights, v.visit, self.dt, tol.resolved_steps,
                                                   self.ref.scene.restitution, tol.restitution)
            self._pairs[key] = measured_at(self._pairs[paired], tol.restitution)
        return self._pairs[key]

    def _part(self, tol: Tolerances) -> _RunPart:
        key = (tol.energy_gain, tol.penetration)
        if key in self._parts:
            return self._parts[key]
        t_div = time_diverged(self.ref, self.traj, tol)
        engine_rows, windows = [], list(self.windows)
        for j, e in enumerate(self.eng_rows):
            start = e.t_first_impact if not math.isnan(e.t_first_impact) else e.t_stick
            if j in self.used or start >= t_div:  # as ``judge``: what a diverged run makes afterwards is no episode
                continue
            engine_rows.append(unpaired_row(e, self.imps))
            windows.append((start, e.t_exit))
        allowance = tol.penetration * self.ref.length_scale
        beyond = self.pen > allowance
        facts = RunFacts(status=self.traj.status, t_end=self.t_end, t_diverged=t_div,
                         t_penetrated=float(self.t[np.argmax(beyond)]) if beyond.any() else math.nan,
                         penetration_allowance=allowance, inside_impacts=self.imps.count,
                         sliding_min=sliding_min(self.found.flight_min, self.ref.scene.restitution), dt=self.dt)
        rows = [v.row for v in self.visits] + engine_rows
        # ``judge._judged_table``'s errors: from the rows' times, as floats, which no tolerance moves
        floats = {k: np.asarray([row.get(k, math.nan) for row in rows], dtype=float) for k in _ERROR_INPUTS}
        errs = {k: v.tolist() for k, v in error_values(floats, self.dt).items()}
        errors = [{k: errs[k][n] for k in errs} for n in range(len(rows))]
        start = np.asarray([row["ref_t_stick"] for row in rows], dtype=float)
        start = np.where(np.isnan(start), np.asarray([row["t_stick"] for row in rows], dtype=float), start)
        order = np.argsort(np.where(np.isnan(start), math.inf, start), kind="stable")
        part = _RunPart(engine_rows=engine_rows, penetration_max=[_window_max(self.t, self.pen, w0, w1, self.traj.index)
                                                                  for w0, w1 in windows],
                        facts=facts, errors=errors, order=order)
        self._parts[key] = part
        return part

    def _visit_rows(self, tol: Tolerances) -> Iterator[tuple[dict, tuple | None, ImpactPairs]]:
        """Each reference episode's row at ``tol`` without its contact after the stick, the rest window that contact
        is read over (None: no stick of the engine, no window), and the visit's pairs."""
        for k, v in enumerate(self.visits):
            row = dict(v.row)
            e, r = v.eng, v.ref
            window = None
            if e is not None and not math.isnan(e.t_stick):
                window = rest_window(e.t_stick, r.t_stick, tol.stick * r.stick_scale, e.t_exit, r.t_exit,
                                     tol.exit * r.sliding_duration, self.t_end)
            pairs = self._pairing(k, tol)
            row.update(resolved_impacts=pairs.resolved, ref_resolved_impacts=pairs.ref_resolved,
                       restitution_error=pairs.worst_error, restitution_excess=pairs.worst_excess,
                       unmeasured_impacts=pairs.unmeasured, measured_impacts=pairs.measured)
            yield row, window, pairs

    def _with_rest(self, row: dict, window: tuple | None) -> dict:
        if window is not None:
            rest = self._rest(row["wall"], window)
            row.update(rest.columns(), rest_resolved=rest.resolved)
        return row

    # -- the judgements ---------------------------------------------------------------------------------------------

    def verdicts(self, tol: Tolerances, complete: bool = True) -> LevelVerdicts:
        """The verdicts at ``tol`` (module docstring: those of ``judge``'s table, without building it).

        ``complete`` False: a row whose verdict the rules decide before they read the contact after the stick
        (``DECIDED_BEFORE_REST``, judge's rules 1 to 6) is judged without it, and its rest columns in ``rows`` are
        those of no window (``persistence.NO_REST``); the verdicts are the same. What a ladder needs: at a point
        where a row fails that way nothing but the verdicts is read, and where every row agrees every row is whole.
        """
        part = self._part(tol)
        kind = _row_type(_JUDGED_COLUMNS)

        def judged(row: dict, pen: float, err: dict) -> tuple:
            values = {**row, **err, "penetration_max": pen}
            for c in ("unmeasured_impacts", "measured_impacts"):
                v = values.get(c, math.nan)
                values[c] = 0 if v != v else v  # NaN -> 0, as ``judge._judged_table``
            r = kind._make(map(values.get, _JUDGED_COLUMNS, itertools.repeat(math.nan)))  # row.get(c, NaN), as judge
            return r, verdict_reason(r, tol, part.facts)[0]

        rows, verdicts, excess = [], [], []
        for (row, window, pairs), pen, err in zip(self._visit_rows(tol), part.penetration_max, part.errors):
            r, verdict = judged(row, pen, err) if window is not None and not complete else (None, "")
            if r is None or verdict not in DECIDED_BEFORE_REST:
                r, verdict = judged(self._with_rest(row, window), pen, err)
            rows.append(r)
            verdicts.append(verdict)
            if len(pairs):
                excess.append(pairs.columns["excess"])
        for row, pen, err in zip(part.engine_rows, part.penetration_max[len(self.visits):], part.errors[len(self.visits):]):
            r, verdict = judged(row, pen, err)
            rows.append(r)
            verdicts.append(verdict)
        ordered = [rows[k] for k in part.order]
        ordered_verdicts = [verdicts[k] for k in part.order]
        failure = run_failure(part.facts)  # the failed run's row where no row says so (``judge._verdicts``)
        if failure and rank(failure) < rank(combine(verdicts)):  # no sticking start: last (``_judged_table``'s order)
            ordered.append(run_row(part.facts, failure, self.deepest))
            ordered_verdicts.append(failure)
        return LevelVerdicts(verdicts=tuple(ordered_verdicts), rows=tuple(ordered),
                             excess=np.concatenate(excess).astype(float) if excess else np.empty(0))

    def judgement(self, tol: Tolerances) -> Judgement:
        """``judge(ref, found, traj, tol)``, from the prepared parts (its tables made by ``judge``'s functions)."""
        part = self._part(tol)
        facts = part.facts
        rows, visit_pairs = [], []
        for k, (row, window, pairs) in enumerate(self._visit_rows(tol)):
            rows.append(self._with_rest(row, window))
            visit_pairs.append((k, row["wall"], pairs))
        rows += part.engine_rows
        if rows:
            table, order = _judged_table(rows, part.penetration_max, self.dt, tol, facts, self.deepest)
        else:
            table, order = _empty_table(self.dt, tol, facts, self.deepest), []
        renumber = {int(old): new for new, old in enumerate(order)}
        impacts = _joined_pairs([(renumber[k], w, p) for k, w, p in visit_pairs if len(p)])
        return Judgement(table=table[TABLE_COLUMNS], impacts=impacts, t_diverged=facts.t_diverged,
                         t_penetrated=facts.t_penetrated, penetration_allowance=facts.penetration_allowance)
