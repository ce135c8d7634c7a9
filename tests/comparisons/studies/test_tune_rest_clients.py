"""The top-level answer of `tune bouncing-ball --engines pybullet` (the default tolerances: stick 5%, restitution 5%),
rebuilt from scratch as users rebuilt it (issue 41; the clients: tests/rest_clients.py), dropped from 0.5, 1 and 2 m
for 10 s: the guide's persistence and restitution claims hold at each height it says the answer transfers to. The tune
is made once a session (shared_runs.pybullet_ball_tune): test_atlas.py compares it with the kept atlas's cell. MuJoCo's: test_tune_frontier.py, on its
tune (one search, shared). The other way: the client finds PyBullet's old answer flickering.
"""

from __future__ import annotations

import json

import pytest

from rest_clients import check_rest_claims, run_client
from shared_runs import pybullet_ball_tune


@pytest.mark.slow  # PyBullet's default tune (about a minute, shared) and three 10 s runs in fresh processes
def test_pybullets_top_level_answer_rests_at_every_height_the_guide_claims(tmp_path, tmp_path_factory):
    out, done = pybullet_ball_tune(tmp_path_factory)
    assert done["code"] == 0, done["err"]  # robust at 5%
    assert check_rest_claims("pybullet", out / "recommended.json", tmp_path) >= 2


@pytest.mark.slow  # one 10 s PyBullet run in a fresh process
def test_the_client_finds_the_flicker_of_the_old_answer(tmp_path):
    # the other way: PyBullet's answer before issue 41 (dt 0.0031, threshold 0), its snippet pasted the same way
    from chatterbench.engines.registry import adapter, make_settings
    from chatterbench.reference import load_scene

    snippet = adapter("pybullet").snippet(load_scene("bouncing-ball"), make_settings("pybullet", 0.0031, {}))
    (tmp_path / "old.json").write_text(json.dumps({"snippet": snippet}))
    m = run_client("pybullet", tmp_path / "old.json", 1.0, tmp_path)
    assert m["onsets"] / m["span"] > 100 and m["open"] > 0.3, m["onsets"]
