"""``chatterbench platemap``: which strikes on a wall end in sliding, in the reference, Feigin's plate and the engines.

    $ chatterbench platemap feigin-pair --out out/platemap
    $ chatterbench platemap feigin-pair --engines mujoco,pybullet --phases 24 --speeds 12 --out out/pm
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from chatterbench.comparisons.pipeline.atomic import write_frame
from chatterbench.comparisons.pipeline.budget import BudgetError, check_engine_run, check_plate_map
from chatterbench.reference.scene import SceneError

from .commands import COMMANDS
from .common import UsageError, add_budget, add_dt, add_engines, add_out, add_scene, add_set, budget_of, engine_list, \
    engines_hint, load_noted, positive_float, positive_int, print_table, settings_of, split_overrides
from .paths import check_dir, writing
from .progress import Progress


# [forcing periods] an engine strike's run without a Zeno point: a lead of 0.02 and a horizon of 0.25 + 0.05
# (studies/plate_map._engine_sticks); a run with one can be longer, so this is the least a strike takes
STRIKE_PERIODS = 0.32


def _check_strike_steps(scene) -> None:
    """Refuse a scene whose strikes the reference cannot follow: each is followed up to one time scale in flow steps
    no longer than the scene's fastest time scale, and the run's own guard (``Options.max_steps``) bounds their count."""
    from chatterbench.reference.flow import Flow
    from chatterbench.reference.linear import LinearSystem
    from chatterbench.reference.simulate import Options

    with np.errstate(over="ignore", invalid="ignore"):  # absurd scales overflow the flow: refused below
        step = Flow(LinearSystem.from_scene(scene).free, horizon=scene.time_scale / 4.0).step
    needed, limit = scene.time_scale / step, Options().max_steps
    if not needed <= limit:
        raise SceneError(f"scene {scene.name!r}: a strike needs about {needed:.3g} flow steps of {step:.3g} s (the "
                         f"scene's fastest time scale), more than max_steps = {limit}; check the forcing amplitudes, "
                         "frequencies and stiffnesses")


def cmd_platemap(args: argparse.Namespace) -> int:
    import pandas as pd

    from chatterbench.comparisons.studies.plate_map import plate_map

    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    scene = load_noted(args.scene, scene_over)
    engines = engine_list(args.engines) if args.engines else ()
    if not engines and (args.dt is not None or engine_over):
        key = "" if args.dt is not None else engine_over[0]
        raise UsageError(f"{'--dt' if args.dt is not None else '--set ' + key}: applies to engine runs; {engines_hint(key=key)}")
    budget = budget_of(args)
    check_plate_map(args.phases, args.speeds, budget)
    _check_strike_steps(scene)
    strike = dataclasses.replace(scene, duration=STRIKE_PERIODS * scene.time_scale)
    settings = settings_of(engines, args.dt, engine_over)
    for name in engines:  # every strike is one engine run: each is held to --max-steps and --max-memory
        try:
            check_engine_run(strike, name, settings[name].dt, budget)
        except BudgetError as exc:
            raise BudgetError(f"platemap, one strike's engine run: {exc}") from None
    # the reference's map takes about a second; each engine runs once per strike: a bar counts them
    with Progress(args.phases * args.speeds * len(engines), f"platemap {scene.name}", unit="strike",
                  enabled=None if engines else False, eta=True) as bar:
        table = plate_map(scene, args.wall, args.phases, args.speeds, args.max_speed, engines, settings=settings,
                          progress=lambda name: bar.done())
    cols = ["reference", "feigin", *engines]
    summary = pd.DataFrame({
        "region": cols,
        "strikes_sliding": [int(table[c].sum()) for c in cols],
        "fraction": [float(table[c].mean()) for c in cols],
        "agrees_with_reference": [float((table[c] == table["reference"]).mean()) for c in cols],
    })
    print_table(summary, title=f"{scene.name}, {args.wall} wall: {len(table)} strikes ({args.phases} phases x {args.speeds} speeds)")
    outside = int((table["feigin"] & ~table["reference"]).sum())
    print(f"strikes inside Feigin's sufficient plate that do not slide: {outside} (the conditions are sufficient: expect 0)")
    if args.out:
        out = Path(args.out)
        with writing("--out", out, together=True) as stage:  # every file, or none (Ctrl-C, a full disk)
            write_frame(stage / "plate_map.csv", table)
            from chatterbench.comparisons.outputs.figures import write_figure  # draws: loads matplotlib (0.7 s), so only when asked
            from chatterbench.comparisons.outputs.plate_map_figure import plate_map_figure

            fig = plate_map_figure(table, scene, args.wall)
            write_figure(fig, stage, "plate_map")
        print(f"wrote {out / 'plate_map.csv'}, plate_map.png, plate_map.svg")
    return 0


def register(sub, formatter) -> None:
    """Add ``platemap`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("platemap", help=COMMANDS["platemap"], formatter_class=formatter)
    add_scene(p)
    p.add_argument("--wall", choices=("lower", "upper"), default="lower", help="the wall struck")
    p.add_argument("--phases", type=positive_int, default=96, help="strike times over one forcing period")
    p.add_argument("--speeds", type=positive_int, default=64, help="incoming speeds")
    p.add_argument("--max-speed", type=positive_float, default=None,
                   help="largest incoming speed [m/s]; None: twice Feigin's plate at its widest")
    add_engines(p, default="", what="engines to map too (slow: one run per strike); empty: none")
    add_dt(p)
    add_set(p)
    add_out(p, what="write plate_map.csv and the figure (PNG, SVG) under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_platemap)
