r"""One stopping criterion for every iterative loop, which also writes the trace.

The loops of the non-associative methods (fixed point and SLP, the block
interior-point method, semismooth Newton, continuation stages) all stop the same
way: the convergence measure of the iterate is at most ``tol``, or an iteration
limit or the run's deadline (:class:`~blockmpec.deadline.Deadline`) is reached.  Each loop owns one :class:`StoppingCriterion` and calls
:meth:`StoppingCriterion.check` once per iteration with its measure and any other
per-iteration values; the criterion appends a trace record
``{"iteration", "time_s", <measure_name>, ...}`` (``time_s`` since :meth:`start`)
and returns the :class:`~blockmpec.result.Status` to stop with, or ``None`` to go on.
(After benchopt's ``StoppingCriterion``: the loop asks, the criterion decides and
records.)  Each record is logged at INFO (shown with ``verbose=True``).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status

__all__ = ["StoppingCriterion"]

log = logging.getLogger(__name__)


@dataclass
class StoppingCriterion:
    """Stop when ``measure <= tol``, or at ``max_iterations``, or at ``deadline``.

    Parameters
    ----------
    tol : float
        Convergence threshold of the measure (the test is ``measure <= tol``).
    max_iterations : int
    deadline : Deadline
        The run's deadline (default: none).
    measure_name : str
        Key of the measure in the trace records (e.g. ``"n_change"``, ``"merit"``).
    """

    tol: float
    max_iterations: int
    deadline: Deadline = NEVER
    measure_name: str = "measure"
    trace: list[dict[str, Any]] = field(default_factory=list)
    t0: float = field(default_factory=time.perf_counter)
    iterations: int = 0

    def start(self) -> StoppingCriterion:
        """Restart the trace's clock and clear the trace (the deadline stays); returns ``self``."""
        self.t0 = time.perf_counter()
        self.trace = []
        self.iterations = 0
        return self

    def elapsed(self) -> float:
        """Seconds since :meth:`start`."""
        return time.perf_counter() - self.t0

    def remaining(self) -> float:
        """Seconds left before the deadline (``inf`` when there is none; never below 0)."""
        return self.deadline.remaining()

    def record(self, **values: Any) -> dict[str, Any]:
        """Append a trace record without a stopping decision (e.g. a start point)."""
        rec = {"iteration": self.iterations, "time_s": self.elapsed(), **values}
        self.trace.append(rec)
        if log.isEnabledFor(logging.INFO):
            log.info("%s", " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in rec.items()))
        return rec

    def check(self, measure: float, **values: Any) -> Status | None:
        """Count one iteration, record it, and say whether to stop.

        Returns
        -------
        Status or None
            ``CONVERGED`` when ``measure <= tol``; ``TIME_LIMIT`` or
            ``ITERATION_LIMIT`` when a limit is reached; ``NUMERICAL`` when the
            measure is not finite; ``None`` to continue.
        """
        self.iterations += 1
        self.record(**{self.measure_name: float(measure)}, **values)
        if not math.isfinite(measure):
            return Status.NUMERICAL
        if measure <= self.tol:
            return Status.CONVERGED
        if self.deadline.expired():
            return Status.TIME_LIMIT
        if self.iterations >= self.max_iterations:
            return Status.ITERATION_LIMIT
        return None

    def out_of_time(self) -> bool:
        """True once the deadline has passed (for checks inside an iteration)."""
        return self.deadline.expired()
