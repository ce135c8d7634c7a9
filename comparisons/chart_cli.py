"""The ``chatterbench chart`` subcommand: draw a chart from a finished sweep dataset, rerunning nothing.

    $ chatterbench chart out/fp --kind work-precision
    $ chatterbench chart out/fp/rows.parquet --kind stability --x dt --y restitution --engine mujoco
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

import pandas as pd

KINDS = ("work-precision", "stability")
ERROR_METRICS = ("exit_error_max", "stick_error_max", "stick_error_plate_max", "first_impact_error_max",
                 "exit_error_rel_max", "stick_error_rel_max", "restitution_error_max")


def load_rows(path: str | Path) -> pd.DataFrame:
    """The rows of a dataset: a sweep directory (``rows.parquet``), a ``.parquet`` or a ``.csv`` file."""
    from .cli import UsageError
    from .pipeline.summary import ROW_COLUMNS

    path = Path(path)
    if path.is_dir():
        if not (path / "rows.parquet").is_file():
            hint = (" (the sweep has not finished: finish it with `chatterbench sweep SPEC --out DIR --resume`)"
                    if (path / "rows").is_dir() else " (give a sweep output directory, a .parquet or a .csv file)")
            raise UsageError(f"{path}: no rows.parquet in this directory{hint}")
        path = path / "rows.parquet"
    elif not path.exists():
        raise UsageError(f"{path}: no such file or directory")
    try:
        if path.suffix == ".parquet":
            rows = pd.read_parquet(path)
        elif path.suffix == ".csv":
            # "none" is a verdict, not a missing value; an empty message is ""
            rows = pd.read_csv(path, keep_default_na=False, na_values=["", "nan", "NaN"],
                               dtype={"verdict": str, "status": str, "engine": str, "scene": str, "message": str})
        else:
            raise UsageError(f"{path}: expected a sweep directory, a .parquet or a .csv file")
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: cannot read the rows ({exc})") from None
    missing = [c for c in ("engine", "dt", "verdict", "cost_per_sim_s") if c not in rows.columns]
    if missing:
        raise UsageError(f"{path}: not a sweep dataset, missing columns {', '.join(missing)} "
                         f"(expected {', '.join(ROW_COLUMNS)} and one column per parameter)")
    if rows.empty:
        raise UsageError(f"{path}: the dataset has no rows")
    return rows


def _where(rows: pd.DataFrame, items: list[str]) -> pd.DataFrame:
    """Keep the rows whose parameter KEY equals VALUE (numbers compared to 1e-9 relative).

    An engine's setting (``mujoco.w0_dt``, ``pybullet.restitution_velocity_threshold``)
    selects among that engine's rows only: the other engines' rows stay, so
    ``--where mujoco.w0_dt=0.03 --where pybullet.restitution_velocity_threshold=0`` keeps
    each engine at one setting.
    """
    from .cli import UsageError
    from .sweep_charts import check_columns, equals, parameter_columns

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
    import matplotlib.pyplot as plt

    from .atomic import write_bytes
    from .outputs import figure_bytes

    paths = [write_bytes(out / f"{stem}.{fmt}", figure_bytes(fig, fmt)) for fmt in ("png", "svg")]
    plt.close(fig)
    return paths


def cmd_chart(args: argparse.Namespace) -> int:
    from .cli import UsageError, print_table
    from .sweep_charts import (check_columns, pareto_front, stability_map_figure, verdict_grid,
                               work_precision_figure, work_precision_points)

    rows = load_rows(args.dataset)
    rows = _where(rows, args.where or [])
    out = Path(args.out) if args.out else _default_out(Path(args.dataset))
    if args.engine:
        check_columns(rows, [args.engine], sorted(rows["engine"].astype(str).unique()), what="engine")
    if args.kind == "work-precision":
        if args.x or args.y:
            raise UsageError("--x/--y are for --kind stability; work-precision always draws error against cost")
        if args.engine:
            rows = rows[rows["engine"] == args.engine]
        fig = work_precision_figure(rows, error=args.error, reference_cost=args.reference_cost,
                                    reference_error=args.reference_error)
        metrics = list(dict.fromkeys([args.error, "stick_error_max"]))
        points = work_precision_points(rows, metrics)
        for m in metrics:
            points[f"front_{m.removesuffix('_max')}"] = pareto_front(points, m).map({True: "*", False: ""})
        show = points.drop(columns=["settings", "engine"])
        print_table(show, title=f"work-precision: {len(points)} points from {len(rows)} rows "
                                f"(errors [s], worst over the folded rows; * = on the Pareto front)")
        paths = _save(fig, out, "work_precision")
    else:
        if not (args.x and args.y):
            raise UsageError("--kind stability needs --x KEY and --y KEY (two swept parameters, e.g. --x dt --y restitution)")
        fig = stability_map_figure(rows, args.x, args.y, args.engine)
        engines = [args.engine] if args.engine else sorted(rows["engine"].astype(str).unique())
        counts = []
        for e in engines:
            grid = verdict_grid(rows, args.x, args.y, e)
            if grid.empty:
                continue
            cells = grid.stack().value_counts()
            counts.append({"engine": e, "cells": f"{grid.shape[1]} x {grid.shape[0]}", **cells.to_dict()})
        print_table(pd.DataFrame(counts).fillna(0), title=f"stability map: cells per verdict, {args.x} (x) by {args.y} (y)")
        stem = f"stability_{args.x}_{args.y}" + (f"_{args.engine}" if args.engine else "")
        paths = _save(fig, out, stem)
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _finite_positive(text: str) -> float:
    from .cli import _positive_float

    return _positive_float(text)


def register(sub) -> None:
    """Add ``chart`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("chart", help="draw the work-precision chart or a stability map from a finished sweep dataset")
    p.add_argument("dataset", metavar="DATASET", help="sweep output directory (rows.parquet), or a .parquet / .csv of rows")
    p.add_argument("--kind", choices=KINDS, required=True, help="work-precision: error against cost; stability: verdict map")
    p.add_argument("--x", metavar="KEY", help="stability: parameter on the x axis (dt, restitution, mujoco.w0_dt, ...)")
    p.add_argument("--y", metavar="KEY", help="stability: parameter on the y axis")
    p.add_argument("--engine", help="draw only this engine")
    p.add_argument("--error", choices=ERROR_METRICS, default="exit_error_max",
                   help="work-precision: metric of the first panel (default exit_error_max; the second is stick_error_max)")
    p.add_argument("--where", action="append", metavar="KEY=VALUE", help="keep only rows with this parameter value (repeatable)")
    p.add_argument("--reference-cost", type=_finite_positive, default=None,
                   help="work-precision: the reference's wall-clock s per simulated s, drawn as a star")
    p.add_argument("--reference-error", type=_finite_positive, default=None,
                   help="work-precision: the reference's error [s] (its root precision, ~1e-12)")
    p.add_argument("--out", metavar="DIR", help="write the PNG and SVG here (default: charts/ beside the dataset)")
    p.set_defaults(func=cmd_chart)
