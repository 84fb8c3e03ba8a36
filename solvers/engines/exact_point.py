r"""The exact solution of (3) on the pattern of an approximate one.

A method that solves (3) to a tolerance (an interior point, a relaxed NLP, a Newton iteration) leaves products
``z_i s_i`` of the order of that tolerance, and its ``lam`` is that of no solution of (3).  Its *pattern*, the pairs
``i`` whose multiplier exceeds their slack (``z_i > s_i``, both in the units of the scaling), fixes one side of every
pair: on it (3) is linear, and the piece LP of :mod:`~blockmpec.solvers.engines.piece_lp` in its two halves,

* the static half ``min lam`` over the statically admissible ``(lam, x)`` with ``G_i x = 0`` on the pattern, and
* the kinematic half, a mechanism ``f_l^T u = 1`` with ``z_i >= 0`` on the pattern and ``z_i = 0`` elsewhere,

gives a point that satisfies every row of (3) and complementarity exactly (up to the LP's feasibility tolerance):
the exact solution next to the approximate one, with the least ``lam`` of its piece (never above that of an exact
point of the piece, hence at most the approximate ``lam`` plus the approximation's own error).
"""

from __future__ import annotations

import numpy as np

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status


def exact_point(form, scaling, w: np.ndarray, deadline: Deadline = NEVER) -> tuple[np.ndarray | None, str]:
    """The exact solution of (3) on the pattern of the approximate solution ``w`` (see the module docstring).

    Parameters
    ----------
    form : CompiledMCP
        Problem (3).
    scaling : MCPScaling
        The units of (3) (:meth:`LoadUnits.mcp <blockmpec.solvers.engines.scaling.LoadUnits.mcp>`) in which the
        pattern is read and the LPs are solved.
    w : ndarray
        The approximate solution, packed (:meth:`~blockmpec.formulations.compiled.CompiledMCP.pack`).
    deadline : Deadline
        When the two LPs stop.

    Returns
    -------
    tuple
        ``(w_exact, "")``, or ``(None, why)`` when a half has no optimal point (the pattern of ``w`` is not that of
        an exact solution: ``w`` is too far from one) or the deadline passed.
    """
    from blockmpec.solvers.engines.piece_lp import SplitPieces

    pieces = SplitPieces(form, scaling, deadline=deadline)
    z, s = pieces.sides(np.asarray(w, float))
    pattern = z > s
    static = pieces.static_lp(pattern)
    if static is None or static.status is not Status.OPTIMAL:
        return None, f"the static LP on the point's pattern is {'past the deadline' if static is None else static.raw_status}"
    mechanism = pieces.mechanism(pattern)
    if mechanism is None or mechanism.status is not Status.OPTIMAL:
        return None, (f"the mechanism LP on the point's pattern is "
                      f"{'past the deadline' if mechanism is None else mechanism.raw_status}")
    return pieces.point(static, mechanism), ""


def exact_solution(form, scaling, solution, deadline: Deadline = NEVER) -> tuple:
    """:func:`exact_point` of a :class:`~blockmpec.result.Solution`: ``(exact Solution, note)``, or ``(solution,
    note)`` unchanged when its pattern gives no exact point (the note says why, for the run's message)."""
    if solution is None or solution.multiplier is None:
        return solution, "no point to make exact"
    w, why = exact_point(form, scaling, form.pack(solution), deadline)
    if w is None:
        return solution, f"no exact solution of (3) on its pattern ({why}); the point is kept"
    exact = form.unpack(w)
    return exact, f"exact solution of (3) on its pattern: lam {solution.multiplier:.10g} -> {exact.multiplier:.10g}"
