"""``chatterbench compare`` on several scenes at once (issue 44's command): each scene's tables in the order given,
one folder per scene under --out, and every scene checked before the first run."""

from __future__ import annotations

import pandas as pd

from helpers import cli

SHORT = ["--engines", "pybullet", "--set", "duration=0.6", "--dt", "1e-3"]  # the first impact of each scene, 1 ms steps


def test_several_scenes_print_their_tables_in_order_and_write_a_folder_each(tmp_path):
    done = cli(["compare", "bouncing-ball", "spring-pair", *SHORT, "--out", str(tmp_path / "out"), "--no-figures"])
    assert done.code == 0, done.err
    ball, spring = done.out.index("bouncing-ball: engine episodes"), done.out.index("spring-pair: engine episodes")
    assert ball < spring
    for scene in ("bouncing-ball", "spring-pair"):  # each folder the scene's own first impact, at 0.4515 s for the ball
        events = pd.read_csv(tmp_path / "out" / scene / "events_pybullet.csv")
        first = float(events[events["kind"] == "impact"]["t"].iloc[0])
        assert (abs(first - 0.4515) < 2e-3) == (scene == "bouncing-ball")
    # the other way: one scene writes its files into --out itself, as before
    one = cli(["compare", "bouncing-ball", *SHORT, "--out", str(tmp_path / "one"), "--no-figures"])
    assert one.code == 0 and (tmp_path / "one" / "episodes.csv").is_file()


def test_a_scene_that_does_not_load_is_refused_before_any_run(tmp_path, engine_runs):
    done = cli(["compare", "bouncing-ball", "no-such-scene", *SHORT])
    assert done.code == 2 and "no-such-scene" in done.err and engine_runs() == []
    twice = cli(["compare", "bouncing-ball", "bouncing-ball", *SHORT, "--out", str(tmp_path / "o")])
    assert twice.code == 2 and "given more than once" in twice.err and engine_runs() == []
    # without --out the same scene twice is two runs of it, each with its tables
    again = cli(["compare", "bouncing-ball", "bouncing-ball", *SHORT])
    assert again.code == 0 and again.out.count("bouncing-ball: engine episodes") == 2
