"""Gravity from the command line (issue 41 item 4): ``run`` of a ball lighter or heavier than 1 kg falls at g, in the
reference and in every installed engine, and a scene file that gives the weight as a force is read as gravity, with a
note on stderr from every command that loads it."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from chatterbench.engines.registry import ENGINE_NAMES

from helpers import cli, needs_engine

T1 = math.sqrt(2.0 / 9.81)  # [s] a fall from rest through 1 m at g = 9.81 m/s^2: 0.45152 s, whatever the mass
DT = 1e-4  # [s] the engines' step here
# the 0.6 s run holds the first impact (the chatter's episode needs 2 s and 7 s of reference): its event log is read
SHORT = ["--set", "duration=0.6"]
NOTE = ("chatterbench: note: 'old-ball': forces[0]: constant -9.81 N on body2 (mass2 1 kg) read as gravity = -9.81 "
        "m/s^2 (the force now follows the mass)")


def _first_impact(tmp_path, *args: str) -> tuple[float, str]:
    """The first impact's time [s] in the event log ``run ARGS --events`` writes, and what the command printed to
    stderr."""
    events = tmp_path / "events.csv"
    done = cli(["run", *args, *SHORT, "--events", str(events)])
    assert done.code == 0, done.err
    log = pd.read_csv(events)
    return float(log[log["kind"] == "impact"]["t"].iloc[0]), done.err


def _ball_file(tmp_path, force: float, gravity: str = "") -> str:
    path = tmp_path / "old-ball.toml"
    path.write_text(f'name = "old-ball"\nmass1 = "inf"\nmass2 = 1.0\nrestitution = 0.5\n{gravity}'
                    "[gap]\nlower = 0.0\n[initial]\ny = 1.0\n"
                    f'[[forces]]\nkind = "constant"\non = "body2"\nvalue = {force!r}\n')
    return str(path)


@pytest.mark.parametrize("mass2", [0.2, 1.0, 5.0])
def test_the_reference_ball_falls_at_g_whatever_its_mass(tmp_path, mass2):
    # before: a constant force of -9.81 N, so the 0.2 kg ball fell at 49 m/s^2 and struck at 0.2019 s; 1e-12 s: the
    # reference's event times (roots.py, 1e-14 relative), written with 17 digits
    t, err = _first_impact(tmp_path, "bouncing-ball", "--set", f"mass2={mass2}")
    assert t == pytest.approx(T1, abs=1e-12) and "note" not in err


# PhysX's speculative contact acts on a body that would reach the wall just after the step's end
# (docs/explanation/engines.md, PhysX's TGS against PGS): its impact can come a step before the crossing's step,
# 1.24 steps early here (0.4514 s)
STEPS = {"physx": 2.0}


@pytest.mark.parametrize("engine", [pytest.param(e, marks=pytest.mark.slow) if e == "mujoco_warp" else e
                                    for e in ENGINE_NAMES])
def test_each_engine_ball_falls_at_g_whatever_its_mass(tmp_path, engine):
    needs_engine(engine)
    times = {m: _first_impact(tmp_path, "bouncing-ball", "--set", f"mass2={m}", "--engines", engine, "--dt", str(DT))[0]
             for m in (0.2, 5.0)}
    print(f"{engine}: first impact at {times} s")
    for t in times.values():  # within one step (a 49 m/s^2 fall struck 0.25 s early, a 1.96 m/s^2 one 0.56 s late)
        assert abs(t - T1) <= STEPS.get(engine, 1.0) * DT
    # and the same for both masses (measured identical, float32 engines too): the weight follows the mass
    assert times[0.2] == pytest.approx(times[5.0], abs=1e-9)


def test_a_files_weight_given_as_a_force_is_read_as_gravity_with_a_note(tmp_path):
    path = _ball_file(tmp_path, -9.81)
    t, err = _first_impact(tmp_path, path, "--set", "mass2=0.2")
    assert t == pytest.approx(T1, abs=1e-12)
    assert err.splitlines().count(NOTE) == 1, err


@pytest.mark.parametrize("force,gravity,t1", [
    (-9.81, "gravity = 0.0\n", math.sqrt(2.0 * 0.2 / 9.81)),  # the file says its gravity: the force stays a force
    (-4.0, "", math.sqrt(2.0 * 0.2 / 4.0)),  # not m g: a force, whatever the mass
])
def test_a_constant_force_that_is_no_weight_stays_a_force_without_a_note(tmp_path, force, gravity, t1):
    t, err = _first_impact(tmp_path, _ball_file(tmp_path, force, gravity), "--set", "mass2=0.2")
    assert t == pytest.approx(t1, abs=1e-12) and "note" not in err


def test_the_built_in_balls_file_gives_gravity_not_a_force():
    done = cli(["scenes", "--toml", "bouncing-ball"])
    assert done.code == 0 and "\ngravity = -9.81 " in done.out and "[[forces]]" not in done.out


@pytest.mark.parametrize("command", ["compare", "gate", "sweep", "judge"])
def test_every_command_that_loads_the_file_prints_the_note_once(tmp_path, command):
    path = _ball_file(tmp_path, -9.81)
    if command == "gate":
        (tmp_path / "g.toml").write_text(f'[[check]]\nscene = {path!r}\nengine = "pybullet"\ndt = 1e-3\n'
                                         'scene_overrides = { duration = 0.6 }\nlimits = ["n_episodes >= 0"]\n')
        argv = ["gate", str(tmp_path / "g.toml")]
    elif command == "sweep":
        (tmp_path / "s.toml").write_text(f'scene = {path!r}\nengines = ["pybullet"]\n[set]\nduration = 0.6\n'
                                         "[grid]\ndt = [1e-3]\n")
        argv = ["sweep", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out"), "--workers", "1"]
    elif command == "judge":  # the note comes with the file's load, before the trajectory is read
        argv = ["judge", path, str(tmp_path / "missing.csv")]
    else:
        argv = ["compare", path, "--engines", "pybullet", "--dt", "1e-3", "--set", "duration=0.6", "--no-figures"]
    done = cli(argv)
    assert done.code == (2 if command == "judge" else 0), done.err
    assert done.err.splitlines().count(NOTE) == 1, done.err
