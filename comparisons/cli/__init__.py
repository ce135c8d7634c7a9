"""The command line: ``main`` parses and dispatches, one module per subcommand, ``common`` below them all.

    $ chatterbench compare feigin-pair --engines mujoco,pybullet --out out/fp
"""

import os
import signal
import sys

# Run as the command (the console script, or ``python -m`` while it finds this package), a Ctrl-C while the
# command imports its modules or while the interpreter shuts down exits 130 with one line, as one during the
# work does (``main``); imported as a library, the caller's Ctrl-C handling is left alone.
_COMMAND = os.path.basename(sys.argv[0]) in ("chatterbench", "-m")


def _interrupted(signum, frame):  # noqa: ARG001 - a signal handler's signature
    os.write(2, b"chatterbench: interrupted\n")
    os._exit(130)


class _Interrupt:
    """SIGINT during the work: remember it, then raise ``KeyboardInterrupt``.

    Python drops an exception raised inside a weakref callback or ``__del__`` ("Exception ignored
    in ..."), so a Ctrl-C that lands while matplotlib collects garbage would be lost and the command
    would run to the end with exit 0; ``main`` reads ``seen`` after the work and exits 130 all the same.
    """

    seen = False

    def __call__(self, signum, frame):  # noqa: ARG002 - a signal handler's signature
        type(self).seen = True
        raise KeyboardInterrupt


interrupt = _Interrupt()


def _unraisable(hook_args, _default=sys.unraisablehook):
    """The swallowed Ctrl-C is said once, by ``main`` ("interrupted"); every other unraisable as Python does."""
    if not (_Interrupt.seen and isinstance(hook_args.exc_value, KeyboardInterrupt)):
        _default(hook_args)


if _COMMAND:
    sys.unraisablehook = _unraisable


class Terminated(BaseException):
    """SIGTERM during the work (a cancelled CI job, ``kill``): raised like Ctrl-C's ``KeyboardInterrupt``, so that what
    the command was writing is removed or finished (``atomic.staged``); ``main`` exits 143."""


def _terminate(signum, frame):  # noqa: ARG001 - a signal handler's signature
    raise Terminated


def _default_term_in_child() -> None:
    """A forked child (a pool's worker, an isolated engine run) dies of SIGTERM, as its parent's pool expects."""
    if signal.getsignal(signal.SIGTERM) is _terminate:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def quiet_interrupts(quiet: bool) -> None:
    """As the command: Ctrl-C exits at once (``quiet``), or raises ``KeyboardInterrupt`` for ``main`` to catch; SIGTERM
    kills at once (``quiet``) or raises ``Terminated``."""
    if _COMMAND and signal.getsignal(signal.SIGINT) in (_interrupted, interrupt, signal.default_int_handler):
        signal.signal(signal.SIGINT, _interrupted if quiet else interrupt)
    if _COMMAND and signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, _terminate):
        signal.signal(signal.SIGTERM, signal.SIG_DFL if quiet else _terminate)


os.register_at_fork(after_in_child=_default_term_in_child)


quiet_interrupts(True)
