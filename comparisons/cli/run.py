"""``chatterbench run``: one scene in the reference or in one engine; its episodes and event log.

    $ chatterbench run feigin-pair --set restitution=0.8 --chatter exhaustive --events log.csv
    $ chatterbench run bouncing-ball --engines mujoco --dt 1e-4 --export-model ball.xml
    $ chatterbench run bouncing-ball --engines pybullet --export-model ball.py

The episode table's ``t_stick`` is the sticking start the judge uses (``compare``, ``report``):
the reference's Zeno point, where its impacts accumulate; a reference run also shows Feigin's
plate entry, under its own name ``t_plate`` (Feigin's model sticks there, its default chatter
mode and the event log's ``stick`` events). ``--export-model`` writes the engine's model file
(``engines.export``: MuJoCo's full MJCF, PyBullet's complete script).

An engine's event log is recovered from its trajectory by ``pipeline/extract.py`` with the
resolution ``compare`` uses (the tightest sticking tolerance of the scene's reference
visits), in the reference's format, so the same episode table describes either run.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from chatterbench.comparisons.pipeline.atomic import write_frame, write_text
from chatterbench.comparisons.pipeline.budget import Budget, check_engine_run, check_reference
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.export import check_exportable, export_files_names, exporting_engines, model_file
from chatterbench.engines.registry import ENGINE_NAMES, adapter, run_engine
from chatterbench.engines.settings import SettingsError
from chatterbench.reference.errors import check_choice
from chatterbench.reference.scene import Scene, SceneError

from .commands import COMMANDS
from .common import (UsageError, add_budget, add_dt, add_out, add_set, budget_of, engines_hint, load_noted, one_line,
                     print_table, settings_of, split_overrides)
from .paths import check_dir, check_distinct, check_file, writing

if TYPE_CHECKING:
    import pandas as pd

SIMULATORS = ("reference", *ENGINE_NAMES)
SHOWN = ["wall", "t_first_impact", "t_plate", "t_stick", "t_exit", "n_impacts", "stick_rule"]  # a reference run's episodes


def run_engine_events(scene: Scene, engine: str, settings: Any, export_model: str | None,
                      budget: Budget) -> tuple[pd.DataFrame, pd.DataFrame, str]:
    """Run ``scene`` in ``engine`` with its ``settings`` object (refused first when over ``budget``); returns (event log,
    episodes, one-line summary)."""
    from chatterbench.comparisons.outputs.engine_files import flight_band  # with the work, not with --help
    from chatterbench.comparisons.pipeline.extract import extract_events
    from chatterbench.comparisons.pipeline.persistence import reference_rest_windows
    from chatterbench.comparisons.pipeline.solution import solve
    from chatterbench.reference.log import episodes, log_frame

    check_engine_run(scene, engine, settings.dt, budget)
    check_reference(scene, budget)  # its sticking resolution is the reference's
    solution = solve(scene)
    if export_model:  # its impacts are the ones counted below
        with writing("--export-model", export_model):
            write_text(Path(export_model), model_file(engine, scene, settings, flight_band(solution, Tolerances()),
                                                          reference_rest_windows(solution, Tolerances())))
    resolution = solution.stick_tolerance(Tolerances().stick)
    traj = run_engine(engine, scene, settings)
    log = extract_events(traj, scene, resolution) if len(traj.t) > 1 else log_frame([])
    n_imp = int((log["kind"] == "impact").sum())
    summary = (f"{engine} dt={settings.dt:g} s: status {traj.status}{' (' + traj.message + ')' if traj.message else ''}, "
               f"{len(traj.t)} samples, {n_imp} impacts, {traj.wall_time:.3f} s stepping")
    if export_model:
        summary += f"; {adapter(engine).export_kind} written to {export_model}"
    return log, episodes(log).drop(columns="t_plate_entry"), summary  # an engine has no plate (pipeline/extract.py)


def _check_export(engine: str, path: str | None) -> None:
    """--export-model: an engine that exports, and the suffix of what it writes (not the scene file the run reads:
    ``paths.check_distinct``)."""
    if not path:
        return
    try:
        check_exportable(engine)
    except SettingsError as exc:
        raise UsageError(f"--export-model: {exc} (use --engines {' or --engines '.join(exporting_engines())})") from None
    suffix = Path(export_files_names(engine)[0]).suffix
    if Path(path).suffix != suffix:
        raise UsageError(f"--export-model {path}: {engine} writes {adapter(engine).export_kind}; name a {suffix} file")


def judged_episodes(scene: Scene, result) -> pd.DataFrame:
    """The reference run's episodes with ``t_stick`` the judge's sticking start (the Zeno point,
    ``pipeline.solution``) and Feigin's plate entry as ``t_plate``. A run that stopped, or a scene
    whose other chatter mode cannot finish, keeps its own table: ``t_plate`` its plate entries,
    ``t_stick`` only where it is the Zeno point (exhaustive mode)."""
    from chatterbench.comparisons.pipeline.solution import solve

    if result.status == "ok":
        try:
            return solve(scene).episodes.rename(columns={"t_plate_entry": "t_plate"})[SHOWN]
        except SceneError:
            pass
    eps = result.episodes.rename(columns={"t_plate_entry": "t_plate"})
    if result.options.chatter != "exhaustive":
        eps["t_stick"] = math.nan  # Feigin's mode sticks at its plate entry, not at the Zeno point
    return eps[SHOWN]


def chatter_mode(text: str) -> str:
    """argparse type of ``--chatter``: one of the reference's chatter modes (looked up when given, so that ``run
    --help`` loads no numba)."""
    from chatterbench.reference.simulate import CHATTER_MODES

    if text not in CHATTER_MODES:
        raise argparse.ArgumentTypeError(f"{text!r}: must be one of {', '.join(CHATTER_MODES)}")
    return text


def cmd_run(args: argparse.Namespace) -> int:
    check_dir("--out", args.out)
    check_file("--events", args.events)
    check_file("--export-model", args.export_model)
    out_files = {} if args.out is None else {f"--out {Path(args.out, n)}": Path(args.out, n) for n in ("events.csv", "episodes.csv")}
    check_distinct({"--events": args.events, "--export-model": args.export_model, **out_files},
                   {"SCENE": args.scene if Path(args.scene).is_file() else None})
    scene_over, engine_over = split_overrides(args.set)
    scene = load_noted(args.scene, scene_over)
    engine = args.engines
    if engine not in SIMULATORS:
        check_choice("--engines", engine, SIMULATORS, error=UsageError)
    if engine != "reference":
        _check_export(engine, args.export_model)
    result = None
    if engine == "reference":
        for given, option in ((engine_over, f"--set {engine_over[0] if engine_over else ''}"),
                              (args.dt is not None, "--dt"), (args.export_model, "--export-model")):
            if given:
                hint = engines_hint(exporting_engines()) if option == "--export-model" else engines_hint(key=option[6:])
                raise UsageError(f"{option}: applies to an engine run; {hint}")
        check_reference(scene, budget_of(args))
        from chatterbench.reference.simulate import simulate

        result = simulate(scene, args.chatter or "feigin")
        log = result.log
        eps = judged_episodes(scene, result)
        summary = f"reference ({result.options.chatter} mode): {len(log)} events, {result.n_impacts} impacts, {result.wall_time * 1e3:.2f} ms"
    else:
        if args.chatter is not None:
            raise UsageError(f"--chatter {args.chatter}: chooses the reference's chatter model; an engine run has none")
        settings = settings_of((engine,), args.dt, engine_over)[engine]
        log, eps, summary = run_engine_events(scene, engine, settings, args.export_model, budget_of(args))
    print(f"{scene.name}: {summary}")
    print_table(eps, title="episodes:" if engine != "reference" else
                "episodes (t_stick: the Zeno point, the sticking start the judge uses; t_plate: Feigin's plate entry):")
    if args.events:
        with writing("--events", args.events):
            write_frame(Path(args.events), log)
        print(f"event log: {args.events}")
    if args.out:
        out = Path(args.out)
        with writing("--out", out, together=True) as stage:  # both files, or neither
            write_frame(stage / "events.csv", log)
            write_frame(stage / "episodes.csv", eps)
        print(f"wrote {out / 'events.csv'}, {out / 'episodes.csv'}")
    if result is not None and result.status != "ok":  # the partial log is printed and written above
        print(f"chatterbench: error: the reference run stopped ({result.status}): {one_line(result.message)}", file=sys.stderr)
        return 2
    return 0


def register(sub, formatter) -> None:
    """Add ``run`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("run", help=COMMANDS["run"], formatter_class=formatter)
    p.add_argument("scene", help="built-in scene name or path to a scene TOML file")
    p.add_argument("--engines", "--engine", default="reference", metavar="SIMULATOR",
                   help=f"the engines to run the scene: one of {', '.join(SIMULATORS)} (Feigin's model)")
    add_dt(p)
    add_set(p)
    p.add_argument("--chatter", type=chatter_mode, default=None,
                   help="reference chatter model: feigin (plate entry -> inelastic impact) or exhaustive (every impact); "
                        "None: feigin")
    p.add_argument("--events", metavar="PATH", default=None, help="write the event log (CSV) here")
    p.add_argument("--export-model", metavar="PATH", default=None,
                   help="write the scene as a file that runs in the engine alone: MuJoCo a full MJCF (.xml), PyBullet a "
                        "complete script (.py)")
    add_out(p, what="write events.csv and episodes.csv under DIR")
    add_budget(p)
    p.set_defaults(func=cmd_run)
