r"""The mixed-integer engine of :class:`~blockmpec.formulations.mpec_milp.MixedIntegerMPEC` (HiGHS), and the record
of one engine run that both of ``milp``'s engines return.

:func:`solve_highs` runs HiGHS's branch and cut on the big-M model and returns a :class:`MIPRun` in the model's
(minimisation) objective ``c^T v``, with a trace of ``(time_s, bound, incumbent, gap)`` over the run from HiGHS's MIP
callback (bound = the engine's dual bound; ``incumbent`` = its best primal value).  The engine does not decide what is
certified: the caller compares the polished point with the bound (:mod:`blockmpec.solvers.engines.milp_search`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status

__all__ = ["MIPRun", "solve_highs", "TRACE_PERIOD_S"]

#: seconds between two trace records of a periodic callback
TRACE_PERIOD_S = 0.25


@dataclass
class MIPRun:
    """One engine run: what it proved (``dual_bound <= optimum``, minimisation) and found."""

    status: Status
    raw_status: str
    message: str
    point: np.ndarray | None
    primal_bound: float
    dual_bound: float
    nodes: int
    time_s: float
    trace: list[dict] = field(default_factory=list)

    @property
    def has_point(self) -> bool:
        return self.point is not None


class _Tracer:
    """Trace records in the caller's multiplier units: value = sign * objective."""

    def __init__(self, sign: float, t0: float) -> None:
        self.sign, self.t0 = sign, t0
        self.records: list[dict] = []
        self.last = -np.inf

    def record(self, bound: float, incumbent: float, force: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self.last < TRACE_PERIOD_S:
            return
        self.last = now
        b = self.sign * bound if np.isfinite(bound) else None
        inc = self.sign * incumbent if np.isfinite(incumbent) and abs(incumbent) < 1e20 else None
        gap = abs(inc - b) if (b is not None and inc is not None) else None
        self.records.append({"time_s": now - self.t0, "bound": b, "incumbent": inc, "gap_abs": gap})


def solve_highs(mip, deadline: Deadline = NEVER, *, rel_gap: float, abs_gap: float, feasibility_tol: float,
                threads: int = 1, start: np.ndarray | None = None, t0: float | None = None) -> MIPRun:
    """HiGHS on the big-M model (integer columns = binaries), within ``deadline``
    (:func:`blockmpec.solvers.engines.highs.highs_mip` runs it)."""
    from blockmpec.solvers.engines.highs import highs_mip

    t0 = time.perf_counter() if t0 is None else t0
    tracer = _Tracer(mip.objective_sign, t0)
    t1 = time.perf_counter()
    info, point = highs_mip(mip.A, mip.c, mip.row_lower, mip.row_upper, mip.col_lower, mip.col_upper, mip.integer,
                            deadline=deadline, rel_gap=rel_gap, abs_gap=abs_gap, feasibility_tol=feasibility_tol,
                            threads=threads, start=start, record=tracer.record)
    run_s = time.perf_counter() - t1
    tracer.record(info.dual_bound, info.primal_bound, force=True)
    return MIPRun(info.status, info.raw_status, info.message, point, info.primal_bound, info.dual_bound, info.nodes,
                  run_s, tracer.records)
