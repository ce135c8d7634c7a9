"""``python -m chatterbench.engines.warm [ENGINE ...]``: each named engine's first run made now, its kernels compiled.

    $ python -m chatterbench.engines.warm          # an empty warp cache, this 2-core machine, quiet
    mujoco_warp: kernels compiled in 33.5 s
    newton_xpbd: kernels compiled in 16.7 s
    newton_semi: kernels compiled in 3.0 s

The engines on warp (MuJoCo Warp, Newton) compile their kernels the first time a process runs them on a machine
(into warp's cache; later processes load them in a fraction of a second). This runs each named engine once on 1 ms of
feigin-pair (both walls) at its default settings and says what its first run cost (``warmup_s`` and ``kernels`` of
the run's record, where the engine records them). With no names: every installed engine whose first run on a machine
compiles (its adapter's ``first_run_note``: MuJoCo Warp, Newton). The
test suite starts it from its controller process before the workers (``tests/conftest.py``), which wait on the
cache's lock (``warp_cache.compile_lock``) instead of compiling the same kernels in each worker.
"""

from __future__ import annotations

import sys


def main(argv: list[str]) -> int:
    from chatterbench.reference.scene import load_scene

    from .registry import ENGINE_NAMES, adapter, make_settings, run_engine, unavailable_reason

    names = list(argv) or [n for n in ENGINE_NAMES if not unavailable_reason(n) and adapter(n).first_run_note]
    unknown = [n for n in names if n not in ENGINE_NAMES]
    if unknown:
        print(f"engine {unknown[0]!r}: one of {', '.join(ENGINE_NAMES)}", file=sys.stderr)
        return 2
    scene = load_scene("feigin-pair", ["duration=0.001"])
    for name in names:
        record = run_engine(name, scene, make_settings(name)).settings
        kernels, seconds = record.get("kernels", "loaded"), record.get("warmup_s")
        print(f"{name}: kernels {kernels}" + (f" in {seconds:.1f} s" if isinstance(seconds, float) else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
