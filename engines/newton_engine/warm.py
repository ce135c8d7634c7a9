"""``python -m chatterbench.engines.newton_engine.warm [SOLVER ...]``: load Newton's kernels once, before workers do.

Compiles (on a cold warp cache) or loads the kernels of the named solvers (default: xpbd and semi) on warp's CPU
device and prints one line per solver (``world.KernelLoad.describe``). Another process that loads them meanwhile
waits on the cache's lock (``warp_cache.compile_lock``), then loads them from the cache.
"""

from __future__ import annotations

import sys

from .world import warm


def main(argv: list[str]) -> int:
    solvers = tuple(argv) or ("xpbd", "semi")
    unknown = [s for s in solvers if s not in ("xpbd", "semi")]
    if unknown:
        print(f"solver {unknown[0]!r}: one of xpbd, semi", file=sys.stderr)
        return 2
    for load in warm(solvers):
        print(load.describe())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
