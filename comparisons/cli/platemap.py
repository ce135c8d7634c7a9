"""``chatterbench platemap``: which strikes on a wall end in sliding, in the reference, Feigin's plate and the engines.

    $ chatterbench platemap feigin-pair --out out/platemap
    $ chatterbench platemap feigin-pair --engines mujoco,pybullet --phases 24 --speeds 12 --out out/pm
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from chatterbench.comparisons.outputs.atomic import write_frame
from chatterbench.comparisons.pipeline.budget import check_plate_map
from chatterbench.comparisons.studies.plate_map import plate_map
from chatterbench.reference.scene import load_scene

from .common import UsageError, add_budget, add_dt, add_engines, add_out, add_scene, add_set, budget_of, engine_list, \
    positive_float, positive_int, print_table, split_overrides
from .paths import check_dir, writing


def cmd_platemap(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    scene_over, engine_over = split_overrides(args.set)
    scene = load_scene(args.scene, scene_over)
    engines = engine_list(args.engines) if args.engines else ()
    if not engines and (args.dt is not None or engine_over):
        raise UsageError(f"{'--dt' if args.dt is not None else '--set ' + engine_over[0]}: applies to engine runs; "
                         "add --engines mujoco or --engines pybullet")
    check_plate_map(args.phases, args.speeds, budget_of(args))
    table = plate_map(scene, args.wall, args.phases, args.speeds, args.max_speed, engines, args.dt, engine_over)
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
        with writing("--out", out):
            write_frame(out / "plate_map.csv", table)
            from chatterbench.comparisons.outputs.figures import write_figure  # draws: loads matplotlib (0.7 s), so only when asked
            from chatterbench.comparisons.outputs.plate_map_figure import plate_map_figure

            fig = plate_map_figure(table, scene, args.wall)
            write_figure(fig, out, "plate_map")
        print(f"wrote {out / 'plate_map.csv'}, plate_map.png, plate_map.svg")
    return 0


def register(sub, formatter) -> None:
    """Add ``platemap`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("platemap", help="map which strikes on a wall end in sliding: reference, Feigin's plate, engines",
                       formatter_class=formatter)
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
