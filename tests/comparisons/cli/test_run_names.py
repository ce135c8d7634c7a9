"""`run`'s episode table names each quantity as compare and report do: t_stick is the judge's sticking start."""

from __future__ import annotations

import io
import math
from contextlib import redirect_stdout

import pandas as pd
import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.pipeline.compare import judge_run
from chatterbench.comparisons.pipeline.solution import solve
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.engines.registry import make_settings
from chatterbench.reference import load_scene

SET = ["--set", f"duration={2 * math.pi}"]  # one forcing period: a lower and an upper visit


def _table(argv: list[str], tmp_path) -> pd.DataFrame:
    with redirect_stdout(io.StringIO()):
        assert main([*argv, *SET, "--out", str(tmp_path)]) == 0
    return pd.read_csv(tmp_path / "episodes.csv")


def test_reference_run_t_stick_is_the_judges_and_the_plate_entry_has_its_own_name(tmp_path):
    table = _table(["run", "feigin-pair"], tmp_path)
    ref = solve(load_scene("feigin-pair", [f"duration={2 * math.pi}"]))
    # the judge's sticking start (the Zeno point, 1.6447 s on the first visit), not Feigin's plate entry (1.5977 s)
    assert table["t_stick"].tolist() == pytest.approx(ref.episodes["t_stick"].tolist(), rel=1e-12)
    assert table["t_plate"].tolist() == pytest.approx(ref.episodes["t_plate_entry"].tolist(), rel=1e-12)
    assert round(table["t_stick"][0], 4) == 1.6447 and round(table["t_plate"][0], 4) == 1.5977
    assert "t_plate_entry" not in table


def test_engine_run_t_stick_is_what_compare_judges(tmp_path):
    table = _table(["run", "feigin-pair", "--engines", "mujoco", "--dt", "1e-3"], tmp_path)
    scene = load_scene("feigin-pair", [f"duration={2 * math.pi}"])
    _, judged, _ = judge_run(solve(scene), "mujoco", make_settings("mujoco", 1e-3), Tolerances())
    assert table["t_stick"].tolist() == pytest.approx(judged["t_stick"].dropna().tolist(), rel=1e-12)
