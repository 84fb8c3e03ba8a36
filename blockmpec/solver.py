"""Solver plug-in base class and the :func:`solve` entry point.

A solver adapter declares:

* ``name`` (CLI/method name), ``problem`` (``"associative"`` or
  ``"non-associative"``), ``summary`` and ``requires`` (backend modules);
* ``Options``: a dataclass of its options (validated in ``__post_init__``);
* ``setup(ops)``: untimed preparation (build the Pyomo model, compile, load);
* ``run()``: the timed solve, returning a :class:`RunOutput` with the raw iterate;
* optionally ``skip_reason(ops)``: why the method does not fit a case;
* ``exact_solution = False`` for a heuristic whose answers need not satisfy (3).

:func:`solve` does the rest for every solver alike: assembly, timing of set-up and
solve apart, the shared verifier, status downgrade and the :class:`Result`.
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
from blockmpec.errors import BlockmpecError, OptionError
from blockmpec.geometry import Structure
from blockmpec.operators import Operators, assemble
from blockmpec.registry import get_solver
from blockmpec.report import StructureMap
from blockmpec.result import Result, Solution, Status
from blockmpec.verify import residuals

log = logging.getLogger(__name__)


@dataclass
class RunOutput:
    """What a solver's ``run`` returns: its claimed status and raw iterate."""

    status: Status
    solution: Solution = field(default_factory=Solution)
    iterations: int = 0
    trace: list[dict[str, Any]] = field(default_factory=list)
    message: str = ""
    raw_status: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class NoOptions:
    """This method has no options."""


class SolverBase:
    """Base class of solver adapters; see the module docstring."""

    name: ClassVar[str]
    problem: ClassVar[str]
    summary: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()
    Options: ClassVar[type] = NoOptions
    #: False for heuristics whose converged iterates are not meant to satisfy every
    #: residual of (3) (e.g. the SLP's tilted friction surface leaves dilatancy);
    #: their results are reported, and usually come out unverified.
    exact_solution: ClassVar[bool] = True

    def __init__(self, **options: Any) -> None:
        fields = {f.name for f in dataclasses.fields(self.Options)}
        unknown = sorted(set(options) - fields)
        if unknown:
            valid = ", ".join(sorted(fields)) or "none"
            raise OptionError(f"method {self.name!r} has no option {unknown[0]!r}; valid options: {valid}")
        try:
            self.options = self.Options(**options)
        except (TypeError, ValueError) as exc:
            raise OptionError(f"method {self.name!r}: {exc}") from None

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

    def run(self) -> RunOutput:  # pragma: no cover - abstract
        """The timed solve."""
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
        The method's options (see ``blockmpec methods``).

    Returns
    -------
    Result
        Never raises for a solver failure: the status says what happened.

    Raises
    ------
    UnknownNameError, OptionError
        For an unknown method or a bad option (before anything runs).
    """
    cls = get_solver(method)
    solver = cls(**options)
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
        out = solver.run()
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
