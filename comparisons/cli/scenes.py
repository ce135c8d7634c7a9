"""``chatterbench scenes``: the built-in scenes, one line each.

    $ chatterbench scenes
"""

from __future__ import annotations

import argparse

import pandas as pd

from chatterbench.reference.catalogue import CATALOGUE, describe
from chatterbench.reference.scene import load_scene

from .common import print_table


def cmd_scenes(args: argparse.Namespace) -> int:
    rows = []
    for name in CATALOGUE:
        s = load_scene(name)
        rows.append({"scene": name, "R": s.restitution, "mu": s.mu, "walls": "+".join(s.gap.walls),
                     "duration_s": s.duration, "description": describe(name)})
    print_table(pd.DataFrame(rows))
    return 0


def register(sub, formatter) -> None:
    """Add ``scenes`` to the ``chatterbench`` subparsers."""
    p = sub.add_parser("scenes", help="list the built-in scenes", formatter_class=formatter)
    p.set_defaults(func=cmd_scenes)
