"""The options every method shares (:class:`CommonOptions`) and validators for the others.

Validators are used in the ``Options.__post_init__`` of every adapter.

Each raises ``ValueError`` naming the option, what was expected and what was
received; :class:`blockmpec.method.SolverBase` turns it into an
:class:`~blockmpec.errors.OptionError` that also names the method.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

#: The one default ``time_limit`` [s] of every method (:class:`CommonOptions`).  Finite, so that no default solve
#: runs unbounded: about 13x the largest LP measured by the HiGHS simplex engines and far beyond the block IPM's
#: 100,000-block LP.  ``time_limit=inf`` (``-O time_limit=Infinity`` on the command line) removes the limit.
DEFAULT_TIME_LIMIT_S = 600.0


@dataclass
class CommonOptions:
    """The options every method has, declared once (each method's ``Options`` extends this class).

    Attributes
    ----------
    time_limit : float
        Seconds for the whole solve, set-up excluded; ``inf`` for none.  :func:`blockmpec.solve` turns it
        into one :class:`~blockmpec.deadline.Deadline` that every engine of the run shares.
    verbose : bool
        Log the run's progress (``logging`` at INFO on the ``blockmpec`` loggers, printed to stderr) and the
        backends' own logs (HiGHS, Ipopt).
    """

    time_limit: float = field(default=DEFAULT_TIME_LIMIT_S, metadata={
        "help": "seconds for the whole solve, set-up excluded (inf: no limit)"})
    verbose: bool = field(default=False, metadata={"help": "print the run's progress and the backends' logs"})

    def __post_init__(self) -> None:
        positive(self, "time_limit", finite=False)
        boolean(self, "verbose")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def positive(options: Any, *names: str, finite: bool = True) -> None:
    """Each option is a number > 0 (finite unless ``finite=False``, e.g. a time limit)."""
    for name in names:
        v = getattr(options, name)
        if not (_is_number(v) and v > 0 and (math.isfinite(v) or not finite)):
            raise ValueError(f"{name} must be a {'finite ' if finite else ''}number > 0; got {v!r}")


def interval(options: Any, name: str, low: float, high: float, *, closed: str = "neither") -> None:
    """The option lies between ``low`` and ``high``; ``closed`` is "left", "right", "both" or "neither"."""
    v = getattr(options, name)
    left_ok = _is_number(v) and (v >= low if closed in ("left", "both") else v > low)
    right_ok = _is_number(v) and (v <= high if closed in ("right", "both") else v < high)
    if not (left_ok and right_ok):
        lb = "[" if closed in ("left", "both") else "("
        rb = "]" if closed in ("right", "both") else ")"
        raise ValueError(f"{name} must be in {lb}{low:g}, {high:g}{rb}; got {v!r}")


def integer(options: Any, *names: str, minimum: int = 0) -> None:
    """Each option is an integer (not a bool) >= ``minimum``; integral floats are converted."""
    for name in names:
        v = getattr(options, name)
        if isinstance(v, float) and v.is_integer():
            v = int(v)
            setattr(options, name, v)
        if isinstance(v, bool) or not isinstance(v, int) or v < minimum:
            raise ValueError(f"{name} must be an integer >= {minimum}; got {v!r}")


def choice(options: Any, name: str, choices: Iterable[Any]) -> None:
    """The option is one of ``choices``.  Where the choices hold numbers, an integral float is converted to the
    integer choice it equals, and a bool matches only a bool (``True == 1`` in Python)."""
    choices = tuple(choices)
    v = getattr(options, name)
    if isinstance(v, float) and v.is_integer() and int(v) in choices:
        v = int(v)
        setattr(options, name, v)
    if v not in choices or (isinstance(v, bool) and not any(c is v for c in choices)):
        raise ValueError(f"{name} must be one of {', '.join(map(str, choices))}; got {v!r}")


def boolean(options: Any, *names: str) -> None:
    """Each option is true or false."""
    for name in names:
        v = getattr(options, name)
        if not isinstance(v, bool):
            raise ValueError(f"{name} must be true or false; got {v!r}")
