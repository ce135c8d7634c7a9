"""Sweeps: one scene, some engines, a grid of scene fields and engine settings -> one row per run.

    >>> from chatterbench.comparisons.studies.sweep import load_sweep, run_sweep
    >>> sweep = load_sweep("examples/sweeps/bouncing-ball-dt.toml")
    >>> len(sweep.engines), sweep.scene_name
    (2, 'bouncing-ball')

Modules, in the order a sweep goes through them: ``spec`` (the TOML spec, validated in full
before any engine starts; the runs it asks for), ``worker`` (one run, isolated in a child
process, to its row), ``dataset`` (rows as Parquet parts, read back and normalised),
``runner`` (the runs on a local pool or a Dask cluster, resumable, with progress); for an
adaptive map (``[refine]``), ``refine`` (the table, where cells split, the fine map they
stand for) and ``adaptive`` (each level's runs from the rows before it, and how well the
result stands for the full fine grid).
"""

from .dataset import DatasetError, load_rows, read_rows
from .directory import OutDirError
from .runner import NO_WORKER_WAIT, NO_WORKERS, NoWorkersError, run_sweep
from .spec import DEFAULT_TIMEOUT, FAILED, MAX_TIMEOUT, RunTask, SpecError, Sweep, load_sweep, sweep_points, sweep_runs
from .worker import run_batch_task, run_task, work_units

__all__ = ["DEFAULT_TIMEOUT", "FAILED", "MAX_TIMEOUT", "NO_WORKERS", "NO_WORKER_WAIT", "DatasetError", "NoWorkersError",
           "OutDirError", "RunTask", "SpecError", "Sweep", "load_rows", "load_sweep", "read_rows", "run_batch_task",
           "run_sweep", "run_task", "sweep_points", "sweep_runs", "work_units"]
