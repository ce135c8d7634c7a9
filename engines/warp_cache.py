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
from dataclasses import dataclass
from typing import ClassVar, Iterator


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


@dataclass(frozen=True)
class KernelLoad:
    """The loading of an engine's kernels on a device: how long [s], and whether warp compiled them (not cached).
    An engine's subclass names itself (``engine``)."""

    device: str
    seconds: float
    compiled: bool
    cache: str  # warp's kernel cache directory
    engine: ClassVar[str] = "warp"

    def describe(self) -> str:
        """One line: ``MuJoCo Warp compiled its kernels for device cuda in 84.2 s (cache: ...)``."""
        what = "compiled its kernels" if self.compiled else "loaded its kernels from warp's cache"
        return f"{self.engine} {what} for device {self.device} in {self.seconds:.1f} s (cache: {self.cache})"


def cache_entries(path: str) -> int:
    """How many entries warp's cache folder ``path`` holds (0 when it cannot be read): more after a load, a compile."""
    try:
        return len(os.listdir(path))
    except OSError:
        return 0
