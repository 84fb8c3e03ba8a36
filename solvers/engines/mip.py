r"""Mixed-integer engines for :class:`~blockmpec.formulations.mpec_milp.MixedIntegerMPEC`: HiGHS and SCIP.

Both take the same model and return a :class:`MIPRun` in the model's (minimisation)
objective ``c^T v``, with a trace of ``(time_s, bound, incumbent, gap)`` over the
run (bound = the engine's dual bound; ``incumbent`` = its best primal value).

* ``solve_highs``: HiGHS branch and cut on the big-M form (``complementarity="bigm"``);
  the trace comes from HiGHS's MIP interrupt callback.
* ``solve_scip``: SCIP on either form; with ``complementarity="sos1"`` SCIP branches
  on the SOS1 sets ``{s_i, z_i}`` directly (no binaries); the trace comes from an
  event handler on dual-bound and best-solution events.

Neither engine decides what is certified: the caller compares the polished point
with the bound (:mod:`blockmpec.solvers.milp`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status

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


#: SCIP status -> Status (anything else: ERROR)
SCIP_STATUS = {
    "optimal": Status.OPTIMAL,
    "gaplimit": Status.OPTIMAL,
    "infeasible": Status.INFEASIBLE,
    "unbounded": Status.UNBOUNDED,
    "inforunbd": Status.INFEASIBLE_OR_UNBOUNDED,
    "timelimit": Status.TIME_LIMIT,
    "nodelimit": Status.ITERATION_LIMIT,
    "userinterrupt": Status.ERROR,
}


def solve_scip(mip, deadline: Deadline = NEVER, *, rel_gap: float, abs_gap: float, feasibility_tol: float,
               threads: int = 1, start: np.ndarray | None = None, t0: float | None = None,
               bilinear: bool = False) -> MIPRun:
    """SCIP on the model: binaries as ``B`` variables, each SOS1 set as an SOS1 constraint.

    ``bilinear=True`` adds the work identity (W) itself, ``q = sum`` over the
    model's ``work_products`` of ``x_r z_i`` as nonlinear constraints ``p_e = x_r z_i``
    (SCIP relaxes them by its own McCormick/OBBT and branches spatially): exact
    constraints of every solution of (3), so the result stays a relaxation.
    """
    import pyscipopt as scip

    from blockmpec.progress import verbose_enabled

    t0 = time.perf_counter() if t0 is None else t0
    tracer = _Tracer(mip.objective_sign, t0)
    m = scip.Model()
    if not verbose_enabled():
        m.hideOutput()
    if deadline.finite:
        m.setParam("limits/time", float(max(deadline.remaining(), 1e-3)))
    m.setParam("limits/gap", float(rel_gap))
    m.setParam("limits/absgap", float(abs_gap))
    m.setParam("numerics/feastol", float(max(feasibility_tol, 1e-9)))
    m.setParam("parallel/maxnthreads", int(threads))
    n = mip.n_columns
    inf = m.infinity()
    v = [m.addVar(name=f"v{j}", vtype="B" if mip.integer[j] else "C",
                  lb=(-inf if not np.isfinite(mip.col_lower[j]) else float(mip.col_lower[j])),
                  ub=(inf if not np.isfinite(mip.col_upper[j]) else float(mip.col_upper[j])),
                  obj=float(mip.c[j])) for j in range(n)]
    A = mip.A.tocsr()
    for i in range(A.shape[0]):
        a, b = A.indptr[i], A.indptr[i + 1]
        expr = scip.quicksum(float(c) * v[j] for j, c in zip(A.indices[a:b], A.data[a:b]))
        lo, hi = mip.row_lower[i], mip.row_upper[i]
        if lo == hi:
            m.addCons(expr == float(lo))
            continue
        if np.isfinite(lo):
            m.addCons(expr >= float(lo))
        if np.isfinite(hi):
            m.addCons(expr <= float(hi))
    for a, b in mip.sos1:
        m.addConsSOS1([v[a], v[b]], [1.0, 2.0])
    if bilinear and mip.work_products is not None and "p" in mip.columns:
        xr, zi, _ = mip.work_products
        for e, pcol in enumerate(mip.columns["p"]):
            m.addCons(v[int(pcol)] == v[int(xr[e])] * v[int(zi[e])])

    class _Events(scip.Eventhdlr):
        def eventinit(self):
            self.model.catchEvent(scip.SCIP_EVENTTYPE.BESTSOLFOUND, self)
            self.model.catchEvent(scip.SCIP_EVENTTYPE.NODESOLVED, self)

        def eventexec(self, event):
            best = event.getType() == scip.SCIP_EVENTTYPE.BESTSOLFOUND
            tracer.record(self.model.getDualbound(), self.model.getPrimalbound(), force=best)

    m.includeEventhdlr(_Events(), "trace", "records bound and incumbent over time")
    if start is not None:
        sol = m.createSol()
        for j in range(n):
            m.setSolVal(sol, v[j], float(start[j]))
        m.addSol(sol, free=True)
    t1 = time.perf_counter()
    m.optimize()
    run_s = time.perf_counter() - t1
    raw = m.getStatus()
    status = SCIP_STATUS.get(raw, Status.ERROR)
    point = None
    if m.getNSols() > 0:
        best = m.getBestSol()
        point = np.array([m.getSolVal(best, x) for x in v])
    primal = m.getPrimalbound() if point is not None else np.inf
    dual = m.getDualbound()
    if raw == "infeasible":
        dual = np.inf
    tracer.record(dual, primal, force=True)
    return MIPRun(status, raw, f"SCIP: {raw}", point, float(primal), float(dual), int(m.getNNodes()), run_s,
                  tracer.records)
