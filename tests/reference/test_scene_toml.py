"""``chatterbench scenes --toml NAME``: a file to start from that runs exactly as the built-in scene."""

from __future__ import annotations

import io
import tomllib
from contextlib import redirect_stdout

import pytest

from chatterbench.comparisons.cli.main import main
from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import load_scene
from chatterbench.reference.simulate import simulate


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_the_toml_of_a_built_in_scene_runs_byte_for_byte_the_same(name, tmp_path):
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["scenes", "--toml", name]) == 0
    text = out.getvalue()
    assert all(line.startswith(("#", "[")) or " # [" in line or line.startswith(("name", "description", "kind", "on"))
               for line in text.splitlines() if line), text  # every number says its unit
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    from_file, built_in = load_scene(str(path)), load_scene(name)
    assert from_file == built_in
    for mode in ("feigin", "exhaustive"):
        a = simulate(from_file, mode).log.to_csv(index=False, float_format="%.17g")
        b = simulate(built_in, mode).log.to_csv(index=False, float_format="%.17g")
        assert a == b


def test_a_toml_value_changed_by_hand_is_read(tmp_path):
    out = io.StringIO()
    with redirect_stdout(out):
        main(["scenes", "--toml", "feigin-pair"])
    text = out.getvalue().replace("restitution = 0.5", "restitution = 0.8")
    assert tomllib.loads(text)["restitution"] == 0.8
    path = tmp_path / "edited.toml"
    path.write_text(text, encoding="utf-8")
    assert load_scene(str(path)).restitution == 0.8
