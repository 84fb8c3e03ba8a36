"""Solver plug-in base class and the :func:`solve` entry point.

A solver adapter declares:

* ``name`` (CLI/method name), ``problem`` (``"associative"`` or
  ``"non-associative"``), ``summary`` and ``requires`` (backend modules);
* ``Options``: a dataclass of its user-facing options, extending
  :class:`~blockmpec.options.CommonOptions` (``time_limit``, ``verbose``), validated in
  ``__post_init__``;
* ``Settings`` (optional): a dataclass of its engine settings, the measured defaults of the
  knobs that experiments vary (``studies/lab``); not options: :func:`solve` does not take them,
  a configured instance does (``get_solver(name)(settings=...)``, run by :func:`run_solver`);
* ``setup(ops)``: untimed preparation (build the Pyomo model, compile, load);
* ``run(deadline)``: the timed solve, returning a :class:`RunOutput` with the raw iterate; every
  engine it runs keeps the one :class:`~blockmpec.deadline.Deadline`;
* optionally ``skip_reason(ops)``: why the method does not fit a case;
* ``exact_solution = False`` for a heuristic whose answers need not satisfy (3).

:func:`solve` does the rest for every solver alike: assembly, timing of set-up and
solve apart, the deadline, the shared verifier, status downgrade and the :class:`Result`.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import logging
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, ClassVar, get_type_hints

from blockmpec import facts
from blockmpec.deadline import Deadline
from blockmpec.errors import BlockmpecError, OptionError
from blockmpec.geometry import Structure
from blockmpec.operators import Operators, assemble
from blockmpec.options import CommonOptions
from blockmpec.progress import verbose
from blockmpec.registry import get_solver
from blockmpec.report import StructureMap
from blockmpec.result import Result, RunOutput, Status
from blockmpec.verify import residuals

log = logging.getLogger(__name__)


class SolverBase:
    """Base class of solver adapters; see the module docstring."""

    name: ClassVar[str]
    problem: ClassVar[str]
    summary: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()
    Options: ClassVar[type] = CommonOptions
    #: engine settings (None: the method has none); see the module docstring
    Settings: ClassVar[type | None] = None
    #: False for heuristics whose converged iterates are not meant to satisfy every
    #: residual of (3) (e.g. the SLP's tilted friction surface leaves dilatancy);
    #: their results are reported, and usually come out unverified.
    exact_solution: ClassVar[bool] = True

    def __init__(self, *, settings: Any = None, **options: Any) -> None:
        fields = {f.name for f in dataclasses.fields(self.Options)}
        unknown = sorted(set(options) - fields)
        if unknown:
            valid = ", ".join(sorted(fields)) or "none"
            raise OptionError(f"method {self.name!r} has no option {unknown[0]!r}; valid options: {valid}")
        try:
            self.options = self.Options(**options)
        except (TypeError, ValueError) as exc:
            raise OptionError(f"method {self.name!r}: {exc}") from None
        if settings is not None and (self.Settings is None or not isinstance(settings, self.Settings)):
            want = "none" if self.Settings is None else f"a {self.Settings.__name__}"
            raise OptionError(f"method {self.name!r}: settings must be {want}; got {type(settings).__name__}")
        #: the engine settings of this instance (the method's measured defaults unless given)
        self.settings = settings if settings is not None else (self.Settings() if self.Settings else None)

    @classmethod
    def unavailable_reason(cls) -> str | None:
        """Why the method cannot run here (a missing backend), or None."""
        missing = [m for m in cls.requires if importlib.util.find_spec(m) is None]
        if missing:
            return f"{cls.name} needs the Python package(s) {', '.join(missing)}, which are not installed"
        return None

    def skip_reason(self, ops: Operators) -> str | None:
        """Why this method does not fit the case ``ops``, or None."""
        return None

    def setup(self, ops: Operators) -> None:
        """Untimed preparation; stores what ``run`` needs."""
        self.ops = ops

    def run(self, deadline: Deadline) -> RunOutput:  # pragma: no cover - abstract
        """The timed solve, within ``deadline``."""
        raise NotImplementedError


def option_fields(cls: type[SolverBase]) -> list[tuple[str, Any, Any, str]]:
    """``(name, type, default, help)`` for each option of a solver class."""
    hints = get_type_hints(cls.Options)
    out = []
    for f in dataclasses.fields(cls.Options):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()  # type: ignore[misc]
        out.append((f.name, hints.get(f.name, str), default, f.metadata.get("help", "")))
    return out


def solve(
    case: Structure | Operators,
    method: str,
    *,
    verify_tol: float = 1e-6,
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


def run_solver(solver: SolverBase, case: Structure | Operators, *, verify_tol: float = 1e-6) -> Result:
    """Run a configured solver instance on a case: what :func:`solve` does after making the instance.

    For experiments that vary a method's engine settings (``studies/lab``):
    ``run_solver(get_solver("milp")(time_limit=60, settings=MILPSettings(lifting="rlt")), wall)``.
    Set-up (assembly, model building) is timed apart from the solve; the solve runs within one
    :class:`~blockmpec.deadline.Deadline` of ``time_limit`` seconds; the shared verifier checks the point.
    """
    cls = type(solver)
    method = cls.name
    opts = dataclasses.asdict(solver.options)
    base = dict(method=method, problem=cls.problem, options=opts, verify_tol=verify_tol)
    reason = cls.unavailable_reason()
    if reason:
        return Result(status=Status.SKIPPED, message=reason, **base)
    t0 = time.perf_counter()
    ops = assemble(case) if isinstance(case, Structure) else case
    t_assembly = time.perf_counter() - t0
    reason = solver.skip_reason(ops)
    if reason:
        return Result(status=Status.SKIPPED, message=reason, **base)
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
