"""What every subcommand shares: the refusal format, tables, and the options named the same everywhere.

    >>> from chatterbench.comparisons.cli.common import (
    ...     Parser, add_engines, engine_list, HelpFormatter, add_dt, add_set, add_tolerance,
    ...     add_out, parse_tolerances)
    >>> parser = Parser(prog="chatterbench demo", formatter_class=HelpFormatter)
    >>> add_engines(parser); add_dt(parser); add_set(parser); add_tolerance(parser); add_out(parser)
    >>> args = parser.parse_args(["--engines", "pybullet", "--tolerance", "stick=0.1"])
    >>> engine_list(args.engines), parse_tolerances(args.tolerance).stick
    (('pybullet',), 0.1)

Option names are the same for the same thing in every subcommand: ``--engines``, ``--dt``,
``--set``, ``--tolerance``, ``--out``. Every option's help says its default
(``HelpFormatter``). A command-line mistake is a ``UsageError`` (exit 2), printed as one line
``chatterbench: error: ...``; library refusals (``InputError``) print the same way.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import warnings
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Sequence

from chatterbench.comparisons.pipeline.budget import GIB, MAX_MEMORY, MAX_STEPS, Budget
from chatterbench.comparisons.pipeline.inert_text import log_text
from chatterbench.comparisons.pipeline.tolerances import Tolerances, tolerances_from_items
from chatterbench.engines.isolate import set_run_limit
from chatterbench.engines.registry import DEFAULT_ENGINES, ENGINE_NAMES, check_engine, settings_for
from chatterbench.reference.errors import InputError, did_you_mean
from chatterbench.reference.scene import Scene, load_scene, split_assignment

if TYPE_CHECKING:  # pandas and the sweep's modules load with the work, not with --help (issue 33)
    import pandas as pd


class UsageError(InputError):
    """A command-line mistake (exit code 2): an option that does not fit the others."""


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Every option's help ends with its default (``(default: ...)``), as argparse's own does."""


class Parser(argparse.ArgumentParser):
    """argparse with the CLI's refusal format: one stderr line ``chatterbench: error: ...``, exit 2.

    (argparse's own prints the usage first; the usage is one ``--help`` away.) A misspelt
    subcommand or option gets the nearest name (``repot``: did you mean 'report'?; ``--dtt``:
    did you mean '--dt'?), and an unknown option is refused by the subcommand that read it, so
    the message points at that subcommand's ``--help``.
    """

    _innermost: "Parser | None" = None  # the last parser that read words: a subcommand's, after the top level's

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)

    def parse_known_args(self, args=None, namespace=None):
        Parser._innermost = self
        return super().parse_known_args(args, namespace)

    def parse_args(self, args=None, namespace=None):
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            inner = Parser._innermost or self
            options = [o for o in inner._option_string_actions if o.startswith("--")]
            words = [w.split("=", 1)[0] for w in extras if w.startswith("--")]
            hints = [f"{w}: {hint[2:-1]}" for w in words if (hint := did_you_mean(w, options))]
            inner.error(f"unrecognized arguments: {' '.join(extras)}" + (f" ({'; '.join(hints)})" if hints else ""))
        return parsed

    def _check_value(self, action, value):  # a choice misspelt (a subcommand: ``repot``) gets the nearest one
        if action.choices is not None and value not in action.choices:
            choices = ", ".join(map(repr, action.choices))
            raise argparse.ArgumentError(action, f"invalid choice: {value!r} (choose from {choices})"
                                                 + did_you_mean(str(value), [str(c) for c in action.choices]))

    def error(self, message: str):  # type: ignore[override]
        sub = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        print(f"chatterbench: error: {sub + ': ' if sub else ''}{one_line(message)} (see {self.prog} --help)",
              file=sys.stderr)
        sys.exit(2)


SHOWN = 120  # characters of one word (a key, a value, a path) a message shows whole; a longer one is shortened
_LONG_WORD = re.compile(r"[^\s:;,'\"]{%d,}" % (SHOWN + 1))  # a word, less the punctuation around it


class _StoreOnce(argparse._StoreAction):
    """An option given once: given again with another value it is refused (argparse would keep the last one)."""

    def __call__(self, parser, namespace, values, option_string=None):
        given = namespace.__dict__.setdefault("_given_once", {})
        if self.dest in given and given[self.dest] != values:
            shown = [repr(v) if isinstance(v, str) else f"{v}" for v in (given[self.dest], values)]
            raise argparse.ArgumentError(self, f"given twice with different values ({shown[0]} and {shown[1]}); give it once")
        given[self.dest] = values
        setattr(namespace, self.dest, values)


def check_settings(args: argparse.Namespace) -> None:
    """Refuse settings that would be ignored or overwritten without a word (``UsageError``).

    The same ``--set`` or ``--tolerance`` key twice with two values; an engine setting
    (``mujoco.w0_dt``) for an engine the command does not run; ``--dt`` together with
    ``--set ENGINE.dt``. Options given once are argparse's (``_StoreOnce``).
    """
    args.__dict__.pop("_given_once", None)
    if getattr(args, "timeout", None) is not None:  # a plugin's load and runs, and an engine's own child, are held to it
        set_run_limit(args.timeout)
    for option in ("set", "tolerance"):
        seen: dict[str, str] = {}
        for item in getattr(args, option, None) or []:
            if "=" not in item:
                continue  # refused by the command, with its own message
            key, value = (part.strip() for part in item.split("=", 1))
            if key in seen and seen[key] != value:
                raise UsageError(f"--{option} {key}={seen[key]} and --{option} {key}={value}: {key} given twice "
                                 "with different values; give it once")
            seen.setdefault(key, value)
    engine_items = [(item, item.split("=", 1)[0].strip()) for item in getattr(args, "set", None) or [] if "=" in item]
    engine_items = [(item, key) for item, key in engine_items if key.split(".")[0] in ENGINE_NAMES]
    given = getattr(args, "engines", None) or getattr(args, "engine", None)
    names = [n.strip() for n in (",".join(given) if isinstance(given, list) else given or "").split(",") if n.strip()]
    if names and names != ["reference"]:
        for item, key in engine_items:
            owner = key.split(".")[0]
            if owner not in names:
                raise UsageError(f"--set {item}: {owner} is not run here (--engines {','.join(names)}); add it to "
                                 "--engines or leave the setting out")
    if getattr(args, "dt", None) is not None:
        for item, key in engine_items:
            if key.split(".", 1)[1:] == ["dt"]:
                raise UsageError(f"--dt {args.dt:g} and --set {item}: two ways of giving the timestep; give one")


class _Held(list):
    keep = True  # set False to drop them


@contextmanager
def held_warnings():
    """Hold the warnings raised inside (numpy's ``overflow encountered``, ...) and issue them at the end, unless
    ``.keep`` was set False: a refused command's one error line is then all it prints. A plugin's fault
    (``engines.registry.PluginFault``) is a ``chatterbench: note:`` line."""
    held = _Held()
    with warnings.catch_warnings(record=True) as caught:
        yield held
    if held.keep:
        from chatterbench.engines.registry import PluginFault

        noted = set()
        for w in caught:
            if issubclass(w.category, PluginFault):  # a plugin's own code failed: one note, the work kept
                if str(w.message) not in noted:
                    print(f"chatterbench: note: {one_line(str(w.message))}", file=sys.stderr)
                noted.add(str(w.message))
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)


def one_line(message: str) -> str:
    """A message on one line, safe for a terminal: control characters (a newline, an escape sequence typed into a
    key) shown escaped (``\\n``, ``\\x1b``); a word longer than ``SHOWN`` characters shortened with an ellipsis."""
    return _LONG_WORD.sub(lambda m: f"{m[0][:60]}...{m[0][-20:]} ({len(m[0])} characters)", log_text(message))


def scene_notes(scene: Scene, file=None) -> None:
    """Print how the scene's file was read (``Scene.notes``: a weight given as a force read as ``gravity``), one
    stderr line each, ``chatterbench: note: SCENE: ...``; the name escaped for a terminal (``one_line``)."""
    for note in scene.notes:
        print(f"chatterbench: note: {one_line(repr(scene.name))}: {one_line(note)}", file=file or sys.stderr)


def load_noted(source: Any, overrides: Sequence[str] = ()) -> Scene:
    """``load_scene(source, overrides)`` with its notes printed (``scene_notes``): how every subcommand loads a scene."""
    scene = load_scene(source, overrides)
    scene_notes(scene)
    return scene


def file_notes(sources: Sequence[Any], overrides: Sequence[str] = ()) -> None:
    """The notes (``scene_notes``) of each scene file among ``sources``, once each, for a command whose library call
    loads them (``report``, ``sweep``, ``gate``); one that does not load is left to that call's refusal."""
    from chatterbench.reference.catalogue import CATALOGUE

    seen: set[str] = set()
    for source in sources:
        if isinstance(source, Scene):
            scene = source
        elif str(source) in CATALOGUE or str(source) in seen:
            continue
        else:
            seen.add(str(source))
            try:
                scene = load_scene(source, overrides)
            except InputError:
                continue
        if scene.notes and scene.name not in seen:
            seen.add(scene.name)
            scene_notes(scene)


def print_table(frame: pd.DataFrame, title: str | None = None, file=None) -> None:
    """Print a DataFrame as a compact fixed-width table."""
    file = file or sys.stdout
    if title:
        print(log_text(title), file=file)
    if frame.empty:
        print("  (none)", file=file)
        return
    frame = frame.map(lambda v: log_text(v) if isinstance(v, str) else v)  # a name from a file starts no line of its own
    print(frame.to_string(index=False, float_format=lambda v: f"{v:.9g}"), file=file)


def split_overrides(items: list[str] | None) -> tuple[list[str], list[str]]:
    """Split ``--set`` items into (scene overrides, engine overrides ``mujoco.*``/``pybullet.*``)."""
    scene, engine = [], []
    for item in items or []:
        key, _ = split_assignment(item)
        (engine if key.split(".")[0] in ENGINE_NAMES else scene).append(item)
    return scene, engine


def settings_of(engines: Sequence[str], dt: float | None, items: Sequence[str]) -> dict[str, Any]:
    """Each engine's settings object from ``--dt`` [s] and the ``--set ENGINE.KEY=VALUE`` items (``split_overrides``'
    engine part): the text is parsed here, once, and the objects go down to ``compare`` and the engines."""
    return settings_for(engines, dt, dict(split_assignment(item) for item in items))


def engine_list(text: str) -> tuple[str, ...]:
    """``"mujoco,pybullet"`` -> the engine names, each checked (did-you-mean for a typo)."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise UsageError(f"--engines: give at least one of {', '.join(ENGINE_NAMES)} (comma-separated)")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise UsageError(f"--engines {text}: {', '.join(repeated)} given more than once (each engine runs once)")
    return tuple(check_engine(n) for n in names)


def engines_hint(engines: Sequence[str] = DEFAULT_ENGINES, key: str = "") -> str:
    """What to add where an option needs an engine run: ``add --engines mujoco or --engines pybullet`` (``engines``,
    by default the engines run when none is named), or the engine that an engine setting ``key``
    (``mujoco.w0_dt=0.05``) names."""
    named = key.split(".", 1)[0] if "." in key else ""
    return "add " + " or ".join(f"--engines {e}" for e in ([named] if named in ENGINE_NAMES else engines))


def parse_tolerances(items: list[str] | None) -> Tolerances:
    """``--tolerance`` items as Tolerances (defaults where not given); a bad key or value is refused by name."""
    return tolerances_from_items(items or [])


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number > 0")
    return value


def integer_type(lo: int, hi: int | None = None, note: str = ""):
    """An argparse type: an integer in [lo, hi] (no upper bound when ``hi`` is None); ``note`` ends the refusal."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < lo or (hi is not None and value > hi):
            bound = f"in [{lo}, {hi}]" if hi is not None else ("> 0" if lo == 1 else f">= {lo}")
            raise argparse.ArgumentTypeError(f"{text!r}: must be an integer {bound}{note}")
        return value

    parse.__name__ = "integer"
    return parse


positive_int = integer_type(1)  # argparse type: an integer > 0


# -- the options every judging subcommand names the same way ---------------------------------

def add_scene(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="built-in scene name (chatterbench scenes) or path to a scene TOML file")


def add_engines(p: argparse.ArgumentParser, default: str = ",".join(DEFAULT_ENGINES), what: str = "engines to run") -> None:
    p.add_argument("--engines", default=default, metavar="E[,E...]", help=f"comma-separated {what}, of: {', '.join(ENGINE_NAMES)}")


def add_dt(p: argparse.ArgumentParser) -> None:
    p.add_argument("--dt", type=positive_float, default=None,
                   help="engine timestep [s]; None: each engine's own default (1e-4)")


def add_set(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", action="append", metavar="KEY=VALUE", default=None,
                   help="override a scene field (restitution=0.8, initial.vy=0.04) or an engine setting "
                        "(mujoco.w0_dt=0.05); repeatable")


def add_tolerance(p: argparse.ArgumentParser) -> None:
    defaults = ", ".join(f"{k}={v:g}" for k, v in Tolerances().as_dict().items())
    p.add_argument("--tolerance", action="append", metavar="KEY=VALUE", default=None,
                   help="a verdict tolerance, repeatable; stick, first_impact: fractions of each episode's chatter "
                        "duration, exit: of its sliding duration, restitution: relative, penetration: of the "
                        f"scene's length scale; None: the defaults, {defaults}")


def gibibytes(text: str) -> float:
    """argparse type: a memory size in GiB (a finite number > 0), returned in bytes."""
    return positive_float(text) * GIB


def add_budget(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-steps", type=positive_float, default=MAX_STEPS, metavar="N",
                   help="refuse, before anything runs, an engine run estimated to take more steps (duration / dt)")
    p.add_argument("--max-memory", type=gibibytes, default=f"{MAX_MEMORY / GIB:g}", metavar="GIB",
                   help="refuse, before anything runs, work estimated to need more memory per process [GiB]")


def budget_of(args: argparse.Namespace) -> Budget:
    """The ``Budget`` of ``--max-steps`` and ``--max-memory``."""
    return Budget(max_steps=args.max_steps, max_memory=args.max_memory)


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def machine_memory() -> int:
    """This machine's memory [B]."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def worker_limit(max_memory: float = MAX_MEMORY) -> int:
    """Worker processes this machine holds: one per core, and no more than its memory / ``max_memory`` [B]."""
    memory = machine_memory()
    return max(1, min(_cores(), int(memory // max_memory)))


def local_workers(requested: int | None, max_memory: float = MAX_MEMORY) -> int:
    """``--workers`` of a local pool: ``requested`` (None: ``worker_limit``) if this machine holds that many, else a UsageError.

    Past one worker per core, or past the memory of ``max_memory`` [B] a worker, workers only
    fight for cores and memory.
    """
    limit = worker_limit(max_memory)
    if requested is not None and requested > limit:
        memory = machine_memory() / GIB
        raise UsageError(f"--workers {requested}: must be in [1, {limit}] on this machine ({_cores()} cores, "
                         f"{memory:.0f} GiB of memory at {max_memory / GIB:g} GiB per worker)")
    return requested or limit


ENGINE_TIMEOUT = 600.0  # [s] the command line's limit on one engine run
# [s] one day, the most --timeout takes: the sweep spec's ``MAX_TIMEOUT``, written here so that parsing --timeout
# loads no sweep module (0.5 s of pandas); tests/comparisons/cli/test_help.py checks that they agree
MAX_TIMEOUT = 86400.0


def timeout_seconds(text: str) -> float:
    """argparse type: a wall-clock limit in seconds, 0 < t <= one day."""
    value = positive_float(text)
    if value > MAX_TIMEOUT:
        raise argparse.ArgumentTypeError(f"{text!r}: must be at most {MAX_TIMEOUT:g} s (one day)")
    return value


def add_timeout(p: argparse.ArgumentParser) -> None:
    p.add_argument("--timeout", type=timeout_seconds, default=ENGINE_TIMEOUT, metavar="SECONDS",
                   help="wall-clock limit of each engine run [s], in (0, 86400]; every engine runs isolated in a "
                        "child process, so a crash or hang is that engine's crashed/timeout verdict and the other "
                        "results are kept")


def add_judging(p: argparse.ArgumentParser) -> None:
    """The options of every command that runs engines and judges them (compare, report)."""
    add_engines(p)
    add_dt(p)
    add_set(p)
    add_tolerance(p)
    add_timeout(p)
    add_budget(p)


def add_out(p: argparse.ArgumentParser, default: str | None = None, what: str = "write the files under DIR") -> None:
    p.add_argument("--out", metavar="DIR", default=default, help=what)


def dask_client(address: str | None):
    """``--dask ADDRESS``'s client (None without one); an empty address or an unreachable scheduler refused by name."""
    if address is None:
        return None
    if not address.strip():
        raise UsageError("--dask '': no scheduler address; give one (tcp://host:8786), or leave --dask out to run locally")
    try:
        from distributed import Client

        return Client(address, timeout=10)
    except (OSError, TimeoutError, ValueError) as exc:
        raise UsageError(f"--dask {address}: cannot reach the Dask scheduler ({exc})") from None
