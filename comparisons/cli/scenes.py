"""``chatterbench scenes``: the built-in scenes, one line each; ``--toml NAME`` prints one as a file to start from.

    $ chatterbench scenes
    $ chatterbench scenes --toml feigin-pair > my-scene.toml     # edit, then: chatterbench run my-scene.toml
"""

from __future__ import annotations

import argparse
import sys

from chatterbench.reference.catalogue import CATALOGUE, describe
from chatterbench.reference.errors import check_choice
from chatterbench.reference.scene import load_scene
from .commands import COMMANDS
from .common import UsageError, load_noted, print_table


def cmd_scenes(args: argparse.Namespace) -> int:
    import pandas as pd

    from chatterbench.reference.scene_toml import scene_toml

    if args.toml is not None:
        name = check_choice("--toml", args.toml, tuple(CATALOGUE), error=UsageError)
        sys.stdout.write(scene_toml(load_noted(name), describe(name)))
        return 0
    rows = []
    for name in CATALOGUE:
        s = load_scene(name)
        rows.append({"scene": name, "R": s.restitution, "mu": s.mu, "walls": "+".join(s.gap.walls),
                     "duration_s": s.duration, "description": describe(name)})
    print_table(pd.DataFrame(rows))
    return 0


def register(sub, formatter) -> None:
    """Add ``scenes`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("scenes", help=COMMANDS["scenes"], formatter_class=formatter)
    p.add_argument("--toml", metavar="NAME", default=None,
                   help="print built-in scene NAME as a commented TOML file (every field with its unit) to edit and run")
    p.set_defaults(func=cmd_scenes)
