"""PyBullet, imported once and quietly: ``p`` for every module of the adapter.

    >>> from chatterbench.engines.pybullet_engine.bullet import p
    >>> p.DIRECT
    2
"""

from __future__ import annotations

import os
import sys


def _import_quietly():
    """Import pybullet without the ``pybullet build time: ...`` line its C code writes to
    stderr at import (it would be a second line under every one-line CLI message)."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no usable fd 2: nothing to protect
        import pybullet

        return pybullet
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
        import pybullet
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return pybullet


p = _import_quietly()

