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


IMPORT_GRACE_S = 2.0  # [s] a Ctrl-C during an import waits for its end at most this long


def _importing(frame) -> bool:
    """Whether ``frame`` runs inside an import (a module's code, or what an extension module's init calls)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib._bootstrap"):
            return True
        frame = frame.f_back
    return False


class _Interrupt:
    """SIGINT during the work: remember it, then raise ``KeyboardInterrupt``.

    Python drops an exception raised inside a weakref callback or ``__del__`` ("Exception ignored
    in ..."), so a Ctrl-C that lands while matplotlib collects garbage would be lost and the command
    would run to the end with exit 0; ``main`` reads ``seen`` after the work and exits 130 all the same.

    A Ctrl-C during an import waits for the import's end (sent again every 20 ms, ``_again``, for at
    most ``IMPORT_GRACE_S``): raised inside an extension module's init, the ``KeyboardInterrupt`` came
    out as that module's ``ImportError`` and a traceback (numba's ``_dispatcher`` importing ``_devicearray``).
    """

    seen = False
    deferred_at: float | None = None  # time.monotonic() of the first Ctrl-C held for an import

    def __call__(self, signum, frame):  # noqa: ARG002 - a signal handler's signature
        type(self).seen = True
        if _importing(frame):
            import time

            now = time.monotonic()
            since = type(self).deferred_at = type(self).deferred_at or now
            if now - since < IMPORT_GRACE_S:
                _again()
                return
        type(self).deferred_at = None
        raise KeyboardInterrupt


_resend: list = []  # the timer of a SIGINT to be sent again, while one is armed: never two


def _again() -> None:
    """Send this process SIGINT again in 20 ms (a daemon timer thread): a Ctrl-C held, or swallowed, is raised anew.
    One at a time: further Ctrl-Cs meanwhile add none (each had raised its own interrupt 10 ms after the first one,
    in the middle of the cleanup that one began)."""
    import threading

    if _resend and _resend[0].is_alive():
        return

    def send() -> None:
        _resend.clear()
        os.kill(os.getpid(), signal.SIGINT)

    again = threading.Timer(0.02, send)
    again.daemon = True
    _resend[:] = [again]
    again.start()


interrupt = _Interrupt()


def answered() -> None:
    """The Ctrl-C is being answered (``main``: "interrupted", then exit 130): a resend still armed (``_again``) is
    cancelled and, as the command, a later Ctrl-C is ignored; one raised inside that answer had killed the process
    with SIGINT (-2) and a traceback after the line."""
    for timer in _resend:
        timer.cancel()
    _resend.clear()
    if _COMMAND:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _unraisable(hook_args, _default=sys.unraisablehook):
    """A Ctrl-C that Python swallowed (raised in a garbage-collection callback, a ``__del__``, or a fork hook such as
    logging's ``_releaseLock`` while a pool forks its workers) is sent again, to be raised where it can end the work,
    and said once, by ``main`` ("interrupted"); every other unraisable as Python does. Swallowed in a fork hook, it
    had left a sweep running until its workers' next run finished (9 s under load, seen)."""
    if _Interrupt.seen and isinstance(hook_args.exc_value, KeyboardInterrupt):
        _again()
    else:
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
