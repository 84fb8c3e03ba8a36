"""One deadline per solve, made by :func:`blockmpec.solve` and handed down to every engine.

A :class:`Deadline` is an end time on :func:`time.perf_counter`'s clock; ``time_limit = inf`` means none
(:attr:`Deadline.end` is then ``inf``, :meth:`Deadline.remaining` ``inf``).  Engines never keep their own
clock arithmetic: they ask the deadline what is left (:meth:`~Deadline.remaining`), whether it has passed
(:meth:`~Deadline.expired`), or hand a backend the seconds it may still use (HiGHS's and Ipopt's time limits).
Code that may not import this module (the linear algebra of :mod:`blockmpec.solvers.linalg`) is handed
:attr:`Deadline.end`, the same end time as a float.
"""

from __future__ import annotations

import math
import time


class Deadline:
    """An end time on :func:`time.perf_counter`'s clock (``inf``: no limit).

    Parameters
    ----------
    seconds : float
        Seconds from now (``inf`` or ``None``: no limit).  Must not be negative or NaN.
    """

    __slots__ = ("end", "seconds", "start")

    def __init__(self, seconds: float | None = math.inf) -> None:
        seconds = math.inf if seconds is None else float(seconds)
        if not seconds >= 0:
            raise ValueError(f"a deadline needs seconds >= 0 (inf for none); got {seconds!r}")
        #: when the deadline was made and how many seconds it allowed (for messages)
        self.start = time.perf_counter()
        self.seconds = seconds
        #: the end time on perf_counter's clock (inf: none)
        self.end = self.start + seconds

    @classmethod
    def at(cls, end: float) -> Deadline:
        """The deadline ending at ``end`` (perf_counter's clock; ``inf`` for none)."""
        deadline = cls()
        deadline.end = float(end)
        deadline.seconds = deadline.end - deadline.start
        return deadline

    @property
    def finite(self) -> bool:
        """True when there is a limit."""
        return math.isfinite(self.end)

    def remaining(self) -> float:
        """Seconds left (``inf`` without a limit; never below 0)."""
        return max(self.end - time.perf_counter(), 0.0) if self.finite else math.inf

    def expired(self) -> bool:
        """True once the end time has passed."""
        return self.finite and time.perf_counter() >= self.end

    def elapsed(self) -> float:
        """Seconds since the deadline was made."""
        return time.perf_counter() - self.start

    def within(self, seconds: float) -> Deadline:
        """The earlier of this deadline and ``seconds`` from now (a stage's own budget inside the run's)."""
        return Deadline.at(min(self.end, time.perf_counter() + float(seconds)))

    def __repr__(self) -> str:
        return f"Deadline({self.seconds:g} s, {self.remaining():.3g} s left)"


#: a deadline that never passes (the default of engines called without one)
NEVER = Deadline()
