"""``chatterbench tune``: per engine, the cheapest robust settings whose episodes all match, the robust frontier over a
ladder of tolerances, and a guide to paste them.

    $ chatterbench tune feigin-pair --engines mujoco,pybullet --tolerance 0.05 --out out/tune-fp
    $ chatterbench tune bouncing-ball --engines mujoco --tolerance stick=0.03 --tolerance restitution=0.2 --max-cost 5000

Each engine's answer leads with whether the asked tolerances have a robust setting and what is reachable
(``studies.tune.answer.frontier_line``), then its frontier as a table; an engine that steps another's model (MuJoCo
Warp: MuJoCo's) has each answer rerun in that engine at the same settings (``studies.tune.conformance``). Exit codes:
0 every engine has a robust candidate at the asked tolerances (its neighbourhood too), 1 one has none (the guide and
recommended.json say what is reachable, and the best reachable), 2 bad input.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from chatterbench.comparisons.pipeline.budget import check_engine_run, check_reference
from chatterbench.comparisons.studies.limits import MAX_RUNS, ROBUST_FRACTION
from chatterbench.comparisons.studies.pools import RENEW_TASKS, process_pool
from chatterbench.reference.scene import split_assignment

from .commands import COMMANDS
from .common import (UsageError, add_budget, add_out, add_scene, add_set, add_tolerance, budget_of, local_workers,
                     engine_list, integer_type, parse_tolerances, positive_float, positive_int, print_table,
                     load_noted, split_overrides)
from .paths import check_dir, check_links, check_shapes, writing
from .progress import CountingExecutor, Progress, waited_s

SHOW = ["stage", "settings", "verdict", "robust", "neighbourhood", "worst_ratio", "failed", "steps_per_sim_s",
        "cost_per_sim_s"]
SHOW_CHECKED = 12  # rows of the terminal's table
SAME_MODEL_SHOW = ["point", "dt", "settings", "verdict", "other_verdict", "episodes", "disagree", "stick_difference_max",
                   "exit_difference_max", "same"]


WRITTEN = ("recommended.json", "guide.md", "guide.html", "guide_section.html", "candidates.csv")  # and figures, ENGINE/


def cmd_tune(args: argparse.Namespace) -> int:
    # the search's modules load here, not with the CLI: `tune --help` stays quick
    from chatterbench.comparisons.outputs.tune_files import write_tune_files
    from chatterbench.comparisons.pipeline.solution import solve
    from chatterbench.comparisons.studies.tune import tune
    from chatterbench.comparisons.studies.tune.space import engine_space, search_space
    from chatterbench.comparisons.studies.tune.conformance import same_model_check, same_model_of

    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    engines = engine_list(args.engines)
    strangers = [item for item in engine_over if split_assignment(item)[0].split(".", 1)[0] not in engines]
    if strangers:
        raise UsageError(f"--set {strangers[0]}: its engine is not among --engines {args.engines}")
    check_links("--out", args.out, (*WRITTEN, *engines))  # a link planted in DIR: refused before the search
    sets = [""] if len(engines) == 1 else [f"{e}/" for e in engines]  # where each engine's set of files goes
    check_shapes("--out", args.out, files=[*WRITTEN, *(f"{s}{name}" for s in sets for name in WRITTEN)],
                 folders=[*engines, *(f"{s}frontier" for s in sets)])  # and a folder in a file's place, or the reverse
    scene = load_noted(args.scene, scene_over)
    tol = parse_tolerances(args.tolerance)
    budget = budget_of(args)  # the reference, then the finest candidate of each engine, before any run
    check_reference(scene, budget)
    for engine in engines:  # the knobs --set fixes, checked against what the engine declares, before any solving
        fixed(engine, engine_space(engine, scene), engine_over)
    solution = solve(scene)
    spaces = {engine: fixed(engine, search_space(engine, scene, tol, solution), engine_over) for engine in engines}
    for engine, space in spaces.items():
        within = [dt for dt in space["dt"] if 1.0 / dt <= args.max_cost]
        if not within:
            coarsest = max(space["dt"])
            raise UsageError(f"--max-cost {args.max_cost:g}: no dt {engine} would search costs so little (the coarsest, "
                             f"{coarsest:.3g} s, is {1 / coarsest:.3g} steps per simulated second): raise it")
        check_engine_run(scene, engine, min(within), budget)
    results = []
    for engine in engines:
        with Progress(None, f"tune {engine} on {scene.name}", unit="candidate") as bar, \
                process_pool(local_workers(args.workers, budget.max_memory), renew=RENEW_TASKS) as pool:
            bar.stage("the search")
            bar.set_postfix(budget=f"{args.max_runs} runs")
            result = tune(scene, engine, tol, space=spaces[engine], executor=CountingExecutor(pool, bar),
                          repeats=args.repeats, max_runs=args.max_runs, max_cost=args.max_cost, solution=solution,
                          robust_fraction=args.robust_fraction)
            if other := same_model_of(engine):  # its answers rerun in the engine whose model it steps (MuJoCo Warp's)
                bar.stage(f"its answers rerun in {other}")
            result.extra["same_model"] = same_model_check(result, other)  # "": none to check against
        _print_result(result)
        results.append(result)
    if args.out:
        out = Path(args.out)
        with Progress(1, f"tune {','.join(engines)} on {scene.name}", unit="step") as bar, \
                writing("--out", out, together=recommended_files(engines)) as stage:  # one set: recommended.json moved in last
            bar.stage("the guide: its figures and the chosen settings' runs")
            written = write_tune_files(results, stage)
        print(f"wrote under {out}: " + ", ".join(written))
    print(f"tune took {waited_s():.1f} s since the command started (the searches "
          + ", ".join(f"{r.engine} {r.extra['wall_time_s']:.1f} s" for r in results) + ")")
    return 0 if all(r.best is not None for r in results) else 1


def recommended_files(engines: list[str]) -> tuple[str, ...]:
    """The ``recommended.json`` files of a tune of ``engines``, relative to DIR: moved in after the rest of the set
    (``atomic.staged``), so that their presence says the guide beside them is the same tune's."""
    return ("recommended.json",) if len(engines) == 1 else tuple(f"{e}/recommended.json" for e in engines)


MAX_COST_CAP = 1e12  # [steps per simulated s] a dt of 1e-12 s: finer than any run the step budget lets a scene take


def cost_cap(text: str) -> float:
    """``--max-cost``: a number in (0, MAX_COST_CAP] (a larger cap caps nothing; before, 1e308 was printed in full)."""
    value = positive_float(text)
    if value > MAX_COST_CAP:
        raise argparse.ArgumentTypeError(f"{text!r}: must be in (0, {MAX_COST_CAP:g}] steps per simulated second "
                                         "(a larger cap caps nothing: leave --max-cost out)")
    return value


def fraction_type(text: str) -> float:
    """``--robust-fraction``: a number in (0, 1]."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r}: must be a number in (0, 1] (the share of the band that must pass)")
    return value


def fixed(engine: str, space: dict[str, tuple], items: list[str]) -> dict[str, tuple]:
    """``space`` with the knobs that ``--set ENGINE.KNOB=VALUE`` items fix held at their value (a smaller search);
    an item for an engine not tuned, or for a setting the engine does not search, is refused by name."""
    from chatterbench.engines.registry import make_settings

    for item in items:
        key = split_assignment(item)[0]
        if key.split(".", 1)[0] != engine:
            continue
        if key not in space:
            knobs = ", ".join(k for k in space if k != "dt")
            raise UsageError(f"--set {item}: {engine} searches {knobs}; --set fixes one of them (dt: --max-cost caps it)")
        value = getattr(make_settings(engine, None, dict([split_assignment(item)])), key.split(".", 1)[1])
        space = {**space, key: (value,)}
    return space


def _print_result(result) -> None:
    """One engine's table of checked passes, the search's extent and the answer, as the terminal says them."""
    from chatterbench.comparisons.studies.tune.answer import frontier_frame, frontier_line, searched_text

    print(f"{result.engine}: {frontier_line(result)}")
    if result.frontier:
        print_table(frontier_frame(result), title=f"the robust frontier of {result.engine} on {result.scene.name} (the "
                                                  "cheapest robust setting at each tolerance level it reaches, cheapest "
                                                  "first; exit and first impact move with stick):")
    checked = result.table[result.table["robust"].notna()].head(SHOW_CHECKED)
    if len(checked):
        print_table(checked[SHOW], title=f"tune {result.engine} on {result.scene.name}; {result.tolerance.describe()}; "
                                         "the passes whose neighbourhood was run, cheapest first (every run: --out "
                                         "DIR/candidates.csv):")
    print(f"searched: {searched_text(result)}")
    for line in answer_lines(result):
        print(line)
    if (check := result.extra.get("same_model")) is not None:
        print_table(check.table[SAME_MODEL_SHOW], title=f"conformance: each answer of {result.engine} rerun in "
                    f"{check.against} at the same settings, both judged at the answer's tolerances:")
        print(check.sentence())


def answer_lines(result) -> list[str]:
    """The answer as the terminal says it: the robust setting and its margin, the fragile pass beside it, or none."""
    from chatterbench.comparisons.studies.tune.answer import fragile_beside, neighbourhood_fails

    c = result.chosen
    if c is None:
        return ["no candidate ran: every one was refused"]
    cost = f"{c['steps_per_sim_s']:.4g} steps and {c['cost_per_sim_s']:.3g} s per simulated s"
    rule = (result.extra["searched"].get("band") or {}).get("rule", "dt x 0.8 and x 1.25 and the knobs' neighbours")
    if result.best is not None:
        lines = [f"recommended (band-robust: passes at {rule}): {c['settings']} ({cost}); "
                 + (f"margin {result.margin:.3g} (worst error / tolerance of the judge's checks; restitution under the scene's "
                    f"forces {c['scene_restitution_ratio']:.3g})" if math.isfinite(result.margin)
                    else "no error to measure (no episode)")]
    elif result.written is not None:
        from chatterbench.comparisons.studies.tune.ladder import level_text

        r = result.best_reachable
        lines = [f"nothing is robust at the asked tolerances; written (band-robust at {level_text(result.chosen_tolerance)}, "
                 f"the tightest robust frontier point): {c['settings']} ({cost}); margin {result.margin:.3g} there"]
        if r is not None:
            lines.append(f"best reachable at the asked tolerances (fragile, not written): {r['settings']} "
                         f"({r['steps_per_sim_s']:.4g} steps per simulated s; {neighbourhood_fails(r) or r['failed']})")
    else:
        lines = [f"no robust setting in the searched space; best reachable: {c['settings']} ({cost}; "
                 f"{c['n_match']}/{c['n_episodes']} match; "
                 + (f"its neighbours fail: {c['neighbourhood']}" if c.get("neighbourhood") else
                    f"its neighbourhood {unrun}" if (unrun := neighbourhood_fails(c)) else f"fails: {c['failed']}") + ")"]
    if (beside := fragile_beside(result)) is not None:
        f, than = beside
        lines.append(f"fragile ({than}, an isolated pass: its neighbours fail): {f['settings']} ({f['steps_per_sim_s']:.4g} "
                     f"steps per simulated s); fails at {f['neighbourhood']}")
    lines.append(f"{len(result.cheaper())} cheaper or as cheap candidates fail; {len(result.cheaper(fragile=True))} "
                 "cheaper or as cheap ones pass but are fragile")
    return lines


def register(sub, formatter) -> None:
    """Add ``tune`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("tune", help=COMMANDS["tune"], formatter_class=formatter)
    add_scene(p)
    p.add_argument("--engines", "--engine", required=True, metavar="E[,E...]",
                   help="the engines to tune, comma-separated: one search and one frontier each")
    add_tolerance(p)
    p.set_defaults(tolerance=None)
    p.add_argument("--workers", type=positive_int, default=None, help="parallel candidate runs; None: all cores")
    p.add_argument("--max-runs", type=integer_type(1, 100_000), default=MAX_RUNS,
                   help="the search's budget: runs of up to 100,000 engine steps, a longer run counting as its steps / "
                        "100,000 (a neighbourhood once begun is completed)")
    p.add_argument("--max-cost", type=cost_cap, default=math.inf, metavar="STEPS_PER_S",
                   help="a cap on the cost: no candidate of more engine steps per simulated second (1 / dt) is run or "
                        "answered (its dt x 0.8 neighbour still checks it); default: none")
    p.add_argument("--robust-fraction", type=fraction_type, default=ROBUST_FRACTION, metavar="F",
                   help="the share of a candidate's band (every dt of [0.8, 1.25] x dt at 4 impact phases) and knob "
                        "neighbours that must pass for it to be robust, in (0, 1]; 1: every one")
    p.add_argument("--repeats", type=integer_type(1, 100), default=3,
                   help="timed runs of the candidates the choice is between; the least wall time counts")
    add_set(p)
    add_out(p, what="write recommended.json (the answer and the robust frontier), guide.md, guide.html, candidates.csv and "
                    "the figures (frontier, tradeoff, ladder, restitution_curve) under DIR; with several engines, each "
                    "engine's under DIR/ENGINE and the frontier of all under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_tune)
