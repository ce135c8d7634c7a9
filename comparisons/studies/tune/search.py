"""The order in which ``tune`` tries candidates: a joint grid over dt and every knob, refined, and each pass's neighbourhood.

    >>> from chatterbench.comparisons.studies.tune.grid import Grid
    >>> from chatterbench.comparisons.studies.tune.search import search
    >>> def run_batch(batch, stage, bounds):      # a stand-in judge: passes for dt in [1e-4, 6e-4] whatever w
    ...     return [{**p, "verdict": "match" if 1e-4 <= p["dt"] <= 6e-4 else "late"} for p in batch]
    >>> grid = Grid.make({"dt": (1e-3, 1e-4), "e.w": (1.0, 2.0)}, depth=1)
    >>> rows = search(run_batch, grid, budget=60).rows
    >>> best = min((r for r in rows if r.get("robust")), key=lambda r: 1 / r["dt"])
    >>> best["dt"], best["robust"], grid.dt
    (0.000316, True, (0.001, 0.000316, 0.0001))

The lattice (``Grid``): dt from coarse to fine, and the *main knob* (the first setting whose
values are all real numbers, e.g. MuJoCo's ``w0_dt``) at the coarse values given, each
interval halved ``depth`` times: dt geometrically, the knob in its own scale by the sweep's
``[refine]`` lattice (``sweep.refine.lattice``: geometric on a log axis); every other setting (an integrator, an
impedance, an iteration count) is a *slice*: the map is searched at each combination of
their values. Dt values are rounded to ``SIG_DIGITS`` (they are printed and pasted).

Promises (``search``):

- **The whole lattice when it fits.** When every lattice setting within the cost cap weighs
  at most ``1 - CHECK_SHARE`` of the budget, all of them run, coarse dt first, and then the
  neighbourhoods (``Searched.exhaustive``); the frontier is then the brute force's.
- **Coarse joint grid** (otherwise). Every coarse dt x every coarse knob value x every slice, dt rows
  from coarse to fine, a row in one batch (the rows run in parallel). A row dearer than
  every ladder point's bound (``bounds``: its answer so far, the tie band added at the asked
  point, and below the answer of any point as tight on both axes) is not run: it costs more
  steps, so it cannot be an answer; nor once the grid has taken ``COARSE_SHARE`` of the budget,
  nor beyond ``max_cost``; **nor past a stall** (``tune.stall``): once two steps of 2.44x of dt in
  a row bring the grid no closer to an answer, the finer rows are not run, by the grid, its
  refinement or the reserve's rounds (``Searched.stalled_dt``, ``stalled``); the one rule that
  assumes something of dts not run. Neighbourhoods and the bisection are not limited by it.
  Nothing else is pruned: no verdict is assumed from another dt's.
- **Refinement where verdicts change** (``sweep.refine.split_points`` per slice, level
  1..depth, as an adaptive sweep does; a run's label is its verdict and the ladder points it
  passes at): a cell whose corners' labels differ runs its centre
  and the midpoints of its edges whose ends differ, the cells of the most promising corners
  first (passing at the asked point, then at the most points, then the most matching episodes,
  the smallest worst error over its tolerance, the fewest steps), so that a budget that ends a
  level ends it where it matters least; **and around the best**: the lattice
  neighbours, at the level's spacing, of the ``AROUND`` cheapest passes (when nothing passes
  yet, the best reachable: most matching episodes, then the smallest worst error over its
  tolerance) and of the cheapest pass of each ladder point, so the search goes on where it is
  closest even if nothing passes. Once a pass is found, refinement stops with ``CHECK_SHARE``
  of the budget left for the neighbourhoods of the passes found; what they leave goes back to
  the grid and the refinement, a share kept again each round, until nothing is left to split.
- **Neighbourhood** (``neighbours``): after each stage, the passes that could still be an answer
  somewhere (``unchecked``: within a point's bound, ranked before its answer so far; those that
  could open a new frontier point first) have their neighbourhood run: dt x 0.8 and x 1.25
  (exactly, 6 significant digits: not the lattice's adjacent dt) with the other settings the same; the adjacent values of the
  main knob's finest lattice; for every other real-valued setting, the values half-way (in its
  scale) to its adjacent searched values. A pass is robust at a ladder point when every neighbour
  also passes there (``robust_at``); at the asked point ``robust`` is True or False and
  ``neighbourhood`` names the neighbours that fail. The band's runs at a phase (free of the budget)
  are run only while the candidate is robust at a point it could still be the answer of: one left
  robust only where a cheaper answer is robust already is stopped there (robust nowhere, ``robust``
  None at the asked point unless a neighbour fails there); the answers are those of the whole band. At the
  end of a range only the neighbour inside it is taken; integer and named settings (solver
  iterations, an integrator) are choices, not neighbourhoods.
- **Judged where it can matter** (``tune.passes.need``): a run is judged at the asked point and at every
  ladder point whose bound, when it was asked for, reaches its cost over ``DT_RATIO`` (bounds
  only fall, so the points left out never matter to it: ``unjudged`` lists them).
- ``budget`` at most, each run counting ``weight(params)`` (one by default; ``tune`` counts a
  long run as several: its work); a neighbourhood once begun is completed; no candidate
  runs twice (and candidates of one run, differing only in settings it does not read, make it
  once: ``tune.rows.evaluator``; each still counts its weight, so the search is the same); every run is returned, refused ones included, each row with ``stage`` and
  ``level`` (its lattice level: 0 the coarse grid, k the k-th refinement; NaN off the lattice).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Callable

from ..limits import ROBUST_FRACTION  # [-] the share of a candidate's neighbourhood that must pass where it is robust
from ..sweep.refine import split_points
from .grid import Grid
from .passes import cost, params_key, passes, reach_key
from .stall import StallWalk
from .bisection import below_lattice

AROUND = 3  # the best candidates whose lattice neighbours each refinement level adds
COARSE_SHARE = 0.6  # [-] of the budget the coarse grid may take before refining (finer rows cost more)
CHECK_SHARE = 0.4  # [-] of the budget the refinement leaves for the neighbourhoods of the passes it found
PER_STAGE = 4  # passes whose neighbourhood is run after each stage (after the last: until the budget is spent)
BAND_PART = 8  # band runs of a candidate run together, at most (two candidates a check: 16 runs for the workers)
MOST_NAMED = 4  # failing neighbours named in a candidate's ``neighbourhood`` (the rest counted)
SEARCH_COLUMNS = ["level", "robust", "neighbourhood", "neighbourhood_worst_ratio", "band"]


@dataclass(frozen=True)
class Searched:
    """What ``search`` ran: every row, and how much of the lattice (module docstring)."""

    rows: list[dict]  # every run, in the order run
    exhaustive: bool  # the whole lattice was run (it fitted the budget)
    lattice: int  # settings on the lattice within the cost cap
    lattice_run: int  # of them run
    costlier: int  # of those not run: costlier than every ladder point's robust answer (none could be one)
    capped: int  # lattice settings over the cost cap, never run
    unchecked: int  # passes that could still be an answer whose neighbourhood the budget left unrun
    stalled: int = 0  # lattice settings not run: finer than the row where the grid stalled (``tune.stall``)
    stalled_dt: float | None = None  # [s] the coarse dt of that row (no lattice dt finer is run after it), None: none


class _Search:
    """The search's state: the rows by candidate, the budget left, the lattice labels."""

    def __init__(self, run_batch: Callable[[list[dict], str, list[float]], list[dict]], grid: Grid, budget: float,
                 band: float,
                 weight: Callable[[dict], float], levels: list[tuple[float, float]] | None = None, asked: int = 0,
                 max_cost: float = math.inf, phases: tuple[float, ...] = (), fraction: float = ROBUST_FRACTION) -> None:
        self.run_batch, self.grid, self.left, self.band = run_batch, grid, budget, band
        self.weight, self.levels, self.asked, self.max_cost = weight, levels or [(0.0, 0.0)], asked, max_cost
        self.phases, self.fraction = phases, fraction
        self.rows: list[dict] = []
        self.seen: dict[tuple, dict] = {}
        self.inferred: dict[int, dict] = {s: {} for s in range(len(grid.slices))}
        self.walk = StallWalk()  # where the grid stalls (``tune.stall``)

    def run(self, batch: list[dict], stage: str, level: int | None, force: bool = False, keep: float = 0.0) -> None:
        new = list({params_key(p): p for p in batch if params_key(p) not in self.seen}.values())
        if not force:
            cum = list(itertools.accumulate(self.cost_of(p) for p in new))
            new = [p for p, c in zip(new, cum) if c <= self.left - keep or c == cum[0] and self.left > keep]
        if not new:
            return
        for params, row in zip(new, self.run_batch(new, stage, self.bounds())):
            where = self.grid.place(params)
            row = {**row, "stage": stage, "level": (level if level is not None else self.level(where))
                   if where is not None else math.nan,
                   "robust": None, "robust_at": None, "neighbourhood": "", "neighbourhood_worst_ratio": math.nan,
                   "band": None}
            self.seen[params_key(params)] = row
            self.rows.append(row)
        self.left -= sum(self.cost_of(p) for p in new)

    def cost_of(self, p: dict) -> float:
        """What a run costs of the budget: its weight, but nothing for a band run (one with a ``phase``), a final
        check of a candidate that passed its band's ends and knobs: the budget bounds the search, not the checks."""
        return 0.0 if "phase" in p else self.weight(p)

    def level(self, where: tuple[int, int, int]) -> int:
        """The refinement level that first reaches a lattice place (0: the coarse grid)."""
        _, i, j = where
        return next(k for k in range(self.grid.depth + 1)
                    if i % 2 ** (self.grid.depth - k) == 0 and j % 2 ** (self.grid.depth - k) == 0)

    def params(self, row: dict) -> dict:
        keys = ["dt", *([self.grid.knob] if self.grid.knob else []), *self.grid.others]
        out = {k: row[k] for k in keys}
        phase = row.get("phase")
        return out if phase is None or isinstance(phase, float) and math.isnan(phase) else {**out, "phase": phase}

    def passes(self, row: dict) -> tuple[int, ...]:
        return passes(row, self.asked)

    def on_lattice(self, row: dict) -> bool:
        return self.grid.place(self.params(row)) is not None

    def rank(self, row: dict) -> tuple:
        """A candidate's place among equally good ones, as ``tune.frontier.answers`` chooses: fewest steps, fewest
        settings away from the defaults, the larger dt, the settings' text."""
        nnd = sum(1 for k, v in self.grid.defaults.items() if row.get(k) != v)
        return cost(row), nnd, -row["dt"], str(row.get("settings", params_key(self.params(row))))

    def answers(self) -> list[tuple | None]:
        """Per ladder point, the rank of its answer so far (the best-ranked robust candidate there), None if none."""
        out: list[tuple | None] = [None] * len(self.levels)
        for r in self.rows:
            for p in r["robust_at"] or ():
                if out[p] is None or self.rank(r) < out[p]:
                    out[p] = self.rank(r)
        return out

    def bounds(self, found: list[tuple | None] | None = None) -> list[float]:
        """Per ladder point, the largest cost at which a candidate could still be its answer *and* on the frontier:
        at most its answer's cost (the asked point: plus the tie band, for ``tune.choice.choose``), and below the cost of
        the answer of every point as tight on both axes (which beats it)."""
        found = self.answers() if found is None else found
        known = [math.inf if a is None else a[0] for a in found]
        out = []
        for p, (t, e) in enumerate(self.levels):
            if p == self.asked:
                out.append(known[p] * (1.0 + self.band))
                continue
            beaten = min((known[q] for q, (tq, eq) in enumerate(self.levels) if q != p and tq <= t and eq <= e),
                         default=math.inf)
            out.append(min(known[p], math.nextafter(beaten, 0.0)))
        return out

    def affordable(self, c: float, bounds: list[float]) -> bool:
        """Whether a candidate of cost ``c`` could still be an answer at some ladder point."""
        return c <= self.max_cost and c <= max(bounds)

    def could_answer(self, row: dict, bounds: list[float], found: list[tuple | None]) -> bool:
        """Whether ``row`` could still be the answer of a point it passes at (``answerable``)."""
        return bool(self.answerable(row, bounds, found))

    def answerable(self, row: dict, bounds: list[float], found: list[tuple | None]) -> set[int]:
        """The points ``row`` passes at where it could still be the answer: within the point's bound and, beside the
        asked point, ranked before the point's answer so far (bounds only fall and answers only improve: a point
        left out never comes back)."""
        c = cost(row)
        if c > self.max_cost:
            return set()
        return {p for p in self.passes(row) if c <= bounds[p] and (p == self.asked or found[p] is None
                                                                    or self.rank(row) < found[p])}

    def unchecked(self) -> list[dict]:
        """The passes whose neighbourhood is not run yet and that could still be an answer: first those that could
        be one at a point that has none yet and no cheaper answer at a tighter point ("open": a new point of the
        frontier), then the others; by rank in each."""
        found = self.answers()
        bounds = self.bounds(found)
        todo = [r for r in self.rows if r["robust_at"] is None and self.passes(r) and self.on_lattice(r)
                and self.could_answer(r, bounds, found)]
        return sorted(todo, key=lambda r: (not any(math.isinf(bounds[p]) for p in self.passes(r)), self.rank(r)))

    def surviving(self, row: dict, near: list[dict]) -> set[int]:
        """The points ``row`` passes at where the neighbours of ``near`` run so far fail no more often than the robust
        fraction allows of all of them (every one passes, at the default fraction 1)."""
        allowed = math.floor((1.0 - self.fraction) * len(near) + 1e-9)
        ran = [self.passes(self.seen[params_key(n)]) for n in near if params_key(n) in self.seen]
        return {p for p in self.passes(row) if sum(1 for q in ran if p not in q) <= allowed}

    def neighbourhoods(self, most: int | None = PER_STAGE) -> None:
        """Run the neighbourhoods of up to ``most`` passes that could still be an answer (``unchecked``), two at a
        time (``check``)."""
        checked = 0
        while self.left > 0 and (most is None or checked < most):
            batch = self.unchecked()[:2]
            if not batch:
                return
            self.check(batch)
            checked += len(batch)

    def check(self, batch: list[dict]) -> None:
        """Run the neighbourhoods of ``batch``'s candidates group by group (``Grid.neighbourhood``: the band's ends,
        the knobs, the band's inner dts, the other phases; the last two in parts, ``split``), each group only for the
        candidates with a ladder point still robust (``_goes_on``), and settle them. A group the budget does not pay
        for (the band's runs at a ``phase``: ``cost_of``) is run only for a candidate still robust at a point it could
        be the answer of (``answerable``, as the check began: no answer changes during it); one robust only where a
        cheaper answer is already robust is *stopped* there (``settle``), so the search, its budget and its answers
        are those of the whole band, with fewer runs."""
        groups = {id(r): self.split(self.grid.neighbourhood(self.params(r), self.phases)) for r in batch}
        near = {id(r): [n for g in groups[id(r)] for n in g] for r in batch}
        found = self.answers()
        bounds = self.bounds(found)
        open_points = {id(r): self.answerable(r, bounds, found) for r in batch}
        stopped: set[int] = set()
        for k in range(max(len(g) for g in groups.values())):
            alive = [r for r in batch if self._goes_on(r, groups[id(r)][k:k + 1], near[id(r)], open_points[id(r)],
                                                       stopped)]
            self.run([n for r in alive for n in groups[id(r)][k]], "neighbourhood", self.grid.depth, force=True)
        for r in batch:
            self.settle(r, near[id(r)], id(r) in stopped)

    def _goes_on(self, r: dict, group: list[list[dict]], near: list[dict], open_points: set[int],
                 stopped: set[int]) -> bool:
        """Whether ``r``'s check runs its next ``group`` (a list of one group; none left: empty): not while it is
        stopped or robust nowhere; a free group (``free``) only while it is robust at a point it could answer
        (``open_points``), else it is stopped here (added to ``stopped``)."""
        left = self.surviving(r, near) if group and id(r) not in stopped else set()
        if not left:
            return False
        if self.free(group[0]) and not left & open_points:
            stopped.add(id(r))
            return False
        return True

    def split(self, groups: list[list[dict]]) -> list[list[dict]]:
        """A neighbourhood's groups with each group the budget does not pay for (``cost_of``: the band's runs at a
        phase) cut into runs of at most ``BAND_PART``, so that a failure stops the rest of it too."""
        out = []
        for g in groups:
            out += [g[i:i + BAND_PART] for i in range(0, len(g), BAND_PART)] if self.free(g) else [g]
        return out

    def free(self, group: list[dict]) -> bool:
        """Whether a group of neighbours is one the budget does not pay for (``cost_of``: the band's runs at a phase)."""
        return bool(group) and not sum(map(self.cost_of, group))

    def settle(self, r: dict, near: list[dict], stopped: bool = False) -> None:
        """A candidate's robust points, what its band checked and passed at each (``band``), and at the asked point its
        verdict: robust, or the neighbours that fail. ``stopped`` (``check``): its band was left unfinished where it
        could answer nothing; robust nowhere, and at the asked point False where a neighbour fails there, else None
        (not checked)."""
        surviving = self.surviving(r, near)
        r["robust_at"] = () if stopped else tuple(sorted(surviving))
        ran = [self.seen[params_key(n)] for n in near if params_key(n) in self.seen]
        r["band"] = self.band_record(r, near, ran)
        if self.asked not in self.passes(r):
            return
        failing = [n for n in ran if self.asked not in self.passes(n)]
        r["robust"] = None if stopped and self.asked in surviving else self.asked in r["robust_at"]
        words = [f"{_moved(self.params(r), n)}: {n['verdict']}" for n in failing]
        r["neighbourhood"] = "; ".join(words[:MOST_NAMED]) + (
            f"; and {len(words) - MOST_NAMED} more of {len(near)}" if len(words) > MOST_NAMED else "")
        ratios = [r.get("worst_ratio", math.nan), *(n.get("worst_ratio", math.nan) for n in ran)]
        r["neighbourhood_worst_ratio"] = max((x for x in ratios if x is not None and not math.isnan(x)), default=math.nan)

    def band_record(self, r: dict, near: list[dict], ran: list[dict]) -> dict[str, Any]:
        """What a candidate's neighbourhood checked and the share that passed at each ladder point it passes at:
        ``dts`` (the band's, ascending, its own among them), ``phases``, ``knobs`` (knob neighbours), ``runs``
        (the neighbourhood's runs, itself included), ``ran`` (of them run: a failure, or no point left that it could
        answer, stops the rest) and
        ``passed`` (point -> the share of all its runs passing there, itself included: 1.0 is every one)."""
        p = self.params(r)
        dts = sorted({p["dt"], *(n["dt"] for n in near)})  # a knob's neighbours keep the candidate's dt
        knobs = sum(1 for n in near if n["dt"] == p["dt"] and "phase" not in n)
        total = len(near) + 1
        passed = {q: (1 + sum(1 for n in ran if q in self.passes(n))) / total for q in self.passes(r)}
        return {"dts": dts, "phases": sorted({0.0, *self.phases}), "knobs": knobs, "runs": total, "ran": len(ran) + 1,
                "passed": passed}

    def answer_rows(self) -> dict[int, dict]:
        """Per ladder point, its answer so far: the best-ranked row robust there (``answers``)."""
        out: dict[int, dict] = {}
        for r in self.rows:
            for p in r["robust_at"] or ():
                if p not in out or self.rank(r) < self.rank(out[p]):
                    out[p] = r
        return out

    def bisect(self) -> None:
        """Below the lattice, the coarsest dt still robust at each answer's points (``tune.bisection``)."""
        below_lattice(self)

    def labels(self, s: int) -> dict[tuple[int, int], tuple]:
        """Slice ``s``'s runs on the lattice -> their label: the verdict and the ladder points passed."""
        out = {}
        for r in self.rows:
            where = self.grid.place(self.params(r))
            if where is not None and where[0] == s:
                out[where[1:]] = (r["verdict"], self.passes(r))
        return out

    def best(self) -> list[dict]:
        """The candidates whose lattice neighbours a refinement level adds: the ``AROUND`` cheapest passes (else the
        best reachable), and the cheapest pass of each ladder point, those cheapest at the most points first."""
        on = [r for r in self.rows if r["verdict"] != "refused" and self.on_lattice(r)]
        ok = sorted((r for r in on if self.asked in self.passes(r)), key=cost)
        cheapest: dict[int, dict] = {}
        for r in sorted(on, key=cost):
            for p in self.passes(r):
                cheapest.setdefault(p, r)
        count = {id(r): sum(1 for c in cheapest.values() if c is r) for r in cheapest.values()}
        front = sorted({id(r): r for r in cheapest.values()}.values(), key=lambda r: (-count[id(r)], cost(r)))
        out = (ok or sorted(on, key=reach_key))[:AROUND] + front[:2 * AROUND]
        return list({id(r): r for r in out}.values())

    def promise(self, r: dict) -> tuple:
        """How close a run is to an answer: passes at the asked point, then at the most points, then the nearest."""
        return (0 if self.asked in self.passes(r) else 1, -len(self.passes(r)), *reach_key(r))

    def refine(self, level: int, keep: float = 0.0) -> None:
        g, half = self.grid, 2 ** (self.grid.depth - level)
        nx, ny = len(g.dt), len(g.knob_values)
        todo: list[tuple[int, int, int]] = []
        split: list[tuple[int, int, int]] = []
        for r in self.best():  # around the best first: where the answer is closest
            s, i, j = g.place(self.params(r))
            todo += [(s, a, b) for a, b in ((i - half, j), (i + half, j), (i, j - half), (i, j + half))
                     if 0 <= a < nx and 0 <= b < ny]
        for s in range(len(g.slices)):
            known = self.labels(s)
            if nx > 1 and ny > 1:
                run, guessed = split_points({**self.inferred[s], **known}, level, g.depth)
                self.inferred[s].update(guessed)
            else:  # one axis: the midpoint of each level-(k-1) interval whose ends differ
                along = {(c[0] if ny == 1 else c[1]): v for c, v in known.items()}
                mids = {a + half for a, v in along.items() if a % (2 * half) == 0 and along.get(a + 2 * half, v) != v}
                run = {(a, 0) if ny == 1 else (0, a) for a in mids}
            split += [(s, i, j) for i, j in run]
        at = {g.place(self.params(r)): r for r in self.rows if g.place(self.params(r)) is not None}

        def promise(c: tuple[int, int, int]) -> tuple:  # the best run of the split cell's corners, then the cheaper
            s, i, j = c
            near = [at[(s, a, b)] for a in (i - half, i, i + half) for b in (j - half, j, j + half) if (s, a, b) in at]
            return (min((self.promise(r) for r in near), default=(2,)), -g.dt[i], c)
        todo += sorted(split, key=promise)  # the budget may end the level: the most promising cells first
        bounds = self.bounds()
        batch = [g.params(*c) for c in dict.fromkeys(todo)]
        self.run([p for p in batch if self.affordable(1.0 / p["dt"], bounds) and not self.past_stall(p["dt"])],
                 f"refine {level}", level, keep=keep)

    def coarse(self, floor: float, check_robust: bool) -> None:
        """The coarse grid's rows, coarse to fine, while the budget is above ``floor`` and a row could hold an answer;
        after each, the neighbourhoods of its passes (a robust answer makes the finer rows dearer than it)."""
        g = self.grid
        for i in g.coarse(g.dt):
            if self.left <= floor or not self.affordable(1.0 / g.dt[i], self.bounds()) or self.past_stall(g.dt[i]):
                break
            self.run([g.params(s, i, j) for s in range(len(g.slices)) for j in g.coarse(g.knob_values)], "grid", 0)
            if check_robust:
                self.neighbourhoods()
            self.note_rows()

    def note_rows(self) -> None:
        """Walk the coarse rows run since the last call, in order, each wholly run (``tune.stall``): a step is judged
        as its last row is run with its neighbourhoods, closer when a run of it is now an answer or could still be one."""
        g, walk = self.grid, self.walk
        rows = g.coarse(g.dt)
        while walk.stalled_dt is None and walk.rows_walked < len(rows):
            i = rows[walk.rows_walked]
            row = [self.seen.get(params_key(g.params(s, i, j))) for s in range(len(g.slices)) for j in g.coarse(g.knob_values)]
            if any(r is None for r in row):
                return
            step = walk.add_row(g.dt[i], row)
            if step is not None:
                found = self.answers()
                bounds, answers = self.bounds(found), {id(r) for r in self.answer_rows().values()}
                walk.judge(g.dt[i], step, any(id(r) in answers or self.answerable(r, bounds, found) for r in step))

    def past_stall(self, dt: float) -> bool:
        """Whether a lattice ``dt`` [s] is finer than the row where the grid stalled (``tune.stall``): not run."""
        return self.walk.past(dt)

    def lattice(self) -> list[dict]:
        """Every setting of the lattice within the cost cap, coarse dt first."""
        g = self.grid
        return [g.params(s, i, j) for i in range(len(g.dt)) if 1.0 / g.dt[i] <= self.max_cost
                for s in range(len(g.slices)) for j in range(len(g.knob_values))]

    def outcome(self, exhaustive: bool) -> Searched:
        lattice = self.lattice()
        unrun = [p for p in lattice if params_key(p) not in self.seen]
        top = max(self.bounds())
        g = self.grid
        capped = len(g.dt) * len(g.slices) * len(g.knob_values) - len(lattice)
        stalled = sum(1 for p in unrun if 1.0 / p["dt"] <= top and self.past_stall(p["dt"]))
        return Searched(rows=self.rows, exhaustive=exhaustive, lattice=len(lattice), lattice_run=len(lattice) - len(unrun),
                        costlier=sum(1 for p in unrun if 1.0 / p["dt"] > top), capped=capped, unchecked=len(self.unchecked()), stalled=stalled,
                        stalled_dt=self.walk.stalled_dt)


def _moved(p: dict, n: dict) -> str:
    """How a neighbour differs from its candidate: ``dt x0.8``, ``w0_dt=0.23``, ``dt x1.09 at phase 0.25``."""
    at = f" at phase {n['phase']:g}" if n.get("phase") else ""
    if n["dt"] != p["dt"]:
        return f"dt x{n['dt'] / p['dt']:.3g}{at}"
    k = next((k for k in p if k != "dt" and p[k] != n[k]), None)
    return (f"{k.split('.', 1)[-1]}={n[k]:g}" if k else "dt x1") + at


def search(run_batch: Callable[[list[dict], str, list[float]], list[dict]], grid: Grid, budget: float, band: float = 0.1,
           check_robust: bool = True, weight: Callable[[dict], float] = lambda params: 1.0,
           levels: list[tuple[float, float]] | None = None, asked: int = 0, max_cost: float = math.inf,
           phases: tuple[float, ...] = (), fraction: float = ROBUST_FRACTION) -> Searched:
    """Every candidate row the search ran (module docstring); ``run_batch(params, stage, bounds)`` judges a batch in
    order, ``bounds`` per ladder point the cost above which a run cannot matter there (``tune.passes.need``).

    ``params`` holds ``dt`` and every searched setting; a row is its params plus at least
    ``verdict`` (and ``passes``, the indices of the ladder points it passes at: ``levels``, each
    point's (timing, restitution) tolerance, ``asked`` the asked one's index; ``steps_per_sim_s``,
    ``n_match``, ``worst_ratio`` where known).
    ``check_robust`` False: no neighbourhood is run (every pass keeps ``robust`` None). ``weight(params)``:
    what a run costs of ``budget``; ``max_cost``: no candidate of more steps per simulated second is run
    (module docstring). ``phases`` (fractions of a step, ``studies.phases``): the band's impact phases; empty, the
    three-point neighbourhood (dt x 0.8 and x 1.25, the knobs) and no bisection. ``fraction``: the share of a
    neighbourhood that must pass at a point for the candidate to be robust there.
    """
    st = _Search(run_batch, grid, budget, band, weight, levels, asked, max_cost, phases, fraction)
    whole = st.lattice()
    if sum(weight(p) for p in whole) <= budget * (1.0 - CHECK_SHARE):  # it fits: run all of it, coarse dt first
        for i in sorted({p["dt"] for p in whole}, reverse=True):
            st.run([p for p in whole if p["dt"] == i], "exhaustive", None)
        if check_robust:
            st.neighbourhoods(most=None)
            if phases:
                st.bisect()
        return st.outcome(exhaustive=True)
    st.coarse(budget * (1.0 - COARSE_SHARE), check_robust)
    for level in range(1, grid.depth + 1):
        # kept for the neighbourhoods of the passes found; none yet, all of it may go to refining
        keep = budget * CHECK_SHARE if check_robust and any(st.passes(r) for r in st.rows) else 0.0
        if st.left <= keep:
            break
        st.refine(level, keep)
        if check_robust:
            st.neighbourhoods()
    if check_robust:
        st.neighbourhoods(most=None)
    while st.left > 0:  # what the reserve left: hand it back to the grid and the refinement, a share kept again
        ran = len(st.rows)
        st.coarse(0.0, check_robust)
        for level in range(1, grid.depth + 1):
            keep = st.left * CHECK_SHARE if check_robust else 0.0
            st.refine(level, keep)
            if check_robust:
                st.neighbourhoods(most=None)
        if len(st.rows) == ran:
            break
    if check_robust and phases:
        st.bisect()
    return st.outcome(exhaustive=False)
