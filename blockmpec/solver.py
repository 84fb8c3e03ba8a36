"""Solving a case with a method: :func:`solve` and :func:`run_solver`.

They do what every method shares: assembly, the plug-in's untimed set-up and its timed run within one
:class:`~blockmpec.deadline.Deadline`, the shared verifier, the status downgrade and the :class:`Result`.  The
plug-in contract itself (:class:`SolverBase`) is :mod:`blockmpec.method`.
"""

from __future__ import annotations

import dataclasses
import logging
import time
import traceback
from typing import Any

from blockmpec import facts
from blockmpec.deadline import Deadline
from blockmpec.errors import BlockmpecError
from blockmpec.geometry import Structure
from blockmpec.method import SolverBase, option_fields  # noqa: F401 - re-exported: the plug-in contract
from blockmpec.operators import Operators, assemble
from blockmpec.progress import verbose
from blockmpec.registry import get_solver
from blockmpec.report import StructureMap
from blockmpec.result import Result, Status
from blockmpec.verify import VERIFY_TOL, residuals

log = logging.getLogger(__name__)


def solve(
    case: Structure | Operators,
    method: str,
    *,
    verify_tol: float = VERIFY_TOL,
    **options: Any,
) -> Result:
    """Solve a case with a registered method and verify the answer.

    Parameters
    ----------
    case : Structure or Operators
        The structure (assembled here) or its assembled operators.
    method : str
        A registered method name (see :func:`blockmpec.registry.list_solvers`).
    verify_tol : float
        A success status is kept only if every residual is at most this.
    **options
        The method's options (``blockmpec methods`` lists them): ``time_limit`` (seconds for the
        whole solve, set-up excluded; ``inf`` for none) and ``verbose`` for every method, and the
        method's own.

    Returns
    -------
    Result
        Never raises for a solver failure: the status says what happened.

    Raises
    ------
    UnknownNameError, OptionError
        For an unknown method or a bad option (before anything runs).
    """
    return run_solver(get_solver(method)(**options), case, verify_tol=verify_tol)


def run_solver(solver: SolverBase, case: Structure | Operators, *, verify_tol: float = VERIFY_TOL) -> Result:
    """Run a configured solver instance on a case: what :func:`solve` does after making the instance.

    For experiments that vary a method's engine settings (``studies/lab``):
    ``run_solver(get_solver("milp")(time_limit=60, settings=MILPSettings(lifting="rlt")), wall)``.
    Set-up (assembly, model building) is timed apart from the solve; the solve runs within one
    :class:`~blockmpec.deadline.Deadline` of ``time_limit`` seconds; the shared verifier checks the point at
    ``verify_tol``, which the solver is handed before set-up (:attr:`SolverBase.verify_tol`); the stages of the
    solver's plan that ran are ``Result.extra["plan"]``.
    """
    cls = type(solver)
    method = cls.name
    opts = dataclasses.asdict(solver.options)
    base = dict(method=method, problem=cls.problem, options=opts, verify_tol=verify_tol)
    reason = cls.unavailable_reason()
    if reason:
        return Result(status=Status.SKIPPED, message=reason, **base)
    t0 = time.perf_counter()
    ops = case if hasattr(case, "E") else assemble(case)  # a Structure or Structure3D, or assembled operators
    t_assembly = time.perf_counter() - t0
    reason = solver.skip_reason(ops)
    if reason:
        return Result(status=Status.SKIPPED, message=reason, **base)
    solver.verify_tol = verify_tol
    with verbose(solver.options.verbose):
        t0 = time.perf_counter()
        try:
            solver.setup(ops)
        except BlockmpecError:
            raise
        except Exception as exc:  # a backend failure is a status, not a crash
            log.debug("setup of %s failed:\n%s", method, traceback.format_exc())
            return Result(status=Status.ERROR, message=f"set-up failed: {type(exc).__name__}: {exc}",
                          build_time_s=time.perf_counter() - t0, **base)
        if solver.plan is not None:
            solver.plan.begin()
        t1 = time.perf_counter()
        try:
            out = solver.run(Deadline(solver.options.time_limit))
        except BlockmpecError:
            raise
        except Exception as exc:
            log.debug("run of %s failed:\n%s", method, traceback.format_exc())
            return Result(status=Status.ERROR, message=f"solve failed: {type(exc).__name__}: {exc}",
                          build_time_s=t1 - t0, solve_time_s=time.perf_counter() - t1, **base)
        t2 = time.perf_counter()
    res = residuals(ops, out.solution, associative=cls.problem == "associative")
    verified = bool(res) and all(v <= verify_tol for v in res.values())
    status, message = out.status, out.message
    if status.is_success and not verified:
        worst = max(res, key=res.get) if res else "all"
        status = Status.NUMERICAL
        message = (f"{method} reported {out.status.value} but the verifier disagrees: "
                   f"{worst} residual {res.get(worst, float('nan')):.3g} > {verify_tol:g}. {out.message}").strip()
    if status.is_success and verified and out.solution.multiplier is not None and out.solution.multiplier < 0:
        message = (f"lam = {out.solution.multiplier:.6g} < 0: the structure is not in equilibrium under the dead "
                   f"load alone; only the live load reversed and scaled by |lam| holds it. {message}").strip()
    extra = dict(out.extra)
    if solver.plan is not None:
        extra["plan"] = solver.plan.ran()
    extra[facts.ASSEMBLY_TIME_S] = t_assembly
    # after the timed part: references only, the frames are built when read (Result.forces, .mechanism)
    structure_map = StructureMap.of(ops) if getattr(ops, "structure", None) is not None else None
    return Result(
        status=status,
        multiplier=out.solution.multiplier,
        solution=out.solution,
        residuals=res,
        verified=verified,
        build_time_s=t1 - t0,
        solve_time_s=t2 - t1,
        iterations=out.iterations,
        trace=out.trace,
        message=message,
        raw_status=out.raw_status,
        extra=extra,
        structure_map=structure_map,
        **base,
    )
