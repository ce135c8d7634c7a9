"""``chatterbench calibrate``: each engine's effective restitution against impact speed, and per impact of a scene.

    $ chatterbench calibrate mujoco pybullet --restitution 0.5 --out out/calibrate
    $ chatterbench calibrate mujoco --gravity 9.81 --speeds 0.01,10 --points 25 --set mujoco.w0_dt=0.1

Prints three tables: e at each speed (strikes at ``STRIKES`` places in a step per speed, 8 through it and its two ends, where in
a step the impact falls moving e: min, median and max, three columns per engine:
``studies/restitution_curve.py``), e under ``--scene``'s own forces at the speeds it reaches
(strikes from the reference's state before each impact the judge resolves, at the same places in
a step: ``studies/scene_restitution.py``), and the restitution of the first ``--impacts`` resolved
impacts of the scene's run per engine, from the judge's paired impacts, with its worst impact
(the one the report's restitution error is) added when it is not among them. ``--out``
writes calibration.csv (the first two tables, one row per engine, strike and place in a step,
``CURVE_COLUMNS``; ``forces`` tells them apart), impacts.csv (every resolved impact,
``IMPACT_COLUMNS``) and restitution_curve.png/.svg (every engine in one picture, with the
restitution tolerance). ``--restitution`` sets R for all (default: the scene's).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from chatterbench.comparisons.pipeline.atomic import write_frame
from chatterbench.comparisons.pipeline.budget import check_comparison
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.studies.limits import ABOVE, DEFAULT_POINTS, DECADES_BELOW, MAX_POINTS
from chatterbench.engines.registry import ENGINE_NAMES, run_engine

from .commands import COMMANDS
from .common import (UsageError, integer_type, add_budget, add_dt, add_out, add_set, budget_of, engine_list, load_noted, positive_float,
                     print_table, settings_of, split_overrides)
from .paths import check_dir, writing
from .progress import Progress


def restitution_value(text: str) -> float:
    """argparse type: Newton's R to calibrate against, in (0, 1)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"{text!r}: must be in (0, 1) (e / R needs R > 0)")
    return value


def speed_range(text: str) -> tuple[float, float]:
    """argparse type: ``LO,HI`` impact speeds [m/s], 0 < LO < HI."""
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"{text!r}: give two speeds LO,HI [m/s], e.g. 0.01,10")
    lo, hi = (positive_float(p.strip()) for p in parts)
    if not lo < hi:
        raise argparse.ArgumentTypeError(f"{text!r}: LO must be below HI")
    return lo, hi


points_value = integer_type(2, MAX_POINTS, " (one engine run each)")  # argparse type: speeds per engine
impacts_value = integer_type(0)  # argparse type: impacts to show per engine


def gravity_value(text: str) -> float:
    """argparse type: a finite acceleration >= 0 [m/s^2]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number >= 0 [m/s^2]")
    return value


def _wide_band(curve, engines):
    """One row per speed: each engine's e over the phases of a step as columns ENGINE min, ENGINE median, ENGINE max."""
    import pandas as pd

    from chatterbench.comparisons.studies.restitution_curve import restitution_band

    band = restitution_band(curve)
    wide = pd.DataFrame({"speed": [float(f"{v:.4g}") for v in dict.fromkeys(curve["speed"])]})
    for name in engines:
        rows = band[band["engine"] == name].set_index("speed")
        for col, label in (("e_min", "min"), ("e_median", "median"), ("e_max", "max")):
            wide[f"{name} {label}"] = [round(float(rows[col].get(v, math.nan)), 4) for v in dict.fromkeys(curve["speed"])]
    return wide


def cmd_calibrate(args: argparse.Namespace) -> int:
    import pandas as pd

    from chatterbench.comparisons.studies.restitution_curve import STRIKES, default_speeds, log_speeds, restitution_band

    check_dir("--out", args.out)
    engines = engine_list(",".join(args.engine))
    scene_over, engine_over = split_overrides(args.set)
    if args.restitution is not None and any(s.split("=", 1)[0].strip() == "restitution" for s in scene_over):
        raise UsageError("--restitution and --set restitution=...: give R once (--restitution)")
    scene = load_noted(args.scene, scene_over + ([f"restitution={args.restitution!r}"] if args.restitution else []))
    if scene.restitution <= 0.0:
        raise UsageError(f"restitution = {scene.restitution:g} (the scene's): e / R needs R in (0, 1); give --restitution")
    settings = settings_of(engines, args.dt, engine_over)  # every refusal before any run
    check_comparison(scene, settings, budget_of(args), reference=args.impacts > 0)
    speeds = log_speeds(*args.speeds, args.points) if args.speeds else default_speeds(scene, args.points)
    with Progress(len(engines) * (4 if args.impacts else 2), f"calibrate {scene.name}", unit="step") as bar:
        curve, strikes, impacts = _calibrations(scene, settings, speeds, args, bar)
    forces = f"under gravity g = {args.gravity:g} m/s^2" if args.gravity else "no other forces"
    print_table(_wide_band(curve, engines),
                title=f"effective restitution e = -v+/v- per speed [m/s] on {scene.name}'s bodies, {forces}, struck at "
                      f"{STRIKES} places in a step (where in a step the impact falls moves e): min, median, max; nominal "
                      f"R = {scene.restitution:g} (0: no rebound)")
    for row in curve[curve["status"] != "ok"].itertuples():
        print(f"{row.engine} at {row.speed:.4g} m/s, {row.phase:g} of a step: {row.status}: {row.message}")
    tol = Tolerances()
    if args.impacts:
        print_table(restitution_band(strikes)[["engine", "impact", "wall", "speed", "e_min", "e_median", "e_max",
                                               "error_worst", "restitution_uncertainty"]].round(4),
                    title=f"{scene.name}'s own forces: strikes from the reference's state before each impact the judge "
                          f"resolves, at {STRIKES} places in a step (speed [m/s]; e min, median, max; error_worst: e/R - 1 "
                          f"of largest magnitude; the judge holds a run to R where the uncertainty u <= {tol.restitution:g})")
        shown = impacts[(impacts.groupby("engine").cumcount() < args.impacts) | impacts["worst"]]
        print_table(shown[["engine", "impact", "speed", "restitution_effective", "restitution_error",
                           "restitution_uncertainty", "worst"]].round(4),
                    title=f"{scene.name}'s run: the first {args.impacts} resolved impacts per engine and the worst "
                          "(the judge's pairs; speed: incoming [m/s]; error e/R - 1; worst: the report's restitution error)")
        for row in impacts[impacts["worst"]].itertuples():
            print(f"{row.engine}: worst impact {row.impact} of {int((impacts['engine'] == row.engine).sum())} at "
                  f"{row.speed:.3g} m/s: e = {row.restitution_effective:.4f}, error {100 * row.restitution_error:+.1f}% "
                  f"(uncertainty {100 * row.restitution_uncertainty:.1f}%)")
    if args.out:
        out = Path(args.out)
        from chatterbench.comparisons.outputs.figures import write_figure  # draws: loads matplotlib (0.7 s), so only when asked
        from chatterbench.comparisons.outputs.restitution_curve import restitution_curve_figure

        fig = restitution_curve_figure(curve, impacts if len(impacts) else None, scene.name,
                                       strikes if len(strikes) else None, tol.restitution)
        with writing("--out", out, together=True) as stage:  # every file, or none (Ctrl-C, a full disk)
            write_frame(stage / "calibration.csv", pd.concat([curve, strikes], ignore_index=True) if len(strikes) else curve)
            if len(impacts):
                write_frame(stage / "impacts.csv", impacts)
            write_figure(fig, stage, "restitution_curve")
        print(f"wrote {out / 'calibration.csv'}{', impacts.csv' if len(impacts) else ''}, restitution_curve.png, "
              "restitution_curve.svg")
    return 0


def _calibrations(scene, settings: dict, speeds, args: argparse.Namespace, bar: Progress):
    """(the curve of one strike per speed, the strikes under the scene's forces, the scene run's impacts) of every
    engine, each stage said on ``bar``; the last two empty without ``--impacts``."""
    import pandas as pd

    from chatterbench.comparisons.pipeline.solution import solve
    from chatterbench.comparisons.studies.restitution_curve import impact_restitutions, pinned_settings, restitution_curve
    from chatterbench.comparisons.studies.scene_restitution import scene_restitution

    # one run of the whole scene per engine: its impacts, and the contact it makes for the scene, which every strike meets
    runs, curves, strikes, impacts, tol = {}, [], [], [], Tolerances()
    for name, s in settings.items():
        bar.stage(f"{name}: the scene")
        runs[name] = run_engine(name, scene, s)
    pinned = {n: pinned_settings(s, runs[n].settings) for n, s in settings.items()}
    for name, s in pinned.items():
        bar.stage(f"{name}: {len(speeds)} strikes")
        curves.append(restitution_curve(name, s, scene.restitution, speeds, scene, args.gravity))
    if args.impacts:
        ref = solve(scene)
        for name, s in pinned.items():
            bar.stage(f"{name}: strikes under the scene's forces")
            strikes.append(scene_restitution(name, s, ref, tol.resolved_steps))
        for name, s in settings.items():
            bar.stage(f"{name}: the run's impacts against the reference")
            impacts.append(impact_restitutions(name, s, scene, ref, tol, trajectory=runs[name]))
    joined = [pd.concat(parts, ignore_index=True) if parts else pd.DataFrame() for parts in (curves, strikes, impacts)]
    return tuple(joined)


def register(sub, formatter) -> None:
    """Add ``calibrate`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("calibrate", help=COMMANDS["calibrate"], formatter_class=formatter)
    p.add_argument("engine", nargs="+", metavar="ENGINE", help=f"engines to calibrate: {', '.join(ENGINE_NAMES)}")
    p.add_argument("--restitution", type=restitution_value, default=None, metavar="R",
                   help="Newton's R the engines are set up for, in (0, 1); None: the scene's")
    p.add_argument("--speeds", type=speed_range, default=None, metavar="LO,HI",
                   help=f"impact speeds [m/s], 0 < LO < HI, log-spaced; None: {DECADES_BELOW:g} decades below the "
                        f"scene's first impact speed v1 up to {ABOVE:g} v1")
    p.add_argument("--points", type=points_value, default=DEFAULT_POINTS, metavar="N",
                   help=f"speeds per engine, in [2, {MAX_POINTS}] (one engine run each)")
    p.add_argument("--gravity", type=gravity_value, default=0.0, metavar="G",
                   help="[m/s^2] pressing the striking body into the wall (9.81: the ball dropped to each speed); "
                        "0: the contact law alone")
    p.add_argument("--scene", default="bouncing-ball",
                   help="whose bodies strike (masses, lower wall, R), whose contact every strike meets (an engine "
                        "that makes it from the scene, Drake, runs the scene once) and whose resolved impacts are listed")
    p.add_argument("--impacts", type=impacts_value, default=5, metavar="N",
                   help="list the first N resolved impacts of --scene's run per engine and its worst (judged against the "
                        "reference), and strike under the scene's own forces at its impacts; 0: none of these")
    add_dt(p)
    add_set(p)
    add_out(p, what="write calibration.csv, impacts.csv and restitution_curve.png/.svg under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_calibrate)
