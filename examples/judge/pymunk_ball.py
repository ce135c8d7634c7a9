"""Judge pymunk (2-D, Chipmunk) against the reference: a ball dropped on a floor, written as a trajectory file.

    python3 examples/judge/pymunk_ball.py ball.csv                 # bouncing-ball at dt = 1e-4
    chatterbench judge bouncing-ball ball.csv --engine pymunk

pymunk is not one of chatterbench's engines: this script only needs pymunk, numpy and
pandas, and writes the columns ``chatterbench judge`` reads (t, x1, x2, v1, v2,
force_lower; SI units, the scene's conventions): body 1 is the floor (fixed, x1 = 0), body 2
the ball, x2 its lowest point's height, so y = x2 - x1 is the gap to the floor.

pymunk's contact restitution is the product of the two shapes' elasticities (the floor's
is 1, the ball's R), applied at every impact; its contact force is the arbiter's impulse
over the step. Options: ``--scene`` (bouncing-ball, or a TOML of a ball on a fixed floor:
mass1 = "inf", lower wall only, under ``gravity`` [m/s^2] or one constant force on body 2 [N]),
``--dt`` [s].
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pymunk

BUILT_IN = {"name": "bouncing-ball", "mass2": 1.0, "restitution": 0.5, "duration": 2.0, "gap": {"lower": 0.0},
            "initial": {"y": 1.0, "vy": 0.0}, "gravity": -9.81}
RADIUS = 0.05  # [m] the ball's; only its lowest point is judged


def scene_data(source: str) -> dict:
    """The scene's numbers: the built-in ball, or a TOML file of a ball on a fixed floor."""
    if source == "bouncing-ball":
        return BUILT_IN
    data = tomllib.loads(Path(source).read_text())
    forces = data.get("forces", [])
    one_force = len(forces) == 1 and forces[0].get("kind") == "constant" and forces[0].get("on") == "body2"
    if str(data.get("mass1")) != "inf" or "upper" in data.get("gap", {}) or not (one_force or not forces):
        sys.exit(f"{source}: this example simulates a ball on a fixed floor under gravity or one constant force only")
    return data


def acceleration(data: dict) -> float:
    """The ball's acceleration along the slide axis [m/s^2]: the scene's gravity plus its constant force / m2."""
    forces = data.get("forces", [])
    return float(data.get("gravity", 0.0)) + (float(forces[0]["value"]) / float(data["mass2"]) if forces else 0.0)


def simulate(data: dict, dt: float) -> pd.DataFrame:
    """Step pymunk for the scene's duration; one row per step (the trajectory table)."""
    m, floor_y = float(data["mass2"]), float(data["gap"]["lower"])
    space = pymunk.Space()
    space.gravity = (0.0, acceleration(data))  # the scene's x is pymunk's y
    space.iterations = 50
    floor = pymunk.Segment(space.static_body, (-10.0, floor_y), (10.0, floor_y), 0.0)
    floor.elasticity = 1.0
    ball = pymunk.Body(m, pymunk.moment_for_circle(m, 0.0, RADIUS))
    ball.position = (0.0, floor_y + float(data["initial"]["y"]) + RADIUS)
    ball.velocity = (0.0, float(data["initial"].get("vy", 0.0)))
    shape = pymunk.Circle(ball, RADIUS)
    shape.elasticity = float(data["restitution"])  # restitution = product of the two elasticities
    shape.friction = 0.0
    space.add(floor, ball, shape)
    n = int(round(float(data["duration"]) / dt))
    rows = np.zeros((n + 1, 3))
    rows[0] = (float(ball.position.y) - RADIUS, float(ball.velocity.y), 0.0)
    for k in range(1, n + 1):
        space.step(dt)
        impulse = sum(abs(arb.total_impulse.y) for arb in _arbiters(ball))
        rows[k] = (float(ball.position.y) - RADIUS, float(ball.velocity.y), impulse / dt)
    t = np.arange(n + 1) * dt
    zero = np.zeros(n + 1)
    return pd.DataFrame({"t": t, "x1": zero, "x2": rows[:, 0], "v1": zero, "v2": rows[:, 1], "force_lower": rows[:, 2]})


def _arbiters(body: pymunk.Body) -> list:
    found = []
    body.each_arbiter(found.append)
    return found


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", help="the trajectory file to write (.csv or .parquet)")
    p.add_argument("--scene", default="bouncing-ball", help="bouncing-ball, or a TOML of a ball on a fixed floor")
    p.add_argument("--dt", type=float, default=1e-4, help="pymunk's step [s] (default 1e-4)")
    args = p.parse_args(argv)
    table = simulate(scene_data(args.scene), args.dt)
    out = Path(args.out)
    table.to_parquet(out) if out.suffix == ".parquet" else table.to_csv(out, index=False)
    print(f"wrote {len(table)} samples to {out}; now: chatterbench judge {args.scene} {out} --engine pymunk")
    return 0


if __name__ == "__main__":
    sys.exit(main())
