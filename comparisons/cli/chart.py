"""The ``chatterbench chart`` subcommand: draw a chart from a finished sweep dataset, rerunning nothing.

    $ chatterbench chart out/fp --kind work-precision
    $ chatterbench chart out/fp/rows.parquet --kind stability --x dt --y restitution --engines mujoco
    $ chatterbench chart rows.csv --kind work-precision --where restitution=0.5 --out charts/

DATASET is a sweep output directory (its ``rows.parquet``), a ``.parquet`` or a ``.csv``
file of rows (``pipeline/summary.py`` documents the columns). Writes ``work_precision.png/.svg`` or
``stability_X_Y[_ENGINE].png/.svg`` under ``--out`` (default: ``charts/`` beside the
dataset), atomically, and prints a table of what it drew. Exit codes: 0 drawn, 2 bad input
(missing file, unknown column or engine, no rows).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from .commands import COMMANDS
from .common import UsageError, add_out, positive_float, print_table
from .paths import check_dir, writing

if TYPE_CHECKING:
    import pandas as pd

KINDS = ("work-precision", "stability")
ERROR_METRICS = ("exit_error_max", "stick_error_max", "stick_error_plate_max", "first_impact_error_max",
                 "exit_error_rel_max", "stick_error_rel_max", "restitution_error_max")


def _where(rows: pd.DataFrame, items: list[str]) -> pd.DataFrame:
    """Keep the rows whose parameter KEY equals VALUE (numbers compared to 1e-9 relative).

    An engine's setting (``mujoco.w0_dt``, ``pybullet.restitution_velocity_threshold``)
    selects among that engine's rows only: the other engines' rows stay, so
    ``--where mujoco.w0_dt=0.03 --where pybullet.restitution_velocity_threshold=0`` keeps
    each engine at one setting.
    """
    from chatterbench.comparisons.outputs.sweep_data import check_columns, equals, parameter_columns

    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UsageError(f"--where {item!r}: expected KEY=VALUE, e.g. restitution=0.5")
        check_columns(rows, [key], parameter_columns(rows), what="--where parameter")
        col = rows[key]
        try:
            value = float(text)
        except ValueError:
            value = text.strip()
        keep = equals(col, value)
        if not keep.any():
            values = ", ".join(sorted({f"{v:g}" if isinstance(v, float) else str(v) for v in col.dropna().unique()}))
            raise UsageError(f"--where {item}: no row has {key} = {text} (values: {values})")
        owner = key.split(".")[0]
        if "." in key and owner in set(rows["engine"].astype(str)):
            keep |= rows["engine"].astype(str) != owner
        rows = rows[keep]
    return rows


def _default_out(dataset: Path) -> Path:
    return (dataset if dataset.is_dir() else dataset.parent) / "charts"


def _save(fig, out: Path, stem: str) -> list[Path]:
    from chatterbench.comparisons.outputs.figures import write_figure  # draws: loads matplotlib (0.7 s), so only when asked

    with writing("--out", out, together=True) as stage:  # the PNG and the SVG, or neither
        return [out / p.relative_to(stage) for p in write_figure(fig, stage, stem)]


def cmd_chart(args: argparse.Namespace) -> int:
    out = Path(args.out) if args.out else _default_out(Path(args.dataset))
    check_dir("--out", out)
    import pandas as pd

    from chatterbench.comparisons.outputs.sweep_data import check_columns
    from chatterbench.comparisons.studies.sweep.dataset import load_rows
    from chatterbench.comparisons.outputs.stability_map import stability_map_figure, verdict_grid  # draws: loads matplotlib (0.7 s), so only when asked
    from chatterbench.comparisons.outputs.work_precision import work_precision_figure
    from chatterbench.comparisons.outputs.work_precision_points import default_error, panel_metrics, pareto_front, work_precision_points

    rows = load_rows(args.dataset)
    rows = _where(rows, args.where or [])
    engines = [e.strip() for e in (args.engines or "").split(",") if e.strip()]
    present = sorted(rows["engine"].astype(str).unique())
    check_columns(rows, engines, present, what="engine")
    if engines:
        rows = rows[rows["engine"].astype(str).isin(engines)]
    engine = engines[0] if len(engines) == 1 else None
    if args.kind == "work-precision":
        if args.x or args.y:
            raise UsageError("--x/--y are for --kind stability; work-precision always draws error against cost")
        error = args.error or default_error(rows)
        fig = work_precision_figure(rows, error=error, reference_cost=args.reference_cost,
                                    reference_error=args.reference_error)
        metrics, empty = panel_metrics(rows, error)
        points = work_precision_points(rows, metrics)
        for m in metrics:
            points[f"front_{m.removesuffix('_max')}"] = pareto_front(points, m).map({True: "*", False: ""})
        show = points.drop(columns=["settings", "engine"])
        print_table(show, title=f"work-precision: {len(points)} points from {len(rows)} rows "
                                f"(errors: worst over the folded rows, _rel_max and restitution as fractions, others [s];"
                                f" * = on the Pareto front)")
        for note in empty:
            print(note)
        paths = _save(fig, out, "work_precision")
    else:
        if not (args.x and args.y):
            raise UsageError("--kind stability needs --x KEY and --y KEY (two swept parameters, e.g. --x dt --y restitution)")
        fig = stability_map_figure(rows, args.x, args.y, engine)
        counts = []
        for e in sorted(rows["engine"].astype(str).unique()):
            grid = verdict_grid(rows, args.x, args.y, e)
            if grid.empty:
                continue
            cells = grid.stack().value_counts()
            counts.append({"engine": e, "cells": f"{grid.shape[1]} x {grid.shape[0]}", **cells.to_dict()})
        print_table(pd.DataFrame(counts).fillna(0), title=f"stability map: cells per verdict, {args.x} (x) by {args.y} (y)")
        stem = f"stability_{args.x}_{args.y}" + ("_" + "_".join(engines) if engines else "")
        paths = _save(fig, out, stem)
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def register(sub, formatter) -> None:
    """Add ``chart`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("chart", help=COMMANDS["chart"], formatter_class=formatter)
    p.add_argument("dataset", metavar="DATASET", help="sweep output directory (rows.parquet), or a .parquet / .csv of rows")
    p.add_argument("--kind", choices=KINDS, required=True, help="work-precision: error against cost; stability: verdict map")
    p.add_argument("--x", metavar="KEY", default=None, help="stability: parameter on the x axis (dt, restitution, mujoco.w0_dt, ...)")
    p.add_argument("--y", metavar="KEY", default=None, help="stability: parameter on the y axis")
    p.add_argument("--engines", "--engine", metavar="E[,E...]", default=None,
                   help="the engines to draw (comma-separated); None: every engine in the dataset")
    p.add_argument("--error", choices=ERROR_METRICS, default=None,
                   help="work-precision: metric of the first panel (the second: the sticking start in the same unit; "
                        "a metric no row measured gives way to one that was); None: exit_error_rel_max, or "
                        "exit_error_max for a dataset written before the relative errors existed")
    p.add_argument("--where", action="append", metavar="KEY=VALUE", default=None,
                   help="keep only rows with this parameter value (repeatable)")
    p.add_argument("--reference-cost", type=positive_float, default=None,
                   help="work-precision: the reference's wall-clock s per simulated s, drawn as a star; None: the rows' median")
    p.add_argument("--reference-error", type=positive_float, default=None,
                   help="work-precision: the reference's error [s]; None: its root precision, 1e-12")
    add_out(p, what="write the PNG and SVG here; None: charts/ beside the dataset")
    p.set_defaults(func=cmd_chart)
