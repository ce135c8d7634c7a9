"""Ctrl-C ends a command with exit 130 even when Python swallows the ``KeyboardInterrupt``.

Before: a Ctrl-C of ``report --out r`` landing while matplotlib collected garbage was raised
inside a weakref callback, printed as "Exception ignored in ... KeyboardInterrupt", and the
report ran to the end with exit 0 (issue 25, "Ctrl-C ... was ignored"; timing-dependent). Here
the SIGINT is delivered, deterministically, inside such a callback.
"""

from __future__ import annotations

import subprocess
import sys

SWALLOWED = r'''
import os, signal, sys, weakref
sys.argv[0] = "chatterbench"          # as the console script
from chatterbench.comparisons.cli import main as cli_main, scenes

real = scenes.cmd_scenes

class Thing:
    pass

def listing(args):
    thing = Thing()
    weakref.finalize(thing, os.kill, os.getpid(), signal.SIGINT)  # the signal arrives in a GC callback
    del thing
    return real(args)

scenes.cmd_scenes = listing
sys.exit(cli_main.main(["scenes"]))
'''


def test_a_ctrl_c_swallowed_by_a_callback_still_exits_130():
    proc = subprocess.run([sys.executable, "-c", SWALLOWED], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130, (proc.returncode, proc.stderr)
    assert proc.stderr.strip().splitlines() == ["chatterbench: interrupted"], proc.stderr
