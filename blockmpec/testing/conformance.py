r"""The conformance suite every method passes, built-in or plug-in: :func:`check_solver`.

What it checks is listed in :data:`CHECKS` (one row of the returned table per check and subject).  Every run goes
through :func:`blockmpec.run_solver`, as ``bm.solve`` does, with the options given and a ``time_limit`` per run;
the method's claimed status is kept (``verify_tol=inf``) and the suite verifies each point itself: a point is
*verified* when it is complete (``multiplier``, ``x``, ``u``, ``z_u``, ``z_f``) and every residual of (3)
(:func:`blockmpec.residuals`) is at most ``verify_tol``.

Tolerances.  A verified point solves (3) to relative residuals of ``verify_tol``, so its multiplier is that of an
exact solution to about ``verify_tol`` on lam's scale: references are met within ``tol = verify_tol *
max(1, |lam_ref|)`` (1e-6 by default; the built-in methods reach 2e-16 on the closed forms and on the
associative references, and lie above the minimum by at most 3.5e-8, the fixed point at two blocks with
``(eta, mu) = (3, 2)``).  The same ``tol`` bounds the change of a verified multiplier under the transformations
(measured: 0 for every built-in method, the assembly being exact in its canonical frame and units) and the
balance of the reported forces and mechanism in the user's units (measured: 1e-16 at most on the two blocks, 1e-14
on the round arch).

The time limit is judged without measuring the machine's speed: the run gets ``time_limit = 1e-9`` s, a deadline
that has passed before the run begins, so a method that honours its deadline reports ``time_limit`` whatever the
machine; ``run`` must also return within :data:`EXPIRED_DEADLINE_SLACK_S` (a second, against the tenth of a
millisecond the built-in methods take).
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from typing import Any

import numpy as np

from blockmpec.errors import OptionError
from blockmpec.geometry import Structure, make_structure
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import PROBLEMS, bad_name, get_solver
from blockmpec.result import Result, Status
from blockmpec.result import is_finite_number as _finite
from blockmpec.solver import option_fields, run_solver
from blockmpec.testing import transforms
from blockmpec.testing.references import ASSOCIATIVE, ReferenceCase, reference_cases
from blockmpec.verify import RESIDUAL_NAMES

#: every check of :func:`check_solver`: name -> what passes
CHECKS: dict[str, str] = {
    "contract.name": "name: a non-empty string without spaces, commas or colons; summary: a non-empty string",
    "contract.problem": "problem is 'associative' or 'non-associative'",
    "contract.options": "Options: a dataclass extending blockmpec.options.CommonOptions, every field with a default, "
                        "a finite default time_limit; the class builds with no argument",
    "contract.methods": "run(deadline) is the class's own; requires is a tuple of module names; exact_solution and "
                        "certifies_minimum are booleans; Settings is None or a dataclass with defaults",
    "available": "the method's backends are installed (unavailable_reason() is None); else every run is skipped",
    "options.unknown": "an unknown option raises blockmpec.OptionError, one line naming it",
    "options.value": "a value of the wrong kind for an option raises blockmpec.OptionError, one line naming it",
    "result": "run_solver returns a Result: a Status, iterations >= 0, a solve time, a trace whose records have "
              "non-decreasing iteration and time_s within the solve time, a finite multiplier with a success, "
              "the class's name and problem, to_dict() as JSON, a one-line repr",
    "honesty": "no error status; no infeasible or unbounded claim on a case with a known solution; a success claimed "
               "by an exact method is verified",
    "closed-form": "on a closed-form case, a verified answer at the closed form (associative) or within "
                   "[minimum, associative] (non-associative); a heuristic (exact_solution=False) claims success "
                   "with a multiplier within them",
    "published": "a verified multiplier rounds to the published value",
    "case": "on a built-in case, a verified multiplier within [minimum, associative] (associative: at the LP "
            "optimum; a certified minimum for methods that certify one), or an honest failure",
    "impossible": "no success claimed on a structure that no load multiplier holds",
    "time-limit": "with a deadline passed before the run begins, status time_limit, back within "
                  "EXPIRED_DEADLINE_SLACK_S",
    "invariance.translation": "the same status and multiplier when the structure is moved by (2^20, -2^18)",
    "invariance.mirror": "the same status and multiplier for the mirror image with the live load reversed",
    "invariance.block-order": "the same status and multiplier with the blocks and interfaces in reverse order",
    "invariance.units": "the same status and multiplier with lengths x 1000 and densities x 25",
    "user-units": "the reported forces of a point in equilibrium balance the loads and its mechanism has unit "
                  "live-load power, in the structure's own units and frame",
}

#: columns of the table :func:`check_solver` returns
COLUMNS = ("check", "subject", "passed", "skipped", "message", "status", "multiplier", "reference",
           "reference_source", "solve_time_s")
#: seconds a run may take to return once its deadline has passed (see the module docstring)
EXPIRED_DEADLINE_SLACK_S = 1.0
#: the time limit of the time-limit check: a deadline that has passed before the run begins
EXPIRED_TIME_LIMIT_S = 1e-9
#: statuses that claim the problem has no solution
_NO_SOLUTION = (Status.INFEASIBLE, Status.UNBOUNDED, Status.INFEASIBLE_OR_UNBOUNDED)
#: the case of the invariance checks: the paper's two blocks, whose solutions of (3) are not unique
_INVARIANCE_CASE = "two-blocks[eta=3,mu=0.65]"
#: the case of the time-limit check: the largest quick case but one (the stone wall's LPs are about as large)
_TIME_LIMIT_CASE = "wall[courses=4,blocks_per_course=2,bond=stack]"
_TRANSFORMS = {
    "invariance.translation": lambda s: transforms.translated(s, 2.0**20, -(2.0**18)),
    "invariance.mirror": transforms.mirrored,
    "invariance.block-order": lambda s: transforms.reordered(s),
    "invariance.units": lambda s: transforms.rescaled(s, length=1000.0, density=25.0),
}


class ConformanceError(AssertionError):
    """Raised by :func:`check_solver` when a check fails: the message names every failed check; :attr:`checks`
    holds the whole table."""

    def __init__(self, message: str, checks) -> None:
        super().__init__(message)
        self.checks = checks


def check_solver(solver: type[SolverBase] | str, *, quick: bool = True, options: dict[str, Any] | None = None,
                 verify_tol: float = 1e-6, time_limit: float = 60.0, raise_on_failure: bool = True):
    """Run the conformance suite on a method: the checks of :data:`CHECKS`.

    Parameters
    ----------
    solver : SolverBase subclass or str
        The class (registered or not), a registered method name, or ``"module:Class"``.
    quick : bool
        The quick set of cases (every 2D built-in case but ``ferris-tinloi``, and the 3D block, at small sizes;
        seconds for the built-in methods); ``False`` adds the larger cases (``ferris-tinloi``, the cases' default sizes), whose references
        may take minutes (a certificate of ``milp`` each, at most
        :data:`~blockmpec.testing.references.REFERENCE_TIME_LIMIT_S`).
    options : dict, optional
        The method's options for every run (each run's ``time_limit`` is ``time_limit`` unless given here); a bad
        one raises :class:`~blockmpec.errors.OptionError` before anything runs.
    verify_tol : float
        The largest residual of (3) of a verified point, and the relative tolerance of the references (see the
        module docstring).
    time_limit : float
        Seconds each run may take: a run stopped by it on a built-in case is an honest failure.
    raise_on_failure : bool
        Raise :class:`ConformanceError` (an ``AssertionError``) naming every failed check (the default), or only
        return the table.

    Returns
    -------
    pandas.DataFrame
        One row per check and subject, columns :data:`COLUMNS`: ``check`` (a key of :data:`CHECKS`), ``subject``
        (a case label, an option), ``passed``, ``skipped``, ``message``, and for runs ``status``, ``multiplier``,
        ``reference``, ``reference_source`` and ``solve_time_s``.

    Raises
    ------
    ConformanceError
        When a check fails (and ``raise_on_failure``); its ``checks`` attribute is the table.

    Examples
    --------
    >>> from blockmpec.testing import check_solver
    >>> table = check_solver("fixed-point")  # doctest: +SKIP
    >>> table[["check", "subject", "passed"]].head()  # doctest: +SKIP
    """
    cls = get_solver(solver) if isinstance(solver, str) else solver
    if not isinstance(cls, type):
        raise TypeError(f"check_solver needs a SolverBase subclass, a method name or 'module:Class'; got {solver!r}")
    suite = _Suite(cls, dict(options or {}), float(verify_tol), float(time_limit))
    if suite.check_contract():
        cls(**{"time_limit": time_limit, **suite.options})  # bad options for the runs: an OptionError, now
        suite.check_options()
        results = suite.check_cases(reference_cases(quick))
        suite.check_impossible_case()
        quick_cases = reference_cases(True)
        suite.check_time_limit(quick_cases[_TIME_LIMIT_CASE])
        suite.check_invariance(quick_cases[_INVARIANCE_CASE], results.get(_INVARIANCE_CASE))
    table = suite.table()
    failed = table[~table["passed"]]
    if raise_on_failure and len(failed):
        lines = [f"  {r.check}[{r.subject}]: {r.message}" if r.subject else f"  {r.check}: {r.message}"
                 for r in failed.itertuples()]
        raise ConformanceError(f"{getattr(cls, 'name', cls.__name__)}: {len(failed)} of {len(table)} conformance "
                               "checks failed:\n" + "\n".join(lines), table)
    return table


class _Suite:
    """The rows of one :func:`check_solver` call and the runs behind them."""

    def __init__(self, cls: type, options: dict[str, Any], verify_tol: float, time_limit: float) -> None:
        self.cls, self.options, self.verify_tol, self.time_limit = cls, options, verify_tol, time_limit
        self.name = getattr(cls, "name", None) if isinstance(getattr(cls, "name", None), str) else None
        self.exact = getattr(cls, "exact_solution", True) is not False
        self.rows: list[dict[str, Any]] = []

    # ------------------------------------------------------------------ bookkeeping

    def add(self, check: str, subject: str, passed: bool, message: str, result: Result | None = None,
            reference: Any = None, skipped: bool = False) -> None:
        row = dict(check=check, subject=subject, passed=bool(passed), skipped=skipped, message=message,
                   status="", multiplier=math.nan, reference=math.nan, reference_source="", solve_time_s=math.nan)
        if result is not None:
            row.update(status=getattr(result.status, "value", str(result.status)),
                       multiplier=_float(result.multiplier), solve_time_s=_float(result.solve_time_s))
        if reference is not None:
            row.update(reference=_float(reference.value), reference_source=reference.source)
        self.rows.append(row)

    def table(self):
        import pandas as pd

        return pd.DataFrame(self.rows, columns=list(COLUMNS))

    def tol(self, value: float | None) -> float:
        return self.verify_tol * max(1.0, abs(value or 0.0))

    def verified(self, res: Result) -> bool:
        """Complete, and every residual of (3) at most ``verify_tol``."""
        sol = res.solution
        complete = all(getattr(sol, f) is not None for f in ("x", "u", "z_u", "z_f")) and _finite(res.multiplier)
        return complete and set(RESIDUAL_NAMES) <= set(res.residuals) and \
            all(v <= self.verify_tol for v in res.residuals.values())

    def solve(self, check: str, subject: str, structure: Structure, **extra: Any) -> Result | None:
        """One run through :func:`blockmpec.run_solver` (the claimed status kept); an exception is a failed row."""
        options = {"time_limit": self.time_limit, **self.options, **extra}
        try:
            return run_solver(self.cls(**options), structure, verify_tol=math.inf)
        except Exception as exc:  # noqa: BLE001 - whatever escapes is the finding
            self.add(check, subject, False, f"run_solver raised {type(exc).__name__}: {_line(exc)} (a method returns "
                     "a blockmpec.RunOutput from run(); a failure is a status, not an exception)")
            return None

    # ------------------------------------------------------------------ the contract

    def check_contract(self) -> bool:
        """The class attributes (no run); True when the runs can go ahead."""
        cls = self.cls
        if not issubclass(cls, SolverBase):
            self.add("contract.name", "", False, f"{cls!r} is not a subclass of blockmpec.SolverBase")
            return False
        reason = bad_name(getattr(cls, "name", None))
        summary = getattr(cls, "summary", "")
        if reason is None and not (isinstance(summary, str) and summary.strip()):
            reason = "summary: a one-line description is needed (blockmpec methods lists it)"
        name_ok = reason is None
        self.add("contract.name", "", name_ok, f"name {cls.name!r}" if name_ok else reason)
        problem_ok = getattr(cls, "problem", None) in PROBLEMS
        self.add("contract.problem", "", problem_ok, f"problem must be one of {', '.join(PROBLEMS)}; got "
                 f"{getattr(cls, 'problem', None)!r}" if not problem_ok else f"problem {cls.problem!r}")
        options_ok = self._check_options_class()
        methods_ok = self._check_methods()
        reason = cls.unavailable_reason() if methods_ok else "requires is malformed"
        self.add("available", "", True, reason or "available", skipped=reason is not None)
        return name_ok and problem_ok and options_ok and reason is None

    def _check_options_class(self) -> bool:
        opts = self.cls.Options
        problem = None
        if not (dataclasses.is_dataclass(opts) and isinstance(opts, type) and issubclass(opts, CommonOptions)):
            problem = f"Options must be a dataclass extending blockmpec.options.CommonOptions; got {opts!r}"
        else:
            missing = [f.name for f in dataclasses.fields(opts)
                       if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
            if missing:
                problem = f"option(s) without a default: {', '.join(missing)}"
        if problem is None:
            try:
                default = self.cls().options.time_limit
            except Exception as exc:  # noqa: BLE001
                problem = f"the class does not build with its defaults: {type(exc).__name__}: {_line(exc)}"
            else:
                if not (_finite(default) and default > 0):
                    problem = f"the default time_limit must be finite and > 0 (no default solve unbounded); got " \
                              f"{default!r}"
        self.add("contract.options", "", problem is None, problem or "Options extends CommonOptions, with defaults")
        return problem is None

    def _check_methods(self) -> bool:
        cls, problems = self.cls, []
        if cls.run is SolverBase.run:
            problems.append("run(deadline) is not defined")
        requires = getattr(cls, "requires", ())
        if not (isinstance(requires, (tuple, list)) and all(isinstance(m, str) for m in requires)):
            problems.append(f"requires must be a tuple of module names; got {requires!r}")
        for flag in ("exact_solution", "certifies_minimum"):
            if not isinstance(getattr(cls, flag, False), bool):
                problems.append(f"{flag} must be True or False; got {getattr(cls, flag)!r}")
        settings = getattr(cls, "Settings", None)
        if settings is not None:
            try:
                assert dataclasses.is_dataclass(settings)
                settings()
            except Exception:  # noqa: BLE001
                problems.append(f"Settings must be None or a dataclass that builds with its defaults; got {settings!r}")
        self.add("contract.methods", "", not problems, "; ".join(problems) or "run, requires, flags and Settings")
        return not problems

    # ------------------------------------------------------------------ options

    def check_options(self) -> None:
        cls = self.cls
        try:
            cls(no_such_option=1)
        except OptionError as exc:
            ok = "no_such_option" in str(exc) and "\n" not in str(exc)
            self.add("options.unknown", "no_such_option", ok, str(exc) if ok else f"not one line naming the option: "
                     f"{exc}")
        except Exception as exc:  # noqa: BLE001
            self.add("options.unknown", "no_such_option", False, f"raised {type(exc).__name__} instead of "
                     f"blockmpec.OptionError: {_line(exc)}")
        else:
            self.add("options.unknown", "no_such_option", False, "an unknown option was accepted")
        try:
            fields = option_fields(cls)
        except Exception as exc:  # noqa: BLE001 - unresolvable annotations
            self.add("options.value", "", False, f"the option types cannot be read: {type(exc).__name__}: {_line(exc)}")
            return
        for name, typ, _default, _help in fields:
            bad = _wrong_values(typ) + ([-1.0] if name == "time_limit" else [])
            if not bad:
                self.add("options.value", name, True, f"no wrong value known for type {typ!r}", skipped=True)
            for value in bad:
                self._check_bad_value(name, typ, value)

    def _check_bad_value(self, name: str, typ: Any, value: Any) -> None:
        subject = f"{name}={value!r}"
        try:
            self.cls(**{name: value})
        except OptionError as exc:
            ok = name in str(exc) and "\n" not in str(exc)
            self.add("options.value", subject, ok, str(exc) if ok else f"not one line naming {name}: {exc}")
        except Exception as exc:  # noqa: BLE001
            self.add("options.value", subject, False, f"raised {type(exc).__name__} instead of blockmpec.OptionError: "
                     f"{_line(exc)}")
        else:
            self.add("options.value", subject, False, f"{name}={value!r} was accepted (option type {_type_name(typ)}):"
                     " validate it in Options.__post_init__ (blockmpec.options: positive, interval, integer, choice, "
                     "boolean)")

    # ------------------------------------------------------------------ runs on the reference cases

    def check_cases(self, cases: dict[str, ReferenceCase]) -> dict[str, Result]:
        """Every reference case: the result, honesty and reference checks; returns the results by label."""
        results = {}
        for label, case in cases.items():
            check = "closed-form" if case.kind == "closed-form" else "case"
            res = self.solve(check, label, case.structure)
            if res is None:
                continue
            results[label] = res
            self.check_result(label, res)
            self.check_honesty(label, res, case)
            self.check_multiplier(check, label, res, case)
            published = case.published.get(self.cls.problem)
            if published is not None:
                self.check_published(label, res, published)
        return results

    def check_result(self, subject: str, res: Result) -> None:
        problems = []
        if not isinstance(res.status, Status):
            problems.append(f"status {res.status!r} is not a blockmpec.Status")
        if isinstance(res.iterations, bool) or not isinstance(res.iterations, (int, np.integer)) or res.iterations < 0:
            problems.append(f"iterations must be an integer >= 0; got {res.iterations!r}")
        if not (_finite(res.solve_time_s) and res.solve_time_s >= 0):
            problems.append(f"solve time {res.solve_time_s!r}")
        if isinstance(res.status, Status) and res.status.is_success and not _finite(res.multiplier):
            problems.append(f"a {res.status.value} result needs a finite multiplier; got {res.multiplier!r}")
        problems += _trace_problems(res.trace, res.solve_time_s)
        if (res.method, res.problem) != (self.cls.name, self.cls.problem):
            problems.append(f"method and problem {res.method!r}, {res.problem!r}; the class says {self.cls.name!r}, "
                            f"{self.cls.problem!r}")
        try:
            json.dumps(res.to_dict(), allow_nan=False)
        except (TypeError, ValueError) as exc:
            problems.append(f"to_dict() is not JSON (blockmpec solve --json prints it; keep extra to numbers, "
                            f"strings, lists and dicts): {_line(exc)}")
        if "\n" in repr(res):
            problems.append("repr spans lines")
        self.add("result", subject, not problems, "; ".join(problems) or "well-formed", res)

    def check_honesty(self, subject: str, res: Result, case: ReferenceCase) -> None:
        status, problem = res.status, None
        if status is Status.ERROR:
            problem = f"error: {res.message} (a crash is not an honest failure)"
        elif status in _NO_SOLUTION:
            known = case.solution_known(self.cls.problem, self.name)
            if known is not None:
                problem = f"claims {status.value}, but a solution is known: lam = {known.value:.10g} ({known.source})"
        elif status.is_success and self.exact and not self.verified(res):
            problem = f"claims {status.value} but is not verified: {_unverified(res, self.verify_tol)}"
        self.add("honesty", subject, problem is None, problem or f"{status.value}", res)

    def check_multiplier(self, check: str, subject: str, res: Result, case: ReferenceCase) -> None:
        lower, upper = case.bounds(self.cls.problem, self.name)
        lam, verified = res.multiplier, self.verified(res)
        if not verified and (check == "case" or (self.exact and check == "closed-form")):
            ok = check == "case"  # a failure on a built-in case is allowed; its status is judged by "honesty"
            why = _unverified(res, self.verify_tol) if res.status.is_success else _line(res.message)
            message = (f"no verified multiplier: {res.status.value}" if ok else
                       f"no verified answer on a closed-form case: {res.status.value}")
            self.add(check, subject, ok, message + (f" ({why})" if why else ""), res, upper)
            return
        if not verified and not res.status.is_success:  # a heuristic on a closed form
            self.add(check, subject, False, f"a heuristic must reach the closed form's mechanism; got "
                     f"{res.status.value} ({_line(res.message)})", res, upper)
            return
        problems = []
        if upper.value is not None and lam > upper.value + self.tol(upper.value):
            problems.append(f"lam = {lam:.10g} is above the associative multiplier {upper.value:.10g} ({upper.source}) "
                            f"by {lam - upper.value:.2g}")
        if lower.value is not None and lam < lower.value - self.tol(lower.value):
            what = "associative multiplier" if self.cls.problem == ASSOCIATIVE else (
                "minimum" if lower.exact else "lower bound of the minimum")
            problems.append(f"lam = {lam:.10g} is below the {what} {lower.value:.10g} ({lower.source}) by "
                            f"{lower.value - lam:.2g}")
        certifies = getattr(self.cls, "certifies_minimum", False) and res.status is Status.OPTIMAL
        if certifies and lower.exact and lower.value is not None and lam > lower.value + self.tol(lower.value):
            problems.append(f"certified lam = {lam:.10g} is above the minimum {lower.value:.10g} ({lower.source})")
        if lower is upper:
            where = f"at the associative multiplier {_fmt(upper.value)} ({upper.source})"
        else:
            where = f"in [{_fmt(lower.value)}, {_fmt(upper.value)}] ({lower.source}; {upper.source})"
        note = "" if verified else f"; not verified, a heuristic's point ({_unverified(res, self.verify_tol)})"
        self.add(check, subject, not problems, "; ".join(problems) or f"lam = {lam:.10g} {where}, tolerance "
                 f"{self.tol(upper.value):.1g}{note}", res, upper)

    def check_published(self, subject: str, res: Result, published: tuple[float, int, str]) -> None:
        value, decimals, source = published
        if not self.verified(res):
            self.add("published", subject, True, "no verified multiplier to compare", res, skipped=True)
            return
        ok = abs(res.multiplier - value) <= 0.5 * 10.0**-decimals
        self.add("published", subject, ok, f"lam = {res.multiplier:.10g} {'rounds' if ok else 'does not round'} to "
                 f"{value:.{decimals}f} ({source})", res)

    # ------------------------------------------------------------------ the other runs

    def check_impossible_case(self) -> None:
        res = self.solve("impossible", "overhang", _impossible_structure())
        if res is None:
            return
        ok = not res.status.is_success
        self.add("impossible", "overhang", ok, f"{res.status.value}" if ok else f"claims {res.status.value} (lam = "
                 f"{_fmt(res.multiplier)}) on a structure no load multiplier holds: a block overhanging its only "
                 "support, mu = 0.5 (the static LP (1) is infeasible)", res)

    def check_time_limit(self, case: ReferenceCase) -> None:
        res = self.solve("time-limit", case.label, case.structure, time_limit=EXPIRED_TIME_LIMIT_S)
        if res is None:
            return
        if res.status is not Status.TIME_LIMIT:
            message = (f"returned {res.status.value} although its deadline (time_limit={EXPIRED_TIME_LIMIT_S:g} s) had "
                       "passed before the run began: stop when deadline.expired() and return Status.TIME_LIMIT")
        elif res.solve_time_s > EXPIRED_DEADLINE_SLACK_S:
            message = (f"returned time_limit only after {res.solve_time_s:.3g} s past its deadline (allowed "
                       f"{EXPIRED_DEADLINE_SLACK_S:g} s): check the deadline before each costly step")
        else:
            message = ""
        self.add("time-limit", case.label, not message, message or f"time_limit after {res.solve_time_s:.2g} s", res)

    def check_invariance(self, case: ReferenceCase, base: Result | None) -> None:
        if base is None:
            for check in (*_TRANSFORMS, "user-units"):
                self.add(check, case.label, True, "no result on the base case", skipped=True)
            return
        self.check_user_units(case.label, case.structure, base)
        for check, transform in _TRANSFORMS.items():
            subject = f"{case.label} {check.partition('.')[2]}"
            structure = transform(case.structure)
            res = self.solve(check, subject, structure)
            if res is None:
                continue
            problems = []
            if res.status is not base.status:
                problems.append(f"status {res.status.value}, {base.status.value} before")
            if self.verified(res) != self.verified(base):
                problems.append(f"verified {self.verified(res)}, {self.verified(base)} before")
            if _finite(res.multiplier) and _finite(base.multiplier) and \
                    abs(res.multiplier - base.multiplier) > self.tol(base.multiplier):
                problems.append(f"lam = {res.multiplier:.12g}, {base.multiplier:.12g} before")
            self.add(check, subject, not problems, "; ".join(problems) or
                     f"same status and lam (change {_change(res, base):.1g})", res)
            if check in ("invariance.mirror", "invariance.units"):
                self.check_user_units(subject, structure, res)

    def check_user_units(self, subject: str, structure: Structure, res: Result) -> None:
        """The balance of a point in equilibrium with a normalised mechanism (verified or a heuristic's)."""
        held = [res.residuals.get(k, math.inf) <= self.verify_tol for k in ("equilibrium", "normalisation")]
        if not (all(held) and _finite(res.multiplier)):
            self.add("user-units", subject, True, "no point in equilibrium with a normalised mechanism to read", res,
                     skipped=True)
            return
        force, moment, power = _balance(structure, res)
        worst = max(force, moment, power)
        self.add("user-units", subject, worst <= self.verify_tol, f"forces balance the loads to {force:.1g} (moments "
                 f"{moment:.1g}), live-load power of the mechanism 1 to {power:.1g}", res)


# ---------------------------------------------------------------------- helpers


def _float(v: Any) -> float:
    return float(v) if _finite(v) else math.nan


def _fmt(v: float | None) -> str:
    return "none" if v is None else f"{v:.10g}"


def _line(exc: Any) -> str:
    return " ".join(str(exc).split())


def _change(res: Result, base: Result) -> float:
    return abs(res.multiplier - base.multiplier) if _finite(res.multiplier) and _finite(base.multiplier) else 0.0


def _unverified(res: Result, tol: float) -> str:
    missing = [f for f in ("x", "u", "z_u", "z_f") if getattr(res.solution, f) is None]
    if not _finite(res.multiplier):
        missing.insert(0, "multiplier")
    if missing:
        return f"an incomplete point (no {', '.join(missing)}): (3) cannot be verified"
    if not res.residuals:
        return "no residuals"
    worst = max(res.residuals, key=lambda k: res.residuals[k] if math.isfinite(res.residuals[k]) else math.inf)
    return f"{worst} residual {res.residuals[worst]:.2g} > {tol:g}"


def _type_name(typ: Any) -> str:
    return getattr(typ, "__name__", str(typ))


def _wrong_values(typ: Any) -> list[Any]:
    """Values of the wrong kind for an option of type ``typ`` (none for a type without an obvious wrong kind)."""
    if isinstance(typ, str):  # an annotation left as text
        typ = {"float": float, "int": int, "bool": bool, "str": str}.get(typ.replace(" ", ""), typ)
    origin = typing.get_origin(typ)
    if origin is typing.Literal:
        return ["no-such-choice"]
    if origin is typing.Union or origin is types.UnionType:  # X | None: X's wrong values
        args = [a for a in typing.get_args(typ) if a is not type(None)]
        return _wrong_values(args[0]) if len(args) == 1 else []
    if typ is bool:
        return ["yes"]
    if typ in (int, float):
        return ["not-a-number"]
    if typ is str:
        return [12345]
    return []


def _trace_problems(trace: Any, solve_time: float) -> list[str]:
    if not isinstance(trace, list):
        return [f"trace must be a list of dicts; got {type(trace).__name__}"]
    bad = [i for i, rec in enumerate(trace) if not (isinstance(rec, dict) and {"iteration", "time_s"} <= set(rec))]
    if bad:
        return [f"trace record {bad[0]} lacks iteration or time_s (every record has both)"]
    times = [rec["time_s"] for rec in trace]
    iterations = [rec["iteration"] for rec in trace]
    problems = []
    if any(b < a for a, b in zip(times, times[1:])):
        problems.append("trace times decrease")
    if any(b < a for a, b in zip(iterations, iterations[1:])):
        problems.append("trace iterations decrease")
    if times and _finite(solve_time) and times[-1] > solve_time + 1e-6:
        problems.append(f"trace time {times[-1]:.3g} s beyond the solve time {solve_time:.3g} s (time_s is the time "
                        "elapsed in the run)")
    return problems


def _impossible_structure() -> Structure:
    """A block overhanging its only support (centroid at x = 1.5 over a support ending at x = 1), mu = 0.5: no
    load multiplier holds it (the moment needs lam = -1, the friction |lam| <= 0.5)."""
    polys = [[[0, -1], [1, -1], [1, 0], [0, 0]], [[0.5, 0], [2.5, 0], [2.5, 1], [0.5, 1]]]
    return make_structure(polys, [True, False], friction=0.5, name="overhang")


def _balance(structure: Structure, res: Result) -> tuple[float, float, float]:
    """Relative errors, in the structure's units and frame, of the balance of forces and of moments (about the
    origin) between the loads on the free blocks and the reported forces of their interfaces with fixed blocks, and
    of the live load's power ``f_l^T u = 1`` with the reported mechanism."""
    forces, lam = res.forces, float(res.multiplier)
    fixed = np.asarray(structure.fixed, bool)
    minus, plus = forces["minus"].to_numpy(), forces["plus"].to_numpy()
    start, end = forces[["start_x", "start_y"]].to_numpy(), forces[["end_x", "end_y"]].to_numpy()
    d = end - start
    nu = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    tau = np.column_stack([nu[:, 1], -nu[:, 0]])
    f = forces["shear"].to_numpy()[:, None] * tau + forces["normal"].to_numpy()[:, None] * nu  # plus on minus
    mid = 0.5 * (start + end)
    m = mid[:, 0] * f[:, 1] - mid[:, 1] * f[:, 0] + forces["moment"].to_numpy()
    sign = np.where(fixed[plus] & ~fixed[minus], 1.0, np.where(fixed[minus] & ~fixed[plus], -1.0, 0.0))
    total_f, total_m = (sign[:, None] * np.nan_to_num(f)).sum(axis=0), float((sign * np.nan_to_num(m)).sum())
    scale_f = scale_m = 0.0
    for point, load in _loads(structure, lam):
        total_f = total_f + load
        total_m += point[0] * load[1] - point[1] * load[0]
        scale_f += float(np.linalg.norm(load))
        scale_m += float(np.linalg.norm(point) * np.linalg.norm(load))
    power = _live_power(structure, res.mechanism)
    return float(np.linalg.norm(total_f)) / scale_f, abs(total_m) / scale_m, abs(power - 1.0)


def _loads(structure: Structure, lam: float):
    """``(point, force)`` of every load on a free block at multiplier ``lam``: weights and live body forces at the
    centroids, point loads (live ones times ``lam``)."""
    live = structure.live_direction * structure.live_factor
    for i in np.flatnonzero(~np.asarray(structure.fixed, bool)):
        w = structure.weight[i]
        yield structure.centroid[i], np.array([lam * live * w, -w])
    for pl in structure.point_loads:
        if not structure.fixed[pl.block]:
            yield np.asarray(pl.point, float), np.asarray(pl.force, float) * (lam if pl.kind == "live" else 1.0)


def _live_power(structure: Structure, mechanism) -> float:
    """``f_l^T u`` in the structure's units: the live body forces and live point loads times the block velocities."""
    u = {int(r.block): (r.u_x, r.u_y, r.rotation) for r in mechanism.itertuples()}
    live = structure.live_direction * structure.live_factor
    power = sum(live * structure.weight[b] * ux for b, (ux, _, _) in u.items())
    for pl in structure.point_loads:
        if pl.kind == "live" and pl.block in u:
            ux, uy, th = u[pl.block]
            c = structure.centroid[pl.block]
            power += pl.force[0] * (ux - th * (pl.point[1] - c[1])) + pl.force[1] * (uy + th * (pl.point[0] - c[0]))
    return float(power)
