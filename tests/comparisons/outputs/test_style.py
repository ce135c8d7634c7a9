"""Every engine has its own colour, the same in every chart: a built-in one, a plugin's and a name no table holds."""

from __future__ import annotations

import subprocess
import sys

from chatterbench.comparisons.outputs.style import (EXIT_COLOUR, PALETTE, REFERENCE_COLOUR, STICK_COLOUR,
                                                    engine_colour)
from chatterbench.engines.registry import ENGINE_NAMES


def test_the_first_engines_keep_their_colours():
    # known answer: the colours the charts had before the palette (MuJoCo blue, PyBullet red, Drake orange, Warp cyan)
    assert [engine_colour(n) for n in ("mujoco", "pybullet", "drake", "mujoco_warp")] == [
        "#1f77b4", "#d62728", "#ff7f0e", "#17becf"]
    assert engine_colour("reference") == REFERENCE_COLOUR == "black"


def test_every_engine_of_the_table_has_its_own_colour_and_none_is_taken():
    colours = [engine_colour(n) for n in ENGINE_NAMES]
    assert len(set(colours)) == min(len(ENGINE_NAMES), len(PALETTE))  # before: PhysX, DART, Siconos all "C2".. or grey
    assert not {REFERENCE_COLOUR, STICK_COLOUR, EXIT_COLOUR} & set(PALETTE)  # the reference, sliding and exits stay apart


def test_an_engine_outside_the_table_gets_a_palette_colour_the_same_in_every_process():
    name = "my_simulator"  # a trajectory file's simulator, or a plugin of another machine
    assert name not in ENGINE_NAMES and engine_colour(name) in PALETTE
    code = f"from chatterbench.comparisons.outputs.style import engine_colour; print(engine_colour({name!r}))"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                           env={"PYTHONHASHSEED": "123", "PATH": ""})
    assert other.stdout.strip() == engine_colour(name)  # a hash of the name, not Python's salted hash()
