"""`chatterbench atlas` as a user runs it: a small atlas (2 scenes x 2 engines, knobs held, dt capped), killed and
resumed without losing a finished case, the same tables through a real Dask cluster, and the report's atlas section;
the tables' known answers both ways."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.comparisons.outputs.atlas_files import atlas_frame, atlas_table_markdown, frontier_frame, grid_markdown
from chatterbench.comparisons.outputs.atlas_section import packaged_atlas, read_atlas, version_notes
from chatterbench.comparisons.studies.bench_tune import ATLAS_FIXED
from helpers import wait_until
from shared_runs import pybullet_ball_tune

# bench atlas's small atlas (its knobs held, dt capped at 300 steps/s): seconds a case
SMALL = ["bouncing-ball", "feigin-pair", "--engines", "pybullet,mujoco", "--max-runs", "40", "--max-cost", "300",
         *[w for knob, value in ATLAS_FIXED.items() for w in ("--set", f"{knob}={value}")]]
TIMED = ["wall_s"]  # the only columns a rerun may change


def _tables(out: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    atlas = pd.read_parquet(out / "atlas.parquet").drop(columns=TIMED)
    key = ["scene", "engine"]
    return (atlas.sort_values(key).reset_index(drop=True),
            pd.read_parquet(out / "frontier.parquet").sort_values([*key, "stick", "restitution"]).reset_index(drop=True))


@pytest.fixture(scope="module")
def small_atlas(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("atlas") / "small"
    assert main(["atlas", *SMALL, "--workers", "2", "--out", str(out)]) == 0
    return out


# -- known answers of the tables ------------------------------------------------------------------------------------

def _case(scene: str, engine: str, robust: bool, frontier: list[dict] | None = None, status: str = "ok") -> dict:
    if status != "ok":
        return {"scene": scene, "engine": engine, "status": status, "message": "RuntimeError: boom", "wall_s": 2.0,
                "runs": 0, "engine_version": "1"}
    frontier = frontier or []
    return {"scene": scene, "engine": engine, "status": "ok", "message": "", "wall_s": 10.0, "runs": 100,
            "engine_version": "1",
            "recommended": {"robust": robust, "dt": 0.002, "settings": {f"{engine}.knob": 0.1},
                            "cost_steps_per_s": 500.0, "written_tolerances": {"stick": 0.05, "restitution": 0.05},
                            "persistence": {"open_fraction": 0.0, "onsets_per_s": 0.0},
                            "tightest": {"stick": min((e["tolerances"]["stick"] for e in frontier), default=None),
                                         "restitution": min((e["tolerances"]["restitution"] for e in frontier),
                                                            default=None)},
                            "frontier": frontier}}


def _point(stick: float, restitution: float, cost: float) -> dict:
    return {"tolerances": {"stick": stick, "restitution": restitution}, "dt": 1 / cost, "settings": {},
            "cost_steps_per_s": cost, "margin": 0.5, "checked": {"runs": 70, "passed": 1.0},
            "persistence": {"open_fraction": 0.0, "onsets_per_s": 0.0}}


def test_the_atlas_table_says_what_each_case_reached_and_nothing_more():
    robust = _case("bouncing-ball", "pybullet", True, [_point(0.05, 0.05, 500.0), _point(0.01, 0.02, 900.0)])
    fragile = _case("bouncing-ball", "mujoco", False, [])  # nothing robust anywhere: no written setting
    failed = _case("bouncing-ball", "drake", False, status="failed")
    table = atlas_frame([robust, fragile, failed]).set_index("engine")
    assert table.loc["pybullet", "robust_at_asked"] and table.loc["pybullet", "tightest_stick"] == 0.01
    assert table.loc["pybullet", "frontier_points"] == 2 and table.loc["pybullet", "cost_steps_per_s"] == 500.0
    assert not table.loc["mujoco", "robust_at_asked"] and pd.isna(table.loc["mujoco", "tightest_stick"])
    assert table.loc["mujoco", "written"] == "" and pd.isna(table.loc["mujoco", "cost_steps_per_s"])
    assert table.loc["drake", "status"] == "failed" and "boom" in table.loc["drake", "message"]
    assert len(frontier_frame([robust, fragile, failed])) == 2


def test_names_from_a_case_are_escaped_in_the_markdown():
    hostile = _case("<img src=http://198.51.100.7/b.png>\n## INJ", "pybullet", True, [_point(0.05, 0.05, 500.0)])
    text = atlas_table_markdown(atlas_frame([hostile]))
    assert re.search(r"(?<!\\)<", text) is None and "\n## INJ" not in text and "\\<img" in text


def test_the_grid_names_each_cells_tightest_point_and_what_it_costs():
    robust = _case("bouncing-ball", "pybullet", True, [_point(0.05, 0.05, 500.0), _point(0.01, 0.02, 900.0)])
    written = _case("bouncing-ball", "mujoco", False, [_point(0.1, 0.3, 1919.0)])
    written["recommended"]["cost_steps_per_s"] = 1919.0
    nothing = _case("feigin-pair", "mujoco", False, [])
    failed = _case("feigin-pair", "pybullet", False, status="failed")
    grid = grid_markdown([robust, written, nothing, failed], ["bouncing-ball", "feigin-pair", "spring-pair"],
                         ["mujoco", "pybullet"]).splitlines()
    assert grid[2] == "| bouncing-ball | 10% / 30%; written at 1,919 | 1% / 2%; 5%/5% at 500 |"
    assert grid[3] == "| feigin-pair | none | failed |"
    assert grid[4] == "| spring-pair | not run | not run |"
    hostile = grid_markdown([], ["<img src=x>\n## INJ"], ["a|b"])
    assert "\\<img" in hostile and "\n## INJ" not in hostile and "a\\|b" in hostile


def test_the_readme_shows_the_kept_atlas_as_it_is():
    # the README's grid is the kept dataset's, cell for cell (renewing comparisons/atlas_data renews it)
    readme = (Path(__file__).resolve().parents[3] / "README.md").read_text()
    grid = grid_markdown(packaged_atlas().cases, ["bouncing-ball", "feigin-pair", "impact-damper", "spring-pair"],
                         ["mujoco", "pybullet", "dart", "physx", "drake", "mujoco_warp", "siconos"])
    assert grid in readme, "README.md's atlas grid is not the kept atlas's:\n" + grid
    cases = packaged_atlas().cases
    minutes = sum(c["wall_s"] for c in cases) / 60
    assert f"has {len(cases)} of the 28 cases" in readme and f"{minutes:.1f} min of case wall time" in readme
    elapsed = packaged_atlas().provenance.get("elapsed_s")  # the atlas's own wall time: cases overlap side by side
    assert elapsed is None or f"{elapsed / 60:.1f} min of wall time" in readme


# -- the command ----------------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_a_small_atlas_writes_its_cases_tables_and_charts(small_atlas):
    out = small_atlas
    for name in ("atlas.json", "atlas.csv", "atlas.parquet", "frontier.csv", "frontier.parquet", "atlas.md",
                 "figures/overview.png", "figures/frontier-bouncing-ball.png", "figures/frontier-feigin-pair.png"):
        assert (out / name).is_file(), name
    atlas, frontier = _tables(out)
    assert len(atlas) == 4 and set(atlas["status"]) == {"ok"}
    assert (frontier.groupby(["scene", "engine"]).size().reindex(pd.MultiIndex.from_frame(atlas[["scene", "engine"]]),
                                                                 fill_value=0).to_numpy()
            == atlas["frontier_points"].to_numpy()).all()
    ball = atlas.set_index(["scene", "engine"]).loc[("bouncing-ball", "pybullet")]
    # under 300 steps/s PyBullet's ball reaches a band-robust point (its tune found stick 10%, restitution 5% at 243)
    assert ball["tightest_stick"] <= 0.1 and ball["open_fraction"] <= 0.01
    provenance = json.loads((out / "atlas.json").read_text())
    assert provenance["versions"]["pybullet"] and provenance["command"].startswith("chatterbench atlas")
    assert "resumed" not in provenance  # one run, never resumed (before: two "resumed" dates from re-opening it)


@pytest.mark.slow
def test_the_cheapest_robust_point_matches_in_a_fresh_compare(small_atlas):
    # the other way round from the atlas: its point, pasted into `compare` at its own tolerances, passes
    case = json.loads((small_atlas / "cases" / "bouncing-ball" / "pybullet" / "case.json").read_text())
    point = case["recommended"]["frontier"][0]
    settings = [w for k, v in point["settings"].items() for w in ("--set", f"{k}={v}")]
    tolerances = [w for k in ("stick", "exit", "first_impact", "restitution")
                  for w in ("--tolerance", f"{k}={point['tolerances'][k]!r}")]
    words = [sys.executable, "-m", "chatterbench.comparisons.cli", "compare", "bouncing-ball", "--engines", "pybullet",
             "--dt", repr(point["dt"]), *settings, *tolerances]
    done = subprocess.run(words, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "match" in done.stdout, done.stdout + done.stderr


@pytest.mark.slow
def test_a_killed_atlas_resumes_one_case_at_a_time_keeping_every_finished_case(tmp_path, small_atlas):
    # killed after its first case (run with one worker, two cases side by side), then resumed one case at a time with
    # two: the tables are those of the atlas run whole two cases at a time (small_atlas), so the resume keeps what
    # was finished and one case at a time gives the side-by-side tables
    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "chatterbench.comparisons.cli", "atlas", *SMALL, "--workers", "1",
                             "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    first = out / "cases" / "bouncing-ball" / "pybullet" / "case.json"
    wait_until(lambda: first.is_file() or proc.poll() is not None, "the atlas finished no case", limit=600)
    assert proc.poll() is None, proc.communicate()
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    kept = first.read_bytes()
    assert not (out / "atlas.parquet").exists()  # killed before the end
    assert main(["atlas", *SMALL, "--workers", "2", "--cases-at-once", "1", "--out", str(out)]) == 0
    assert first.read_bytes() == kept  # the finished case was not run again
    assert len(json.loads((out / "atlas.json").read_text())["resumed"]) == 1  # the one rerun
    for mine, whole in zip(_tables(out), _tables(small_atlas)):
        pd.testing.assert_frame_equal(mine, whole)


@pytest.mark.slow
def test_an_atlas_on_a_dask_cluster_gives_the_local_tables(tmp_path, cluster, small_atlas):
    address, _ = cluster
    out = tmp_path / "on-cluster"
    done = subprocess.run([sys.executable, "-m", "chatterbench.comparisons.cli", "atlas", *SMALL, "--dask", address,
                           "--out", str(out)], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    for mine, local in zip(_tables(out), _tables(small_atlas)):
        pd.testing.assert_frame_equal(mine, local)


@pytest.mark.slow
def test_another_search_in_the_same_folder_is_refused(small_atlas, tmp_path, capsys):
    out = tmp_path / "copy"
    shutil.copytree(small_atlas, out)
    assert main(["atlas", *SMALL, "--tolerance", "0.1", "--out", str(out)]) == 2
    assert "another search" in capsys.readouterr().err


def test_bad_input_is_refused_before_any_case_runs(tmp_path, capsys):
    out = tmp_path / "atlas"
    for words, said in ((["--engines", "pybullet", "--set", "pybullet.nope=1"], "--set pybullet.nope=1: pybullet searches"),
                        (["--engines", "pybullet", "--set", "restitution=0.3"], "scene fields belong in a scene file"),
                        (["--engines", "bogus"], "engine 'bogus'"),
                        (["--engines", "pybullet", "--cases-at-once", "2", "--dask", "tcp://127.0.0.1:9"],
                         "--cases-at-once 2 with --dask")):
        argv = ["atlas", "bouncing-ball", *words, "--out", str(out)]
        assert main(argv) == 2
        assert said in capsys.readouterr().err
        assert not out.exists()  # nothing written, nothing run
    assert main(["atlas", "bouncing-ball", "--engines", "pybullet"]) == 2 and "--out DIR is needed" in capsys.readouterr().err
    for k in ("0", "9"):
        with pytest.raises(SystemExit) as stop:
            main(["atlas", "bouncing-ball", "--engines", "pybullet", "--cases-at-once", k, "--out", str(out)])
        assert stop.value.code == 2 and f"--cases-at-once: '{k}': must be an integer in [1, 8]" in capsys.readouterr().err
        assert not out.exists()


# -- the report's section -------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_the_report_shows_an_atlas_and_says_when_versions_differ(small_atlas, tmp_path):
    same = read_atlas(small_atlas)
    assert same.version_notes == () and len(same.cases) == 4
    moved = tmp_path / "moved"
    shutil.copytree(small_atlas, moved)
    spec = json.loads((moved / "atlas.json").read_text())
    spec["versions"]["pybullet"] = "0.0.1"
    (moved / "atlas.json").write_text(json.dumps(spec))
    out = tmp_path / "report"
    assert main(["report", "bouncing-ball", "--engines", "pybullet", "--atlas", str(moved), "--out", str(out)]) == 0
    md, page = (out / "report.md").read_text(), (out / "index.html").read_text()
    for text in (md, page):
        assert "Atlas: every engine" in text and "the atlas measured pybullet 0.0.1" in text
    assert page.count('id="atlas-frontier-') == 2 and 'id="atlas-overview"' in page


def test_a_link_in_an_atlas_folder_is_refused_by_name(tmp_path):
    outside = tmp_path / "outside.json"
    outside.write_text(json.dumps({"scene": "x", "engine": "y", "status": "ok"}))
    atlas = tmp_path / "atlas"
    (atlas / "cases" / "bouncing-ball" / "pybullet").mkdir(parents=True)
    (atlas / "atlas.json").write_text(json.dumps({"versions": {}}))
    (atlas / "cases" / "bouncing-ball" / "pybullet" / "case.json").symlink_to(outside)
    assert main(["report", "bouncing-ball", "--engines", "pybullet", "--atlas", str(atlas),
                 "--out", str(tmp_path / "r")]) == 2
    assert not (tmp_path / "r" / "report.md").exists()


def test_version_notes_name_an_engine_only_where_it_moved():
    from chatterbench.engines.registry import engine_version

    here = engine_version("pybullet")
    assert version_notes({"versions": {"pybullet": here}}, {"pybullet"}) == []
    (note,) = version_notes({"versions": {"pybullet": "0.0.1"}}, {"pybullet"})
    assert f"pybullet {here} is installed here" in note and "0.0.1" in note


def test_the_packaged_atlas_has_its_provenance():
    section = packaged_atlas()
    assert section is not None, "comparisons/atlas_data holds no atlas"
    p = section.provenance
    assert p["command"].startswith("chatterbench atlas") and p["machine"] and p["versions"] and p["code"]
    assert {c["status"] for c in section.cases} <= {"ok", "failed"} and len(section.cases) >= 2


@pytest.mark.slow
def test_a_cell_of_the_packaged_atlas_recomputed_from_scratch_gives_its_answer(tmp_path_factory):
    # the report's atlas is data kept in the repository: one of its cells, tuned again here with the atlas's own
    # search, reaches the same frontier (tolerances, dt, settings, cost); fixed-step costs, no timing decides it. The
    # kept atlas searched with tune's defaults, so its case is `tune bouncing-ball --engines pybullet` (the user's
    # command, made once a session: test_tune_rest_clients.py checks its answer in fresh PyBullet processes)
    from chatterbench.comparisons.pipeline.tolerances import Tolerances
    from chatterbench.comparisons.studies.limits import MAX_RUNS, ROBUST_FRACTION

    section = packaged_atlas()
    (kept,) = [c for c in section.cases if (c["scene"], c["engine"]) == ("bouncing-ball", "pybullet")]
    search = section.provenance["search"]
    assert search == {"tolerances": dataclasses.asdict(Tolerances()), "max_runs": MAX_RUNS, "robust_fraction": ROBUST_FRACTION,
                      "fixed": {}, "max_cost": None}, "the kept atlas no longer searched with tune's defaults"
    out, done = pybullet_ball_tune(tmp_path_factory)
    assert done["code"] == 0, done["err"]
    again = json.loads((out / "recommended.json").read_text())

    def answer(rec):
        return ([(e["tolerances"]["stick"], e["tolerances"]["restitution"], e["dt"], e["settings"], e["cost_steps_per_s"])
                 for e in rec["frontier"]], rec["tightest"], rec["robust"])

    assert json.loads(json.dumps(answer(again))) == json.loads(json.dumps(answer(kept["recommended"])))
    assert kept["recommended"]["frontier"], "the cell checked must have a frontier to compare"


def test_a_resumed_atlas_names_every_commit_its_cases_ran_on(tmp_path):
    atlas = tmp_path / "atlas"
    atlas.mkdir()
    (atlas / "atlas.json").write_text(json.dumps({"versions": {}, "code": "git aaa", "command": "chatterbench atlas"}))
    for engine, code in (("pybullet", "git aaa"), ("mujoco", "git bbb")):
        (atlas / "cases" / "bouncing-ball" / engine).mkdir(parents=True)
        case = {**_case("bouncing-ball", engine, False), "code": code}
        (atlas / "cases" / "bouncing-ball" / engine / "case.json").write_text(json.dumps(case))
    assert read_atlas(atlas).provenance["code"] == "cases made by git aaa, git bbb"
    (atlas / "cases" / "bouncing-ball" / "mujoco" / "case.json").write_text(
        json.dumps({**_case("bouncing-ball", "mujoco", False), "code": "git aaa"}))
    assert read_atlas(atlas).provenance["code"] == "git aaa"  # one commit: as the atlas says


def test_a_resumed_atlas_names_every_machine_its_cases_ran_on(tmp_path):
    """A case names the machine it ran on; cases from before that field are the atlas's machine's. One machine: as the
    atlas says; several: each with its count of cases, most first (the wall times are each machine's)."""
    atlas = tmp_path / "atlas"
    atlas.mkdir()
    (atlas / "atlas.json").write_text(json.dumps({"versions": {}, "machine": "x86_64, AMD EPYC, 2 cores",
                                                  "command": "chatterbench atlas"}))
    for engine, machine in (("pybullet", None), ("mujoco", None), ("dart", "x86_64, Intel Xeon, 2 cores")):
        (atlas / "cases" / "bouncing-ball" / engine).mkdir(parents=True)
        case = {**_case("bouncing-ball", engine, False), **({"machine": machine} if machine else {})}
        (atlas / "cases" / "bouncing-ball" / engine / "case.json").write_text(json.dumps(case))
    assert read_atlas(atlas).provenance["machine"] == ("x86_64, AMD EPYC, 2 cores (2 cases); "
                                                       "x86_64, Intel Xeon, 2 cores (1 case)")
    (atlas / "cases" / "bouncing-ball" / "dart" / "case.json").write_text(
        json.dumps({**_case("bouncing-ball", "dart", False), "machine": "x86_64, AMD EPYC, 2 cores"}))
    assert read_atlas(atlas).provenance["machine"] == "x86_64, AMD EPYC, 2 cores"  # one machine: as the atlas says


def test_a_case_names_the_machine_and_code_it_ran_on(tmp_path):
    """``run_case`` writes where it ran: this machine in the provenance's words, and the code."""
    from chatterbench.comparisons.studies.atlas import AtlasSpec, code_version, machine_name, run_case

    spec = AtlasSpec(scenes=("bouncing-ball",), engines=("pybullet",), fixed={"pybullet.no_such_knob": 1})
    case, _ = run_case(spec, "bouncing-ball", "pybullet")  # refused at once: a failed case, still saying where
    assert case["status"] == "failed" and "no_such_knob" in case["message"] and case["machine"] == machine_name() and case["code"] == code_version()
    assert machine_name().endswith(" cores") and machine_name().count(", ") == 2


def test_the_code_is_a_commit_only_of_a_checkout_that_tracks_chatterbench(tmp_path):
    """Installed (not editable) into a folder inside some other git repository, chatterbench names its own version:
    before, a pyenv's own git checkout put pyenv's commit (``git f6a5b409e9fd``) in every case.json of an atlas run
    from ``pip install .``; a venv inside a user's project would have put the project's. Its own checkout, tracking
    the file: the commit, and ``+changes`` when a tracked file changed."""
    from importlib.metadata import version

    from chatterbench.comparisons.studies.atlas import code_version

    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                              capture_output=True, text=True, check=True).stdout.strip()

    git("init", "-q")
    (tmp_path / "README").write_text("someone else's project\n")
    git("add", "README")
    git("commit", "-qm", "theirs")
    installed = tmp_path / "site-packages" / "chatterbench" / "comparisons" / "studies" / "atlas.py"
    installed.parent.mkdir(parents=True)
    installed.write_text("# as pip copies it: untracked here\n")
    assert code_version(installed) == f"chatterbench {version('chatterbench')}"
    git("add", str(installed))
    git("commit", "-qm", "tracked: a checkout of chatterbench")
    assert code_version(installed) == f"git {git('rev-parse', '--short=12', 'HEAD')}"
    installed.write_text("# changed\n")
    assert code_version(installed).endswith("+changes")


def test_each_case_runs_in_a_pool_of_its_own(tmp_path):
    # before: one pool served every case, so each worker held every engine it had run and what their runs left
    # (Drake keeps ~0.1 MB of every diagram it builds): 1.48 GB for one process of a four-engine spring-pair atlas
    from contextlib import contextmanager

    from chatterbench.comparisons.studies.atlas import AtlasSpec, run_atlas
    from chatterbench.comparisons.studies.pools import process_pool

    workers = []

    @contextmanager
    def pool():
        with process_pool(1) as executor:
            yield executor
            workers.append(executor.submit(os.getpid).result())  # the process that ran the case's candidates

    spec = AtlasSpec(scenes=("bouncing-ball",), engines=("pybullet", "mujoco"), max_runs=6, max_cost=300.0,
                     fixed=dict(ATLAS_FIXED))
    _, done = run_atlas(tmp_path / "atlas", spec, pool=pool)
    assert [done[("bouncing-ball", e)]["status"] for e in ("pybullet", "mujoco")] == ["ok", "ok"]
    assert len(workers) == 2 and workers[0] != workers[1] and os.getpid() not in workers


def _pool_events(tmp_path, at_once: int) -> tuple[list[str], dict[str, pd.DataFrame]]:
    """The events of a two-case atlas run ``at_once`` side by side ("made": a case's pool made, "done": shut down),
    in their order, and each case's rows."""
    from contextlib import contextmanager

    from chatterbench.comparisons.studies.atlas import AtlasSpec, run_atlas
    from chatterbench.comparisons.studies.pools import process_pool

    events = []

    @contextmanager
    def pool():
        events.append("made")
        with process_pool(1) as executor:
            yield executor
        events.append("done")

    spec = AtlasSpec(scenes=("bouncing-ball",), engines=("pybullet", "mujoco"), max_runs=6, max_cost=300.0,
                     fixed=dict(ATLAS_FIXED))
    out = tmp_path / f"at-once-{at_once}"
    _, done = run_atlas(out, spec, pool=pool, at_once=at_once)
    assert [done[("bouncing-ball", e)]["status"] for e in ("pybullet", "mujoco")] == ["ok", "ok"]
    made = json.loads((out / "atlas.json").read_text())  # the atlas's own wall time, not its cases' summed
    assert isinstance(made["elapsed_s"], float) and made["cases_at_once"] == at_once
    rows = {e: pd.read_parquet(out / "cases" / "bouncing-ball" / e / "candidates.parquet").drop(
        columns=["cost_per_sim_s"]) for e in ("pybullet", "mujoco")}
    return events, rows


def test_cases_side_by_side_overlap_and_give_the_rows_of_cases_one_after_another(tmp_path):
    # the cases of an atlas ran one after another: a case's pool left its workers idle between passes and through
    # a pass's last candidates (the kept atlas ran at 166% CPU with 2 workers on 2 cores)
    alone, rows_alone = _pool_events(tmp_path, 1)
    together, rows_together = _pool_events(tmp_path, 2)
    assert alone == ["made", "done", "made", "done"]  # one after another: the second pool made once the first is done
    assert together == ["made", "made", "done", "done"]  # side by side: the second made while the first runs
    for engine in rows_alone:  # every row the same but the measured time
        pd.testing.assert_frame_equal(rows_alone[engine], rows_together[engine])


def test_the_provenance_names_the_atlas_wall_time_and_its_cases_summed():
    from chatterbench.comparisons.outputs.atlas_files import provenance_sentence

    kept = {"command": "chatterbench atlas", "wall_s": 4812.0}  # an atlas made before elapsed_s was recorded
    assert ", 80.2 min of wall time over its cases;" in provenance_sentence(kept)
    side = provenance_sentence({**kept, "elapsed_s": 3480.0, "cases_at_once": 2})
    assert ", 58.0 min of wall time (80.2 min of wall time over its cases, up to 2 side by side);" in side
    alone = provenance_sentence({**kept, "elapsed_s": 4830.0, "cases_at_once": 1})
    assert ", 80.5 min of wall time (80.2 min of wall time over its cases);" in alone
    for bogus in ("3480", None, float("nan"), True):  # a hand-edited atlas.json: the cases' sum only
        assert ", 80.2 min of wall time over its cases;" in provenance_sentence({**kept, "elapsed_s": bogus})


def test_cases_expected_longest_run_first_and_the_kept_atlas_sets_the_order(tmp_path):
    # side by side, a long case started last runs alone at the end: the ball's seven cases in the scene's order put
    # MuJoCo Warp's (the longest) last, and it ran alone for 2 of the 8 minutes
    from chatterbench.comparisons.cli.atlas import _kept_walls
    from chatterbench.comparisons.studies.atlas import AtlasSpec, run_atlas

    spec = AtlasSpec(scenes=("bouncing-ball",), engines=("pybullet", "mujoco"), max_runs=6, max_cost=300.0,
                     fixed=dict(ATLAS_FIXED))
    for expected, first in (({("bouncing-ball", "mujoco"): 90.0, ("bouncing-ball", "pybullet"): 20.0}, "mujoco"),
                            ({("bouncing-ball", "mujoco"): 20.0, ("bouncing-ball", "pybullet"): 90.0}, "pybullet"),
                            (None, "pybullet")):  # none expected: the order asked
        began = []
        run_atlas(tmp_path / f"{first}-{expected is None}", spec, at_once=2, expected=expected,
                  started=lambda scene, engine, k, n: began.append(engine))
        assert began[0] == first
    kept = _kept_walls()  # the kept atlas: each of its 28 cases' wall time
    assert len(kept) == 28 and kept[("bouncing-ball", "mujoco_warp")] > kept[("bouncing-ball", "drake")] > 0
