"""Cross-checks between methods: :func:`assert_methods_agree`."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from blockmpec.geometry import Structure
from blockmpec.registry import get_solver
from blockmpec.result import Result
from blockmpec.solver import run_solver


def _label(name: str, options: dict[str, Any]) -> str:
    return f"{name}[{','.join(f'{k}={v}' for k, v in options.items())}]" if options else name


def assert_methods_agree(structure: Structure, methods: Iterable[str | tuple[str, dict[str, Any]]],
                         rtol: float = 1e-6, *, verify_tol: float = 1e-6) -> dict[str, Result]:
    """Solve ``structure`` with each method and assert that the answers agree.

    They agree when

    * every method returns a verified success (:attr:`blockmpec.Result.success` at ``verify_tol``);
    * the multipliers of the methods of one problem agree: ``|lam_a - lam_b| <= rtol * max(|lam_a|, |lam_b|)``
      (the associative multiplier is unique; for the non-associative problem, whose solutions need not be, choose
      methods that should find the same one, such as two that seek the minimum);
    * no non-associative multiplier exceeds an associative one by more than that (the forces of every solution of
      (3) are admissible for the static LP (1)).

    Parameters
    ----------
    structure : Structure
    methods : iterable
        Method names (registered or ``"module:Class"``), or ``(name, options)`` pairs.
    rtol : float
        Relative tolerance of the multipliers (the default suits verified points: their multipliers are exact to
        about ``verify_tol``).
    verify_tol : float
        Passed to :func:`blockmpec.run_solver`.

    Returns
    -------
    dict
        Label (``name`` or ``name[k=v,...]``) -> :class:`~blockmpec.Result`, for further checks.

    Raises
    ------
    AssertionError
        Naming each method that failed or disagrees, with every method's status and multiplier.

    Examples
    --------
    >>> import blockmpec as bm
    >>> from blockmpec.testing import assert_methods_agree
    >>> results = assert_methods_agree(bm.cases.wall(4, 2, bond="stack"), ["milp", "nlp", "static-lp"])  # doctest: +SKIP
    """
    runs = [(m, {}) if isinstance(m, str) else (m[0], dict(m[1] or {})) for m in methods]
    if not runs:
        raise ValueError("methods: give at least one method")
    results = {_label(n, o): run_solver(get_solver(n)(**o), structure, verify_tol=verify_tol) for n, o in runs}
    problems = [f"{label} did not succeed: {res.status.value} ({' '.join(res.message.split())})"
                for label, res in results.items() if not res.success]
    good = {label: res for label, res in results.items() if res.success}
    by_problem: dict[str, dict[str, float]] = {}
    for label, res in good.items():
        by_problem.setdefault(res.problem, {})[label] = float(res.multiplier)
    for problem, lams in by_problem.items():
        first = next(iter(lams))
        for label, lam in lams.items():
            if abs(lam - lams[first]) > rtol * max(abs(lam), abs(lams[first])):
                problems.append(f"{label} (lam = {lam:.12g}) and {first} (lam = {lams[first]:.12g}) disagree "
                                f"beyond rtol = {rtol:g} on the {problem} problem")
    for label, lam in by_problem.get("non-associative", {}).items():
        for other, upper in by_problem.get("associative", {}).items():
            if lam > upper + rtol * max(abs(lam), abs(upper)):
                problems.append(f"{label} (lam = {lam:.12g}) is above the associative multiplier of {other} "
                                f"({upper:.12g}): no solution of (3) lies above it")
    if problems:
        table = "; ".join(f"{label}: {res.status.value}, lam = {res.multiplier}" for label, res in results.items())
        raise AssertionError(f"methods disagree on {structure.name}: " + "; ".join(problems) + f" [{table}]")
    return results
