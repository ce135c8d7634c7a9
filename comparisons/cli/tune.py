"""``chatterbench tune``: the cheapest settings of one engine whose episodes all match, and a guide to paste them.

    $ chatterbench tune feigin-pair --engines mujoco --tolerance 0.05 --out out/tune-fp

Exit codes: 0 a candidate met the tolerances, 1 none did (the guide says the best reachable), 2 bad input.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from chatterbench.comparisons.outputs.atomic import write_frame, write_text
from chatterbench.comparisons.pipeline.budget import check_engine_run, check_reference
from chatterbench.comparisons.studies.tune import engine_space, tune
from chatterbench.reference.scene import load_scene

from .common import (UsageError, add_budget, add_out, add_scene, add_set, add_tolerance, budget_of, local_workers,
                     engine_list, parse_tolerances, positive_int, print_table, split_overrides)
from .paths import check_dir, writing

SHOW = ["stage", "settings", "verdict", "n_match", "n_episodes", "worst_ratio", "failed", "steps_per_sim_s",
        "cost_per_sim_s"]


def cmd_tune(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    if engine_over:
        raise UsageError(f"--set {engine_over[0]}: tune searches the engine settings itself; set scene fields only")
    engines = engine_list(args.engines)
    if len(engines) != 1:
        raise UsageError(f"--engines {args.engines}: tune takes one engine at a time")
    engine = engines[0]
    scene = load_scene(args.scene, scene_over)
    tol = parse_tolerances(args.tolerance)
    space = engine_space(engine, scene)
    budget = budget_of(args)  # the finest candidate and the reference, before any run
    check_engine_run(scene, engine, min(space["dt"]), budget)
    check_reference(scene, budget)
    result = tune(scene, engine, tol, space=space, workers=local_workers(args.workers, budget.max_memory),
                  repeats=args.repeats)
    print_table(result.table[SHOW], title=f"tune {engine} on {scene.name}; {tol.describe()}:")
    c = result.chosen
    if result.best is None:
        print("no candidate passes" + (f"; best reachable: {c['settings']} ({c['n_match']}/{c['n_episodes']} match; "
                                       f"fails: {c['failed']})" if c else ""))
    else:
        print(f"recommended: {c['settings']} ({c['steps_per_sim_s']:.3g} steps and {c['cost_per_sim_s']:.3g} s per "
              f"simulated s); {len(result.cheaper())} cheaper candidates fail")
    print(f"tune took {result.extra['wall_time_s']:.1f} s")
    if args.out:
        out = Path(args.out)
        # draws and reruns the chosen settings (the ladder, R(v)): only when files are asked for
        from chatterbench.comparisons.outputs.figures import write_figure
        from chatterbench.comparisons.outputs.guide import FIGURE_FILES, guide_figures, guide_html, guide_markdown, guide_section_html
        from chatterbench.comparisons.studies.tune_evidence import evidence

        figures = guide_figures(result, evidence(result))
        with writing("--out", out):
            write_text(out / "guide.md", guide_markdown(result, figures))
            write_text(out / "guide.html", guide_html(result, figures))
            write_text(out / "guide_section.html", guide_section_html(result, figures))  # for `report --tune DIR`
            write_frame(out / "candidates.csv", result.table)
            for name, fig in figures.items():
                write_figure(fig, out, FIGURE_FILES[name])
        print(f"wrote {out / 'guide.md'}, guide.html, guide_section.html, candidates.csv, "
              + ", ".join(f"{FIGURE_FILES[n]}.png/.svg" for n in figures))
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
    p.add_argument("--repeats", type=positive_int, default=3,
                   help="timed runs of the candidates the choice is between; the least wall time counts")
    add_set(p)
    add_out(p, what="write guide.md, guide.html, candidates.csv and the figures (tradeoff, ladder, restitution_curve) under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_tune)
