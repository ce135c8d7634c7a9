"""``chatterbench compare``: the reference and the engines on one scene or several, episode by episode, with verdicts.

    $ chatterbench compare feigin-pair --engines mujoco,pybullet --dt 1e-4 --out out/fp
    $ chatterbench compare bouncing-ball --tolerance stick=0.02
    $ chatterbench compare bouncing-ball feigin-pair impact-damper spring-pair --engines newton_xpbd,newton_semi

Prints, for each scene in the order given, the episode table and the summary (the columns ``report``, ``tune``,
``sweep`` and ``gate`` use: ``pipeline/summary.py``); ``--out`` writes the files of ``outputs/comparison_files.py``
(for several scenes, one folder per scene under it, named for the scene). Every scene is loaded and checked before
the first run: a scene that does not load is refused with nothing run. A progress bar on stderr (on a terminal)
says which run is going.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


from .commands import COMMANDS
from .common import UsageError, add_judging, add_out, budget_of, engine_list, load_noted, parse_tolerances, \
    print_table, settings_of, split_overrides
from .paths import check_dir, writing
from .progress import Progress

EPISODE_SHOW = ["engine", "wall", "ref_t_stick", "t_stick", "stick_error_zeno", "stick_error_rel", "ref_t_exit", "t_exit",
                "exit_error", "exit_error_steps", "restitution_error", "resolved_impacts", "ref_resolved_impacts",
                "onset_rate", "open_fraction",
                "n_impacts", "verdict"]
SUMMARY_SHOW = ["engine", "verdict", "n_episodes", "n_match", "stick_error_max", "stick_error_rel_max", "exit_error_max",
                "exit_error_rel_max", "restitution_error_max", "penetration_max", "cost_per_sim_s", "status"]
CONFORMANCE_SHOW = ["wall", "ref_t_first_impact", "verdict", "other_verdict", "stick_difference", "stick_difference_rel",
                    "exit_difference", "impact_count_difference", "resolved_impacts", "other_resolved_impacts", "disagree"]


def cmd_compare(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    scenes = [load_noted(name, scene_over) for name in args.scene]  # all checked before any run
    names = [scene.name for scene in scenes]
    if args.out and len(set(names)) < len(names):
        repeated = next(n for n in names if names.count(n) > 1)
        raise UsageError(f"scene {repeated}: given more than once with --out (each scene writes one folder)")
    tol = parse_tolerances(args.tolerance)
    engines = engine_list(args.engines)
    settings = settings_of(engines, args.dt, engine_over)  # a plugin that does not load is refused here
    for scene in scenes:
        out = args.out if len(scenes) == 1 or not args.out else Path(args.out) / scene.name
        _compare_one(scene, engines, settings, tol, args, out)
    return 0


def _compare_one(scene, engines, settings, tol, args: argparse.Namespace, out) -> None:
    """One scene: run, print its tables, write its files under ``out`` (None: none)."""
    # the work's modules (pandas, numba: 0.5 s) once the input is checked: a refusal is one line without them
    from chatterbench.comparisons.pipeline.compare import compare
    from chatterbench.comparisons.pipeline.conformance import conformance, describe, same_model_pairs

    with Progress(1 + len(engines), f"compare {scene.name}", unit="run") as bar:
        result = compare(scene, engines=engines, settings=settings, tol=tol,
                         timeout=args.timeout, budget=budget_of(args), progress=bar.stage)
    print_table(result.table[EPISODE_SHOW],
                title=f"{scene.name}: engine episodes against the reference (errors in s; _rel: fraction of the "
                      f"episode's scale; _steps: in timesteps); {tol.describe()}")
    print_table(result.summary()[SUMMARY_SHOW], title="summary:")
    for engine, other in same_model_pairs(result.runs):  # one model, two executors: where they part on chatter
        print_table(conformance(result, engine, other)[CONFORMANCE_SHOW],
                    title=f"conformance, {other} against {engine} (differences: {other} - {engine}):")
        print(describe(result, engine, other))
    for name, run in result.runs.items():  # a failed run says why
        if run.status != "ok":
            where = f"{scene.name}: " if len(args.scene) > 1 else ""
            print(f"{where}{name}: {run.status}: {run.trajectory.message}", file=sys.stderr)
    if out:
        from chatterbench.comparisons.outputs.comparison_files import write_comparison  # draws: loads matplotlib (0.7 s), so only when asked

        with writing("--out", out, together=True) as stage:  # every file, or none (Ctrl-C, a full disk)
            paths = write_comparison(result, stage, figures=not args.no_figures)
        print(f"wrote {len(paths)} files under {out}")


def register(sub, formatter) -> None:
    """Add ``compare`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("compare", help=COMMANDS["compare"], formatter_class=formatter)
    p.add_argument("scene", nargs="+", help="built-in scene names (chatterbench scenes) or paths to scene TOML files; "
                                            "several: one after another, each with its tables")
    add_judging(p)
    add_out(p, what="write tables (CSV, Parquet), event logs, impacts, provenance and figures under DIR")
    p.add_argument("--no-figures", action="store_true", help="skip the figures under --out")
    p.set_defaults(func=cmd_compare)
