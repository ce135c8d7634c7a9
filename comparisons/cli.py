"""The ``chatterbench`` command: one entry point, one subcommand per job.

    $ chatterbench scenes
    $ chatterbench run feigin-pair --set restitution=0.8 --chatter exhaustive --events log.csv
    $ chatterbench bench reference

Every subcommand prints a short table and writes files only where asked (``--out``,
``--events``). Exit codes: 0 ok, 1 a check failed (gate), 2 bad input. A user mistake
is one line naming the field, the value and what is allowed, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

import pandas as pd

from chatterbench.reference.errors import InputError
from chatterbench.reference.catalogue import CATALOGUE, describe
from chatterbench.reference.scene import SceneError, load_scene, split_assignment
from chatterbench.reference.simulate import CHATTER_MODES, simulate

from .atomic import write_frame

ENGINE_PREFIXES = ("mujoco", "pybullet")
# modules that add their own subcommands through register(subparsers)
SUBCOMMAND_MODULES: tuple[str, ...] = ("sweep_cli", "chart_cli", "report_cli", "gate_cli")


class UsageError(Exception):
    """A command-line mistake (exit code 2)."""


class Parser(argparse.ArgumentParser):
    """argparse with the CLI's refusal format: one stderr line ``chatterbench: error: ...``, exit 2.

    (argparse's own prints the usage first; the usage is one ``--help`` away.)
    """

    def error(self, message: str):  # type: ignore[override]
        sub = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        print(f"chatterbench: error: {sub + ': ' if sub else ''}{one_line(message)} (see {self.prog} --help)",
              file=sys.stderr)
        sys.exit(2)


def one_line(message: str) -> str:
    """A message on one line: newlines (from a key or value the user typed) shown as \\n."""
    return message.replace("\r", "\\r").replace("\n", "\\n")


def print_table(frame: pd.DataFrame, title: str | None = None, file=None) -> None:
    """Print a DataFrame as a compact fixed-width table."""
    file = file or sys.stdout
    if title:
        print(title, file=file)
    if frame.empty:
        print("  (none)", file=file)
        return
    print(frame.to_string(index=False, float_format=lambda v: f"{v:.9g}"), file=file)


def split_overrides(items: list[str]) -> tuple[list[str], list[str]]:
    """Split ``--set`` items into (scene overrides, engine overrides ``mujoco.*``/``pybullet.*``)."""
    scene, engine = [], []
    for item in items:
        key, _ = split_assignment(item)
        (engine if key.split(".")[0] in ENGINE_PREFIXES else scene).append(item)
    return scene, engine


# -- subcommands ---------------------------------------------------------------------

def cmd_scenes(args: argparse.Namespace) -> int:
    rows = []
    for name in CATALOGUE:
        s = load_scene(name)
        rows.append({
            "scene": name,
            "R": s.restitution,
            "mu": s.mu,
            "walls": "+".join(s.gap.walls),
            "duration_s": s.duration,
            "description": describe(name),
        })
    print_table(pd.DataFrame(rows))
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    scene_over, engine_over = split_overrides(args.set or [])
    scene = load_scene(args.scene, scene_over)
    if args.engine == "reference":
        if engine_over:
            raise UsageError(f"--set {engine_over[0]}: engine settings need --engine mujoco|pybullet")
        result = simulate(scene, args.chatter)
        log, episodes = result.log, result.episodes
        summary = f"reference ({args.chatter} mode): {len(log)} events, {result.n_impacts} impacts, {result.wall_time * 1e3:.2f} ms"
    else:
        from .engine_run import run_engine_events

        log, episodes, summary = run_engine_events(scene, args.engine, args.dt, engine_over, args.export_model)
    print(f"{scene.name}: {summary}")
    print_table(episodes, title="episodes:")
    if args.events:
        write_frame(Path(args.events), log)
        print(f"event log: {args.events}")
    if args.out:
        out = Path(args.out)
        write_frame(out / "events.csv", log)
        write_frame(out / "episodes.csv", episodes)
        print(f"wrote {out / 'events.csv'}, {out / 'episodes.csv'}")
    if args.engine == "reference" and result.status != "ok":  # the partial log is printed and written above
        print(f"chatterbench: error: the reference run stopped ({result.status}): {one_line(result.message)}", file=sys.stderr)
        return 2
    return 0


def _engine_list(text: str) -> tuple[str, ...]:
    from chatterbench.engines.registry import check_engine

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise UsageError("--engines: give at least one of mujoco, pybullet (comma-separated)")
    return tuple(check_engine(n) for n in names)


def _tolerance_help() -> str:
    from .pipeline.tolerances import Tolerances

    defaults = ", ".join(f"{k}={v:g}" for k, v in Tolerances().as_dict().items())
    return ("a verdict tolerance KEY=VALUE, repeatable; stick, first_impact: fractions of the episode's chatter duration, "
            "exit: of its sliding duration, restitution: relative, penetration: of the scene's length scale; "
            f"defaults: {defaults}")


TOLERANCE_HELP = _tolerance_help()
COMPARE_SHOW = ["engine", "wall", "ref_t_stick", "t_stick", "stick_error_zeno", "stick_error_rel", "ref_t_exit", "t_exit",
                "exit_error", "exit_error_steps", "restitution_error", "resolved_impacts", "ref_resolved_impacts",
                "n_impacts", "verdict"]


def add_tolerance_option(p: argparse.ArgumentParser) -> None:
    """The ``--tolerance KEY=VALUE`` option of every command that judges."""
    p.add_argument("--tolerance", action="append", metavar="KEY=VALUE", default=None, help=TOLERANCE_HELP)


def parse_tolerances(items):
    """``--tolerance`` items as Tolerances (defaults where not given); ToleranceError names a bad key or value."""
    from .pipeline.tolerances import tolerances_from_items

    return tolerances_from_items(items or [])


def cmd_compare(args: argparse.Namespace) -> int:
    from .outputs import write_comparison
    from .pipeline.compare import compare

    scene_over, engine_over = split_overrides(args.set or [])
    scene = load_scene(args.scene, scene_over)
    tol = parse_tolerances(args.tolerance)
    result = compare(scene, engines=_engine_list(args.engines), dt=args.dt, overrides=engine_over, tol=tol)
    print_table(result.table[COMPARE_SHOW],
                title=f"{scene.name}: engine episodes against the reference (errors in s; _rel: fraction of the "
                      f"episode's scale; _steps: in timesteps); {tol.describe()}")
    print_table(result.summary()[["engine", "verdict", "n_episodes", "n_match", "stick_error_max", "stick_error_rel_max",
                                  "exit_error_max", "exit_error_rel_max", "restitution_error_max", "penetration_max",
                                  "cost_per_sim_s", "status"]], title="summary:")
    if args.out:
        paths = write_comparison(result, Path(args.out), figures=not args.no_figures)
        print(f"wrote {len(paths)} files under {args.out}")
    return 0


def cmd_platemap(args: argparse.Namespace) -> int:
    from .atomic import write_bytes
    from .outputs import figure_bytes
    from .plate_map import plate_map, plate_map_figure

    scene_over, engine_over = split_overrides(args.set or [])
    scene = load_scene(args.scene, scene_over)
    engines = _engine_list(args.engines) if args.engines else ()
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
        import matplotlib.pyplot as plt

        out = Path(args.out)
        write_frame(out / "plate_map.csv", table)
        fig = plate_map_figure(table, scene, args.wall)
        write_bytes(out / "plate_map.png", figure_bytes(fig, "png"))
        write_bytes(out / "plate_map.svg", figure_bytes(fig, "svg"))
        plt.close(fig)
        print(f"wrote {out / 'plate_map.csv'}, plate_map.png, plate_map.svg")
    return 0


def cmd_tune(args: argparse.Namespace) -> int:
    import matplotlib.pyplot as plt

    from .atomic import write_bytes, write_text
    from .guide import guide_html, guide_markdown, guide_section_html, tradeoff_figure
    from .outputs import figure_bytes
    from .tune import tune

    scene_over, engine_over = split_overrides(args.set or [])
    if engine_over:
        raise UsageError(f"--set {engine_over[0]}: tune searches the engine settings itself; set scene fields only")
    scene = load_scene(args.scene, scene_over)
    tol = parse_tolerances(args.tolerance)
    result = tune(scene, _engine_list(args.engine)[0], tol, workers=args.workers)
    show = ["stage", "settings", "verdict", "n_match", "n_episodes", "exit_error_rel_max", "stick_error_rel_max",
            "restitution_error_max", "cost_per_sim_s"]
    print_table(result.table[show], title=f"tune {args.engine} on {scene.name}; {tol.describe()}:")
    if result.best is None:
        b = result.best_reachable
        print("no setting meets the tolerance" + (f"; best reachable: {b['settings']} (worst exit error {b['exit_error_max']:.3g} s)" if b else ""))
    else:
        print(f"recommended: {result.best['settings']} (cost {result.best['cost_per_sim_s']:.3g} s per simulated s)")
    if args.out:
        out = Path(args.out)
        write_text(out / "guide.md", guide_markdown(result))
        write_text(out / "guide.html", guide_html(result))
        write_text(out / "guide_section.html", guide_section_html(result))  # for `report --tune DIR`
        write_frame(out / "candidates.csv", result.table.drop(columns=["_run_settings"], errors="ignore"))
        fig = tradeoff_figure(result)
        write_bytes(out / "tradeoff.png", figure_bytes(fig, "png"))
        plt.close(fig)
        print(f"wrote {out / 'guide.md'}, guide.html, guide_section.html, candidates.csv, tradeoff.png")
    return 0 if result.best is not None else 1


def cmd_bench(args: argparse.Namespace) -> int:
    if args.what == "reference":
        from .bench import bench_reference

        figures = bench_reference(periods=args.periods, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="reference on feigin-pair (best of repeats, one core):")
        print("goals: feigin mode < 20 ms per 100 periods; exhaustive mode < 20 us per impact")
        return 0
    if args.what == "sweep":
        from .sweep import bench_sweep

        figures = bench_sweep(points=args.points, workers=args.workers or 2)
        print_table(pd.DataFrame([figures]).T.reset_index().rename(columns={"index": "figure", 0: "value"}),
                    title="sweep overhead: feigin-pair, both engines, 3 periods, dt = 1e-4")
        print("goals: overhead_ratio (wall against the runs' own time) and engine_ratio (against engine stepping alone) "
              "<= 1.15; speedup (1 worker against --workers) >= 1.7")
        return 0
    if args.what == "platemap":
        from .bench import bench_platemap

        figures = bench_platemap(strikes=args.strikes, repeats=args.repeats)
        print_table(pd.DataFrame([figures]), title="plate map, feigin-pair lower wall, reference exhaustive mode (best of repeats):")
        print("goal: 100,000 strikes in under 30 s")
        return 0
    from .bench import bench_engines

    table = bench_engines(steps=args.steps, repeats=args.repeats)
    print_table(table, title="engines on feigin-pair (steps per second, best of repeats):")
    print("goal: adapter keeps >= 80% of the raw engine loop")
    return 0


# -- parser --------------------------------------------------------------------------

def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number > 0")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: must be an integer > 0")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="chatterbench",
        description="Cross-validate MuJoCo and PyBullet impact chatter against Feigin's sliding model.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("scenes", help="list the built-in scenes")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("run", help="run one scene in the reference or an engine; print its episodes")
    p.add_argument("scene", help="built-in scene name or path to a scene TOML file")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scene field (restitution=0.8, initial.vy=0.04) or an engine setting (mujoco.w0_dt=0.05)")
    p.add_argument("--chatter", choices=CHATTER_MODES, default="feigin",
                   help="reference chatter model: feigin (plate entry -> inelastic impact) or exhaustive (every impact)")
    p.add_argument("--engine", choices=("reference", "mujoco", "pybullet"), default="reference")
    p.add_argument("--dt", type=_positive_float, default=None, help="engine timestep [s] (default: the engine settings' dt)")
    p.add_argument("--events", metavar="PATH", help="write the event log (CSV) here")
    p.add_argument("--export-model", metavar="PATH", help="MuJoCo: write the generated MJCF here")
    p.add_argument("--out", metavar="DIR", help="write events.csv and episodes.csv under DIR")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("compare", help="run the reference and the engines on a scene; judge every episode")
    p.add_argument("scene", help="built-in scene name or path to a scene TOML file")
    p.add_argument("--engines", default="mujoco,pybullet", help="comma-separated engines (default: mujoco,pybullet)")
    p.add_argument("--dt", type=_positive_float, default=None, help="engine timestep [s] (default: each engine's default)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="scene field or engine setting override")
    add_tolerance_option(p)
    p.add_argument("--out", metavar="DIR", help="write tables (CSV, Parquet), event logs, provenance and figures under DIR")
    p.add_argument("--no-figures", action="store_true", help="skip the figures under --out")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("platemap", help="map which strikes on a wall end in sliding: reference, Feigin's plate, engines")
    p.add_argument("scene", help="built-in scene name or path to a scene TOML file")
    p.add_argument("--wall", choices=("lower", "upper"), default="lower")
    p.add_argument("--phases", type=_positive_int, default=96, help="strike times over one forcing period")
    p.add_argument("--speeds", type=_positive_int, default=64, help="incoming speeds")
    p.add_argument("--max-speed", type=_positive_float, default=None, help="largest incoming speed [m/s]")
    p.add_argument("--engines", default="", help="also map these engines (comma-separated; slow: one run per strike)")
    p.add_argument("--dt", type=_positive_float, default=None, help="engine timestep [s]")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="scene field or engine setting override")
    p.add_argument("--out", metavar="DIR", help="write plate_map.csv and the figure (PNG, SVG) under DIR")
    p.set_defaults(func=cmd_platemap)

    p = sub.add_parser("tune", help="find the cheapest engine settings whose episodes all match within a tolerance")
    p.add_argument("scene", help="built-in scene name or path to a scene TOML file")
    p.add_argument("--engine", required=True, help="mujoco or pybullet")
    p.add_argument("--tolerance", action="append", metavar="T|KEY=VALUE", required=True,
                   help="the accuracy to reach: one number sets the sticking, exit and first-impact tolerances "
                        "at once (e.g. 0.05); otherwise " + TOLERANCE_HELP)
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="scene field override")
    p.add_argument("--workers", type=_positive_int, default=None, help="parallel candidate runs (default: all cores)")
    p.add_argument("--out", metavar="DIR", help="write guide.md, candidates.csv and tradeoff.png under DIR")
    p.set_defaults(func=cmd_tune)

    p = sub.add_parser("bench", help="benchmarks: reference speed, engine steps per second")
    p.add_argument("what", choices=("reference", "engines", "platemap", "sweep"))
    p.add_argument("--points", type=_positive_int, default=200, help="comparison points for `bench sweep`")
    p.add_argument("--workers", type=_positive_int, default=None, help="workers for `bench sweep` (default 2)")
    p.add_argument("--strikes", type=_positive_int, default=100_000, help="strikes for `bench platemap`")
    p.add_argument("--periods", type=_positive_int, default=100, help="forcing periods for `bench reference`")
    p.add_argument("--steps", type=_positive_int, default=200_000, help="engine steps for `bench engines`")
    p.add_argument("--repeats", type=_positive_int, default=5)
    p.set_defaults(func=cmd_bench)
    for name in SUBCOMMAND_MODULES:
        importlib.import_module(f"{__package__}.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``chatterbench`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (InputError, UsageError) as exc:  # every refusal of user input
        text = str(exc) if getattr(exc, "multiline", False) else one_line(str(exc))
        print(f"chatterbench: error: {text}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("chatterbench: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
