"""Newton's exported script (``run --export-model scene.py``): run in a fresh process with newton alone, it prints the
run's impacts as chatterbench's judge measures them."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

pytest.importorskip("newton", reason="the newton extra is not installed: pip install \".[newton]\"")

from chatterbench.comparisons.pipeline.extract import extract  # noqa: E402
from chatterbench.comparisons.pipeline.solution import solve  # noqa: E402
from chatterbench.comparisons.pipeline.tolerances import Tolerances  # noqa: E402
from chatterbench.engines.registry import make_settings, run_engine  # noqa: E402
from chatterbench.reference import load_scene  # noqa: E402

from helpers import cli as cli_here  # noqa: E402

# the script must not need chatterbench: it runs in a fresh interpreter where importing chatterbench fails
NO_CHATTERBENCH = "import sys; sys.modules['chatterbench'] = None; exec(open(sys.argv[1]).read())"


def _printed(stdout: str) -> list[tuple[float, float, float, float]]:
    """(t, v_in, v_out, e) of each ``impact`` line the script printed, after its ``# impact:`` header."""
    header, *lines = stdout.splitlines()
    assert header.startswith("# impact: ")
    return [tuple(float(w.split("=")[1]) for w in line.split()[1:]) for line in lines if line.startswith("impact ")]


def _exported_and_run(tmp_path, run_args: list[str]) -> tuple[int, list[tuple[float, float, float, float]]]:
    """``chatterbench run RUN_ARGS --export-model scene.py``, then the script in a fresh process without chatterbench:
    the impacts the run counted, and the (t, v_in, v_out, e) lines the script printed."""
    done = cli_here(["run", *run_args, "--export-model", str(tmp_path / "scene.py")])
    assert done.code == 0, done.err
    counted = int(re.search(r"(\d+) impacts", done.out).group(1))
    out = subprocess.run([sys.executable, "-c", NO_CHATTERBENCH, str(tmp_path / "scene.py")], capture_output=True,
                         text=True, cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stderr
    return counted, _printed(out.stdout)


@pytest.mark.parametrize("engine, sets", [("newton_xpbd", []), ("newton_semi", []),
                                          ("newton_xpbd", ["newton_xpbd.length_unit=1000"])])
def test_the_exported_script_prints_the_runs_impacts(tmp_path, engine, sets):
    over = "duration=1.3"  # six bounces and the start of the chatter: the script's run is a few seconds
    counted, printed = _exported_and_run(
        tmp_path, ["bouncing-ball", "--engines", engine, "--set", over, *[w for o in sets for w in ("--set", o)]])
    scene = load_scene("bouncing-ball", [over])
    settings = make_settings(engine, overrides=sets)
    found = extract(run_engine(engine, scene, settings), scene, solve(scene).stick_tolerance(Tolerances().stick))
    judged = found.log[found.log["kind"] == "impact"]
    assert len(printed) == counted == len(judged) >= 5
    for (t, v_in, v_out, e), row in zip(printed, judged.itertuples()):
        # the same engine, model, forces and sampling in float32: the judge's impacts to its printed digits
        assert t == pytest.approx(row.t, abs=1e-6) and v_in == pytest.approx(row.v_minus, rel=1e-5)
        assert e == pytest.approx(-row.v_plus / row.v_minus, rel=1e-5, nan_ok=True)
    first = printed[0]
    assert first[3] == pytest.approx(0.5, abs=0.02)  # the ball bounces with R (semi: within its phase error)


SHAKER = """name = "shaker"
mass1 = "inf"
mass2 = 1.0
restitution = 0.5
duration = 6.5
[gap]
lower = -0.1
upper = 0.1
[prescribed]
amplitude = 1.0
omega = 1.0
[initial]
x1 = 0.0
v1 = 1.0
"""


@pytest.mark.parametrize("engine", ["newton_xpbd", "newton_semi"])
def test_the_exported_script_moves_a_prescribed_body_1(tmp_path, engine):
    # a box moved as x1 = sin t (a kinematic link in the script too): the script's impacts are the run's
    (tmp_path / "shaker.toml").write_text(SHAKER)
    counted, printed = _exported_and_run(tmp_path, [str(tmp_path / "shaker.toml"), "--engines", engine, "--dt", "1e-3"])
    assert len(printed) == counted >= 5
