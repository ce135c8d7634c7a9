"""The errors a user's input gets, and the checks that raise them: one root, one number check.

    >>> from chatterbench.reference.errors import InputError, check_number
    >>> check_number("mass2", 2, lo=0.0, lo_open=True)
    2.0
    >>> check_number("mass2", 0.0, lo=0.0, lo_open=True)
    Traceback (most recent call last):
    chatterbench.reference.errors.InputError: mass2 = 0.0: must be > 0

``InputError`` (a ``ValueError``) is the root of every refusal of user input: a scene
(``SceneError``), an engine setting (``engines.settings.SettingsError``), a tolerance, a
sweep spec, a gate file, a chart option. Each message names the field, the value and what
is allowed; the command line turns any of them into one line and exit code 2. The checks
take the class to raise (``error=``), so each layer raises its own. A file reader is a table of
its keys, each with its check made of these (``check_fields``: the sweep spec's ``FIELDS``,
the gate file's ``CHECK_FIELDS``), never a check written again.
"""

from __future__ import annotations

import difflib
import math
from typing import Any, Callable, Mapping, Sequence


class InputError(ValueError):
    """A user's input is not allowed; the message names the field, the value and what is allowed."""


def did_you_mean(name: str, allowed: Sequence[str]) -> str:
    """Return ``" (did you mean 'x'?)"`` for the nearest allowed name, or ``""``."""
    close = difflib.get_close_matches(str(name), [str(a) for a in allowed], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def shown(value: Any, limit: int = 40) -> str:
    """``repr(value)`` for a message, shortened in the middle past ``limit`` characters.

    >>> from chatterbench.reference.errors import shown
    >>> shown(10**60)
    '1000000000000...00000000 (61 characters)'
    """
    text = repr(value)
    return text if len(text) <= limit else f"{text[:13]}...{text[-8:]} ({len(text)} characters)"


def is_number(value: Any) -> bool:
    """A real number that is not a bool (TOML and JSON give ``True`` where a number was meant)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def describe_range(lo: float | None, hi: float | None, lo_open: bool = False, hi_open: bool = False) -> str:
    """``"> 0"``, ``"in [0, 1)"``: the allowed range as a message says it."""
    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {lo:g}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {hi:g}"
    return "a finite number"


def check_number(where: str, value: Any, lo: float | None = None, hi: float | None = None, lo_open: bool = False,
                 hi_open: bool = False, unit: str = "", error: type[InputError] = InputError) -> float:
    """``value`` as a float if it is a finite real number in the range, else ``error`` naming ``where``.

    ``unit`` (``" [s]"``) is appended to the allowed range in the message (and to "must be a number").
    """
    if not is_number(value):
        raise error(f"{where} = {shown(value)}: must be a number{unit}")
    try:
        v = float(value)
    except OverflowError:
        raise error(f"{where} = {shown(value)}: too large; must be {describe_range(lo, hi, lo_open, hi_open)}{unit}") from None
    if not math.isfinite(v):
        bounds = "" if lo is None and hi is None else " " + describe_range(lo, hi, lo_open, hi_open)
        raise error(f"{where} = {shown(value)}: must be a finite number{bounds}{unit}")
    low = lo is not None and (v <= lo if lo_open else v < lo)
    high = hi is not None and (v >= hi if hi_open else v > hi)
    if low or high:
        raise error(f"{where} = {shown(value)}: must be {describe_range(lo, hi, lo_open, hi_open)}{unit}")
    return v


def check_integer(where: str, value: Any, lo: int | None = None, hi: int | None = None,
                  error: type[InputError] = InputError) -> int:
    """``value`` if it is an integer (not a bool) in [lo, hi], else ``error`` naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int) or (lo is not None and value < lo) or (hi is not None and value > hi):
        allowed = "an integer" + (f" {describe_range(lo, hi)}" if lo is not None or hi is not None else "")
        raise error(f"{where} = {shown(value)}: must be {allowed}")
    return value


def check_bool(where: str, value: Any, error: type[InputError] = InputError) -> bool:
    """``value`` if it is ``True`` or ``False``, else ``error`` naming ``where``."""
    if not isinstance(value, bool):
        raise error(f"{where} = {shown(value)}: must be true or false")
    return value


def check_choice(where: str, value: Any, allowed: Sequence[str], error: type[InputError] = InputError) -> str:
    """``value`` if it is one of ``allowed``, else ``error`` with the list and the nearest name."""
    if value not in allowed:
        raise error(f"{where} = {shown(value)}: must be one of {', '.join(map(str, allowed))}" + did_you_mean(str(value), allowed))
    return value


def check_text(where: str, value: Any, error: type[InputError] = InputError) -> str:
    """``value`` if it is a string, else ``error`` naming ``where``."""
    if not isinstance(value, str):
        raise error(f"{where} = {shown(value)}: must be a string")
    return value


def check_table(where: str, value: Any, error: type[InputError] = InputError) -> Mapping[str, Any]:
    """``value`` if it is a table (a mapping of keys to values), else ``error`` naming ``where``."""
    if not isinstance(value, Mapping):
        raise error(f"{where} = {shown(value)}: must be a table, e.g. {where} = {{ key = value }}")
    return value


def unknown_keys(data: Mapping[str, Any], allowed: Sequence[str], what: str = "key") -> list[str]:
    """One message per key of ``data`` not in ``allowed``: ``unknown key 'gird' (did you mean 'grid'?); allowed: ...``."""
    return [f"unknown {what} {shown(k)}{did_you_mean(str(k), allowed)}; allowed: {', '.join(allowed)}"
            for k in data if k not in allowed]


def check_fields(data: Mapping[str, Any], fields: Mapping[str, Callable[[str, Any], Any]], prefix: str = "",
                 problems: list[str] | None = None, error: type[InputError] = InputError) -> dict[str, Any]:
    """An input table read through a table of checks: each key's value passed to its check.

    ``fields`` maps each allowed key to ``check(where, value) -> value`` (a ``check_*`` of this
    module, or one made of them), which raises an ``InputError`` naming ``where`` (``prefix`` +
    the key). Returns the checked value of each key present in ``data``; unknown keys are refused
    (``unknown_keys``, as ``error``). With ``problems`` (a list), every refusal is appended to it,
    one line each, and a key that fails is left out; without, the first refusal is raised.

    >>> from chatterbench.reference.errors import check_fields, check_number, check_text
    >>> fields = {"name": check_text, "dt": lambda where, v: check_number(where, v, lo=0.0, lo_open=True, unit=" [s]")}
    >>> check_fields({"name": "ball", "dt": 1e-3}, fields)
    {'name': 'ball', 'dt': 0.001}
    >>> problems = []
    >>> check_fields({"dt": 0, "dtt": 1}, fields, "check.", problems), problems
    ({}, ["check: unknown key 'dtt' (did you mean 'dt'?); allowed: name, dt", 'check.dt = 0: must be > 0 [s]'])
    """
    refused = [f"{prefix[:-1]}: {m}" if prefix else m for m in unknown_keys(data, list(fields))]
    if refused and problems is None:
        raise error(refused[0])
    out: dict[str, Any] = {}
    for key, check in fields.items():
        if key not in data:
            continue
        try:
            out[key] = check(prefix + key, data[key])
        except InputError as exc:
            if problems is None:
                raise
            refused.extend(str(exc).splitlines())
    if problems is not None:
        problems.extend(refused)
    return out


# c [m/s]: Newton's mechanics and his impact law stop describing anything near it; an input speed at or past it is
# refused, and a run whose speeds pass it is refused by the judge's reference (``push.fastest_push`` names the likely
# cause). Below it the square of a speed never overflows (v^2 < 9e16).
SPEED_OF_LIGHT = 299_792_458.0


def check_speed(where: str, value: float, error: type[InputError] = InputError) -> float:
    """``value`` [m/s], refused (``error`` naming ``where``) unless slower than light."""
    if not abs(value) < SPEED_OF_LIGHT:
        raise error(f"{where} = {value!r}: must be in (-{SPEED_OF_LIGHT:.0f}, {SPEED_OF_LIGHT:.0f}) [m/s] "
                    "(slower than light: Newton's impact law has no meaning past it)")
    return value
