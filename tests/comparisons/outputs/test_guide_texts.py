"""The guide's sentences as a user reads them (issue 33, texts): counts in words, checks with nothing to measure
named as such, and a fragile pass called cheaper only when it is.

Before: a bouncing-ball guide said "all 1 episodes pass" and "exit nan" (the ball never slides off, so
there is no exit to measure), and a fragile pass at the answer's own cost was headed "Fragile (cheaper,
...)". Each result here comes from a real tune of PyBullet (one dt, no refinement: about a second).
"""

from __future__ import annotations

import dataclasses
import re

import pytest

from chatterbench.comparisons.cli.tune import answer_lines
from chatterbench.comparisons.outputs.guide import guide_markdown
from chatterbench.comparisons.studies.tune import tune
from chatterbench.reference.scene import load_scene


@pytest.fixture(scope="module")
def ball():
    """bouncing-ball (one episode, which never exits), PyBullet at one dt with a bounce threshold (its default 0
    bounces at g dt forever after the stick: buzz): a robust match."""
    return tune(load_scene("bouncing-ball"), "pybullet", 0.05, space=BALL_SPACE, workers=1, refine_steps=0,
                ladder=None, phases=(), transfer=False)


BALL_SPACE = {"dt": (1e-3,), "pybullet.restitution_velocity_threshold": (0.1,)}


def test_one_episode_is_said_in_words_and_an_absent_exit_is_not_nan(ball):
    assert ball.best is not None and ball.best["n_episodes"] == 1
    text = guide_markdown(ball)
    assert "its one episode passes" in text and "all 1 episodes" not in text
    assert not re.search(r"\bnan\b", text), [line for line in text.splitlines() if re.search(r"\bnan\b", line)]
    ratios = next(line for line in text.splitlines() if "Each check's worst error" in line)
    assert re.search(r"nothing to measure for [^.;]*\bexit\b", ratios), ratios
    assert re.search(r"sticking \d", ratios), ratios  # the measured ones keep their number


def test_several_episodes_are_counted():
    pair = tune(load_scene("feigin-pair"), "pybullet", 0.05, space={"dt": (1e-3,)}, workers=1, refine_steps=0,
                ladder=None, transfer=False)
    n = pair.chosen["n_episodes"]
    assert n > 1
    text = guide_markdown(pair)
    want = f"all {n} episodes pass" if pair.best is not None else f"{pair.chosen['n_match']} of {n} episodes match"
    assert want in text


def test_a_fragile_pass_is_called_cheaper_only_when_it_is(ball):
    row = ball.best
    same = {**row, "settings": "dt=0.001, erp=0.3", "neighbourhood": "dt x 1.25 late"}
    cheaper = {**same, "steps_per_sim_s": row["steps_per_sim_s"] / 2}
    for fragile, word in ((same, "as cheap"), (cheaper, "cheaper")):
        result = dataclasses.replace(ball, fragile=fragile)
        text = guide_markdown(result)
        head = next(line for line in text.splitlines() if "**Fragile" in line)
        assert head.startswith(f"**Fragile ({word}, but an isolated pass):**"), head
        assert f"(the answer: {row['steps_per_sim_s']:.3g})" in head
        terminal = [line for line in answer_lines(result) if line.startswith("fragile")]
        assert terminal and terminal[0].startswith(f"fragile ({word},"), terminal
