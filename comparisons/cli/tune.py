"""``chatterbench tune``: the cheapest robust settings of one engine whose episodes all match, and a guide to paste them.

    $ chatterbench tune feigin-pair --engines mujoco --tolerance 0.05 --out out/tune-fp

Exit codes: 0 a robust candidate met the tolerances (its neighbourhood too), 1 none did (the guide and
recommended.json say the best reachable), 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from chatterbench.comparisons.pipeline.atomic import write_frame, write_text
from chatterbench.comparisons.pipeline.budget import check_engine_run, check_reference
from chatterbench.comparisons.studies.limits import MAX_RUNS
from chatterbench.reference.scene import load_scene

from .commands import COMMANDS
from .common import (UsageError, add_budget, add_out, add_scene, add_set, add_tolerance, budget_of, local_workers,
                     engine_list, integer_type, parse_tolerances, positive_int, print_table, split_overrides)
from .paths import check_dir, check_links, writing
from .progress import CountingExecutor, Progress, waited_s

SHOW = ["stage", "settings", "verdict", "robust", "neighbourhood", "worst_ratio", "failed", "steps_per_sim_s",
        "cost_per_sim_s"]
SHOW_CHECKED = 12  # rows of the terminal's table


WRITTEN = ("recommended.json", "guide.md", "guide.html", "guide_section.html", "candidates.csv")  # and figures, ENGINE/


def cmd_tune(args: argparse.Namespace) -> int:
    from chatterbench.comparisons.studies.tune import search_space, searched_text, tune

    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    if engine_over:
        raise UsageError(f"--set {engine_over[0]}: tune searches the engine settings itself; set scene fields only")
    engines = engine_list(args.engines)
    if len(engines) != 1:
        raise UsageError(f"--engines {args.engines}: tune takes one engine at a time")
    engine = engines[0]
    check_links("--out", args.out, (*WRITTEN, engine))  # a link planted in DIR: refused before the search
    scene = load_scene(args.scene, scene_over)
    tol = parse_tolerances(args.tolerance)
    budget = budget_of(args)  # the reference, then the finest candidate, before any run
    check_reference(scene, budget)
    space = search_space(engine, scene, tol)
    check_engine_run(scene, engine, min(space["dt"]), budget)
    with Progress(None, f"tune {engine} on {scene.name}", unit="candidate") as bar, \
            ProcessPoolExecutor(max_workers=local_workers(args.workers, budget.max_memory)) as pool:
        bar.stage("the search")
        bar.set_postfix(budget=f"{args.max_runs} runs")
        result = tune(scene, engine, tol, space=space, executor=CountingExecutor(pool, bar), repeats=args.repeats,
                      max_runs=args.max_runs)
    checked = result.table[result.table["robust"].notna()].head(SHOW_CHECKED)
    if len(checked):
        print_table(checked[SHOW], title=f"tune {engine} on {scene.name}; {tol.describe()}; the passes whose "
                                         f"neighbourhood was run, cheapest first (every run: --out DIR/candidates.csv):")
    print(f"searched: {searched_text(result)}")
    for line in answer_lines(result):
        print(line)
    if args.out:
        with Progress(1, f"tune {engine} on {scene.name}", unit="step") as bar:
            bar.stage("the guide: its figures and the chosen settings' runs")
            wrote = write_tune_files(result, Path(args.out))
        print(wrote)
    print(f"tune took {waited_s():.1f} s since the command started (the search {result.extra['wall_time_s']:.1f} s)")
    return 0 if result.best is not None else 1


def write_tune_files(result, out: Path) -> str:
    """Write the guide, the candidates, the figures and the engine's files under ``out``, as one set; returns the line
    that says what was written.

    They are staged in a hidden folder under ``out`` and moved in together, ``recommended.json``
    last (its old copy removed first): a tune killed or interrupted at any point leaves ``out``
    as it was, or a ``recommended.json`` beside the files of the same tune, never one beside an
    older tune's guide. Nothing is written through a link (``paths.writing``).
    """
    # draws and reruns the chosen settings (the ladder, R(v)): only when files are asked for
    from chatterbench.comparisons.outputs.engine_files import write_engine_files
    from chatterbench.comparisons.outputs.figures import write_figure
    from chatterbench.comparisons.outputs.guide import FIGURE_FILES, guide_figures, guide_html, guide_markdown, guide_section_html
    from chatterbench.comparisons.studies.tune import recommended
    from chatterbench.comparisons.studies.tune_evidence import evidence

    rec = recommended(result)
    ev = evidence(result)
    figures = guide_figures(result, ev)
    with writing("--out", out, together=["recommended.json"]) as stage:
        if rec is not None:  # moved in last (``staged``): it says the rest is this tune's
            write_text(stage / "recommended.json", json.dumps(rec, indent=2) + "\n")
        write_text(stage / "guide.md", guide_markdown(result, figures, ev))
        write_text(stage / "guide.html", guide_html(result, figures, ev))
        write_text(stage / "guide_section.html", guide_section_html(result, figures, ev))  # for `report --tune DIR`
        write_frame(stage / "candidates.csv", result.table)
        for name, fig in figures.items():
            write_figure(fig, stage, FIGURE_FILES[name])
        exported = write_engine_files(result, stage)  # at recommended.json's settings (tune_evidence.chosen_settings)
    return (f"wrote {out / 'guide.md'}, " + ("recommended.json, " if rec else "") + "guide.html, guide_section.html, "
            "candidates.csv, " + ", ".join([*(f"{FIGURE_FILES[n]}.png/.svg" for n in figures), *exported]))


def answer_lines(result) -> list[str]:
    """The answer as the terminal says it: the robust setting and its margin, the fragile pass beside it, or none."""
    from chatterbench.comparisons.studies.tune import neighbourhood_fails

    c, f = result.chosen, result.fragile
    if c is None:
        return ["no candidate ran: every one was refused"]
    cost = f"{c['steps_per_sim_s']:.4g} steps and {c['cost_per_sim_s']:.3g} s per simulated s"
    if result.best is not None:
        lines = [f"recommended (robust: passes at dt x0.8, x1.25 and the knobs' neighbours): {c['settings']} ({cost}); "
                 + (f"margin {result.margin:.3g} (worst error / tolerance of the judge's checks; restitution under the scene's "
                    f"forces {c['scene_restitution_ratio']:.3g})" if math.isfinite(result.margin)
                    else "no error to measure (no episode)")]
    else:
        lines = [f"no robust setting in the searched space; best reachable: {c['settings']} ({cost}; "
                 f"{c['n_match']}/{c['n_episodes']} match; "
                 + (f"its neighbours fail: {c['neighbourhood']}" if c.get("neighbourhood") else
                    f"its neighbourhood {unrun}" if (unrun := neighbourhood_fails(c)) else f"fails: {c['failed']}") + ")"]
    if f is not None and f["settings"] != c["settings"]:
        lines.append(f"fragile (an isolated pass: its neighbours fail): {f['settings']} ({f['steps_per_sim_s']:.4g} "
                     f"steps per simulated s); fails at {f['neighbourhood']}")
    lines.append(f"{len(result.cheaper())} cheaper or as cheap candidates fail; {len(result.cheaper(fragile=True))} "
                 "cheaper or as cheap ones pass but are fragile")
    return lines


def register(sub, formatter) -> None:
    """Add ``tune`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("tune", help=COMMANDS["tune"], formatter_class=formatter)
    add_scene(p)
    p.add_argument("--engines", "--engine", required=True, metavar="E", help="the engines to tune: one at a time")
    add_tolerance(p)
    p.set_defaults(tolerance=None)
    p.add_argument("--workers", type=positive_int, default=None, help="parallel candidate runs; None: all cores")
    p.add_argument("--max-runs", type=integer_type(1, 100_000), default=MAX_RUNS,
                   help="the search's budget: runs of up to 100,000 engine steps, a longer run counting as its steps / "
                        "100,000 (a neighbourhood once begun is completed)")
    p.add_argument("--repeats", type=integer_type(1, 100), default=3,
                   help="timed runs of the candidates the choice is between; the least wall time counts")
    add_set(p)
    add_out(p, what="write recommended.json, guide.md, guide.html, candidates.csv and the figures (tradeoff, ladder, restitution_curve) under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_tune)
