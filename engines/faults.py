"""Test-only fault injection: make an engine run crash, hang or raise on purpose.

    >>> settings = make_settings("mujoco", overrides=["mujoco.fault=segfault"])

Set through the engine settings' ``fault`` field (``""`` by default, which does nothing).
The tests use it to prove that a sweep survives a point that kills its process
(``segfault``), never returns (``hang``) or raises (``raise``), and that the point is
classified while every other point is kept.
"""

from __future__ import annotations

import ctypes
import time

FAULTS = ("", "segfault", "hang", "raise")


class InjectedFault(RuntimeError):
    """The exception raised by ``fault = "raise"``."""


def inject(fault: str) -> None:
    """Do what ``fault`` says: nothing, a segmentation fault, an endless sleep, or an exception."""
    if fault == "segfault":
        ctypes.string_at(0)  # reads address 0: SIGSEGV in this process
    elif fault == "hang":
        while True:
            time.sleep(3600)
    elif fault == "raise":
        raise InjectedFault("fault injected by the settings (fault = 'raise')")
