"""Below tune's dt lattice: each answer's dt bisected toward the next coarser lattice dt (``tune.search``'s ``bisect``).

The search state ``st`` is ``tune.search``'s ``_Search``: its answers, its runs and checks, its grid and cost cap.
"""

from __future__ import annotations

from .grid import band_dts
from .passes import params_key


def below_lattice(st) -> None:
    """Below the lattice: between each answer's dt and the next coarser lattice dt (``DT_RATIO`` apart), the
    coarsest dt that is still robust at the answer's points, by bisection over the band's dts in between
    (``BAND_RATIO`` apart; ``tune.search``'s module docstring). A trial is a candidate like any other: run, judged at the points
    where it can matter, its neighbourhood checked where it passes; a robust one becomes the answer of the
    points where it is robust and cheapest."""
    done: set[tuple] = set()
    while True:
        todo = [(r, {p for p, a in st.answer_rows().items() if a is r}) for r in
                {id(a): a for a in st.answer_rows().values()}.values() if st.on_lattice(r)]
        todo = [(r, points) for r, points in todo if params_key(st.params(r)) not in done]
        if not todo:
            return
        r, points = min(todo, key=lambda item: st.rank(item[0]))
        done.add(params_key(st.params(r)))
        i = st.grid.dt.index(r["dt"])
        if i == 0:
            continue
        trials = [d for d in band_dts(r["dt"], st.grid.dt[i - 1]) if r["dt"] < d < st.grid.dt[i - 1]]
        lo, hi = -1, len(trials)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            params = {**st.params(r), "dt": trials[mid]}
            if 1.0 / params["dt"] > st.max_cost:
                hi = mid
                continue
            st.run([params], "bisect", None, force=True)
            trial = st.seen[params_key(params)]
            if trial["robust_at"] is None and points & set(st.passes(trial)):
                st.check([trial])
            lo, hi = (mid, hi) if points & set(trial["robust_at"] or ()) else (lo, mid)

