"""One process at a time compiles into warp's kernel cache: the others wait, then load what it compiled.

    >>> import tempfile
    >>> from chatterbench.engines.warp_cache import compile_lock
    >>> with compile_lock(tempfile.mkdtemp(), "newton"):
    ...     pass   # load (compile, on a cold cache) Newton's warp modules here

Warp (MuJoCo Warp, Newton) compiles a module the first time a process launches one of its kernels and keeps the
binary in its kernel cache (``wp.config.kernel_cache_dir``, ~/.cache/warp); a later process loads it in a fraction of
a second. Two processes that start on a cold cache (two test workers, two sweep or tune workers) would each compile
the same modules, each taking the whole compile's CPU. ``compile_lock(cache, family)`` holds an exclusive ``flock`` on
``chatterbench-FAMILY.lock`` in the cache folder while a process loads its kernels, so the second waits and then reads
the cache; the families (``"mujoco_warp"``, ``"newton"``: modules of their own) compile side by side.
A cache folder that cannot hold the lock file (read-only, or not a folder; "" for none) gives no lock: each process
loads on its own, as warp does without it.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from typing import Iterator


def lock_name(family: str) -> str:
    """The lock file's name in the cache folder for one family of warp modules."""
    return f"chatterbench-{family}.lock"


@contextlib.contextmanager
def compile_lock(cache: str, family: str) -> Iterator[None]:
    """Held while this process loads ``family``'s warp kernels into (or from) the cache folder ``cache`` (module
    docstring)."""
    if not cache:
        yield
        return
    try:
        os.makedirs(cache, exist_ok=True)
        handle = open(os.path.join(cache, lock_name(family)), "a+")
    except OSError:  # a cache that cannot be shared: each process on its own
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
