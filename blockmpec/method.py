"""The plug-in contract of a method: :class:`SolverBase`, which every solver adapter extends.

A solver adapter declares:

* ``name`` (CLI/method name), ``problem`` (``"associative"`` or
  ``"non-associative"``), ``summary`` and ``requires`` (backend modules);
* ``Options``: a dataclass of its user-facing options, extending
  :class:`~blockmpec.options.CommonOptions` (``time_limit``, ``verbose``), validated in
  ``__post_init__``;
* ``Settings`` (optional): a dataclass of its engine settings, the measured defaults of the
  knobs that experiments vary (``studies/lab``); not options: :func:`blockmpec.solve` does not take them,
  a configured instance does (``get_solver(name)(settings=...)``, run by :func:`blockmpec.run_solver`);
* ``setup(ops)``: untimed preparation (build the Pyomo model, compile, load) and, optionally, the ``plan``: the
  stages the run may take (a :class:`blockmpec.solvers.plan.Plan`), whose stages ``run`` starts one by one and
  whose stages that ran :func:`blockmpec.run_solver` records as ``Result.extra["plan"]``;
* ``run(deadline)``: the timed solve, returning a :class:`~blockmpec.result.RunOutput` with the raw iterate;
  every engine it runs keeps the one :class:`~blockmpec.deadline.Deadline`; a method that judges its own
  iterates (a multistart, a heuristic incumbent) asks :meth:`SolverBase.verified`, which verifies at the run's
  ``verify_tol`` (handed down by :func:`blockmpec.run_solver` before set-up);
* optionally ``skip_reason(ops)``: why the method does not fit a case;
* ``exact_solution = False`` for a heuristic whose answers need not satisfy (3).

:func:`blockmpec.solve` does the rest for every solver alike (:mod:`blockmpec.solver`).
"""

from __future__ import annotations

import dataclasses
import importlib.util
from typing import Any, ClassVar, get_type_hints

from blockmpec.deadline import Deadline
from blockmpec.errors import OptionError
from blockmpec.operators import Operators
from blockmpec.options import CommonOptions
from blockmpec.result import RunOutput, Solution
from blockmpec.verify import VERIFY_TOL, residuals


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
    #: the largest residual of a verified success: the run's ``verify_tol``, set by :func:`blockmpec.run_solver`
    #: before set-up
    verify_tol: float = VERIFY_TOL
    #: the stages set-up chose (a :class:`blockmpec.solvers.plan.Plan`; None: the method records none)
    plan: Any = None

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

    def verified(self, solution: Solution) -> bool:
        """Whether ``solution`` has a multiplier and every residual of its problem at most :attr:`verify_tol` (the
        shared verifier, as :func:`blockmpec.solve` judges the result)."""
        if solution is None or solution.multiplier is None:
            return False
        found = residuals(self.ops, solution, associative=self.problem == "associative")
        return bool(found) and all(v <= self.verify_tol for v in found.values())


def option_fields(cls: type[SolverBase]) -> list[tuple[str, Any, Any, str]]:
    """``(name, type, default, help)`` for each option of a solver class."""
    hints = get_type_hints(cls.Options)
    out = []
    for f in dataclasses.fields(cls.Options):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()  # type: ignore[misc]
        out.append((f.name, hints.get(f.name, str), default, f.metadata.get("help", "")))
    return out
