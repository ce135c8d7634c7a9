"""``chatterbench tune``: the cheapest settings of one engine whose episodes all match, and a guide to paste them.

    $ chatterbench tune feigin-pair --engines mujoco --tolerance 0.05 --out out/tune-fp

Exit codes: 0 a candidate met the tolerances, 1 none did (the guide says the best reachable), 2 bad input.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from chatterbench.comparisons.outputs.atomic import write_bytes, write_frame, write_text
from chatterbench.comparisons.pipeline.budget import check_engine_run, check_reference
from chatterbench.comparisons.studies.tune import SEARCH_SPACE, tune
from chatterbench.reference.scene import load_scene

from .common import (UsageError, add_budget, add_out, add_scene, add_set, add_tolerance, budget_of, local_workers,
                     engine_list, parse_tolerances, positive_int, print_table, split_overrides)
from .paths import check_dir, writing

SHOW = ["stage", "settings", "verdict", "n_match", "n_episodes", "exit_error_rel_max", "stick_error_rel_max",
        "restitution_error_max", "cost_per_sim_s"]


def cmd_tune(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    if engine_over:
        raise UsageError(f"--set {engine_over[0]}: tune searches the engine settings itself; set scene fields only")
    engines = engine_list(args.engines)
    if len(engines) != 1:
        raise UsageError(f"--engines {args.engines}: tune takes one engine at a time")
    scene = load_scene(args.scene, scene_over)
    tol = parse_tolerances(args.tolerance)
    budget = budget_of(args)  # the finest candidate and the reference, before any run
    check_engine_run(scene, engines[0], min(SEARCH_SPACE[engines[0]]["dt"]), budget)
    check_reference(scene, budget)
    result = tune(scene, engines[0], tol, workers=local_workers(args.workers, budget.max_memory))
    print_table(result.table[SHOW], title=f"tune {engines[0]} on {scene.name}; {tol.describe()}:")
    if result.best is None:
        b = result.best_reachable
        print("no setting meets the tolerances" + (f"; best reachable: {b['settings']} (timing {b['timing_score']:.3g} "
                                                   "times its tolerance)" if b else ""))
    else:
        print(f"recommended: {result.best['settings']} (cost {result.best['cost_per_sim_s']:.3g} s per simulated s)")
    if args.out:
        out = Path(args.out)
        from chatterbench.comparisons.outputs.figures import figure_bytes  # draws: loads matplotlib (0.7 s), so only when asked
        from chatterbench.comparisons.outputs.guide import guide_html, guide_markdown, guide_section_html, tradeoff_figure

        with writing("--out", out):
            write_text(out / "guide.md", guide_markdown(result))
            write_text(out / "guide.html", guide_html(result))
            write_text(out / "guide_section.html", guide_section_html(result))  # for `report --tune DIR`
            write_frame(out / "candidates.csv", result.table.drop(columns=["_run_settings"], errors="ignore"))
            write_bytes(out / "tradeoff.png", figure_bytes(tradeoff_figure(result), "png"))
        print(f"wrote {out / 'guide.md'}, guide.html, guide_section.html, candidates.csv, tradeoff.png")
    return 0 if result.best is not None else 1


def register(sub, formatter) -> None:
    """Add ``tune`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("tune", help="find the cheapest engine settings whose episodes all match within the tolerances",
                       formatter_class=formatter)
    add_scene(p)
    p.add_argument("--engines", "--engine", required=True, metavar="E", help="the engines to tune: one at a time")
    add_tolerance(p)
    p.set_defaults(tolerance=None)
    p.add_argument("--workers", type=positive_int, default=None, help="parallel candidate runs; None: all cores")
    add_set(p)
    add_out(p, what="write guide.md, guide.html, candidates.csv and tradeoff.png under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_tune)
