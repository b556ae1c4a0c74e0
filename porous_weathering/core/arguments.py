"""The checks of the arguments of the public functions, written once: a number, a whole number,
a name among choices. Each returns the value as the function uses it or raises ValueError, one
line naming the argument, before any work: a string, an array or a list where a number or a
name is expected is refused, not taken apart later into a TypeError."""

import numbers
from collections.abc import Iterable
from typing import Any


def real_number(name: str, value: Any) -> float:
    """``value`` as a float: a Python or numpy real number, not a bool, a string, an array or a
    list. NaN and infinities pass: whether they are in range is the caller's check."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    raise ValueError(f"{name} must be a number, not {value!r}")


def whole_number(name: str, value: Any) -> int:
    """``value`` as an int: an int or a numpy integer (not a bool, not a float such as 16.0)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    raise ValueError(f"{name} must be a whole number (an int), not {value!r}")


def choice(what: str, value: Any, choices: Iterable[str | None]) -> str:
    """``value``, one of the names ``choices`` (a str, never a list of one); the message names
    ``what`` and lists ``choices`` (a None among them is offered, and handled, by the caller)."""
    choices = tuple(choices)
    if isinstance(value, str) and value in choices:
        return value
    raise ValueError(f"unknown {what} {value!r}: choose one of {', '.join(map(str, choices))}")
