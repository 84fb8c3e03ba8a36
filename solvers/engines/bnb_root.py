r"""The root LP of ``milp``'s branch and bound (:mod:`~blockmpec.solvers.engines.complementarity_bnb`), by the
interior point.

The lifted root LP is very degenerate (most copies are zero), so the dual simplex needs long on it; HiGHS's interior
point IPX without crossover solves it, and any row duals ``y`` give a bound by weak duality
(:func:`~blockmpec.solvers.engines.lifted_lp.dual_bound`), valid whatever the point.

``root_lp="ipm"`` (:meth:`RootLP.interior_root`).  With the ``rlt-full`` lifting the LP is solved in the null-space
coordinates of :mod:`~blockmpec.solvers.linalg.null_space` (the same LP with equilibrium and compatibility solved
once: fewer rows and columns, the same minimum).  Without them and with an incumbent, a first run leaves out the
moments' rows (X) (a relaxation: the LP of the ``rlt`` lifting), which closes most walls at a fraction of the cost.
The run on the whole LP then picks the *dormant* rows: the copy pair rows ``G_j x^(i) <= 0`` (``j != i``) whose dual
is zero within ``DORMANT_DUAL_TOL``; any subset of the rows is a relaxation, so leaving them out of the node LPs
keeps every bound valid, and a node whose point violates one wakes it.  A second run on the LP without the rows of
zero dual (a relaxation, smaller) may still close the root.  An interior point that gives no finite bound is run
once more with its crossover.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from blockmpec.solvers.engines.lifted_lp import DORMANT_DUAL_TOL, dual_bound
from blockmpec.solvers.engines.node_lp import InteriorPoint, NullSpaceNodes, interior_point

#: the root is closed when the interior point's dual bound is within this (times max(1, |incumbent|)) of the
#: incumbent (= CERTIFICATE_TOL of milp, which then checks the reported gap against the same tolerance)
INTERIOR_CLOSE_TOL = 1e-7
#: HiGHS's primal and dual feasibility tolerances of the interior point in null-space coordinates (at HiGHS's
#: default 1e-7 IPX left reduced costs up to 7e-8 on free columns, which give no bound)
NULL_SPACE_IPM_TOL = 1e-10
#: in null-space coordinates the second run (without the rows of zero dual) runs only when the first one's finite
#: bound is within this (times max(1, |incumbent|)) of the incumbent: farther, a relaxation of that LP cannot close it
NULL_SPACE_SETTLED_GAP = 1e-5


def meets(bound: float, target: float) -> bool:
    """The dual ``bound`` closes the root at the incumbent's ``target`` (finite) within ``INTERIOR_CLOSE_TOL``
    (times ``max(1, |target|)``); never without an incumbent."""
    return bool(np.isfinite(target) and target - bound <= INTERIOR_CLOSE_TOL * max(1.0, abs(target)))


class RootLP:
    """The root-LP methods of :class:`~blockmpec.solvers.engines.complementarity_bnb.ComplementarityBnB` (a mixin:
    it reads the search's lifted LP, its dormant rows and its deadline)."""

    def interior_solution(self, A, c, rl, ru, cl, cu, crossover: bool = False,
                          tolerance: float | None = None) -> InteriorPoint:
        """The LP by HiGHS's interior point within the search's deadline (one LP counted in ``n_lps``)."""
        self.n_lps += 1
        return interior_point(A, c, rl, ru, cl, cu, self.deadline, crossover, tolerance)

    def _interior_bound(self, A, c, rl, ru, cl, cu, tolerance: float | None = None) -> tuple:
        """``(dual bound, row duals)`` of the LP from the interior point without crossover, and, when that gives no
        finite bound and time is left, from a second run *with* crossover (``(-inf, None)`` if neither gives one)."""
        y = self.interior_solution(A, c, rl, ru, cl, cu, tolerance=tolerance).y
        bound = -np.inf if y is None else dual_bound(A, c, rl, ru, cl, cu, y)
        if bound == -np.inf and not self.deadline.expired():
            self.crossover_runs += 1
            y2 = self.interior_solution(A, c, rl, ru, cl, cu, crossover=True, tolerance=tolerance).y
            bound2 = -np.inf if y2 is None else dual_bound(A, c, rl, ru, cl, cu, y2)
            if y is None or bound2 > bound:
                bound, y = bound2, y2
        return bound, y

    def interior_root(self, target: float = np.inf, record=None) -> float:
        """A lower bound on ``lam`` at the root (``root_lp="ipm"``, see the module docstring): the root LP, its
        bounds already applied by ``apply_node``.  ``target``: the incumbent's ``lam``; ``record(bound)`` (if given)
        is called with the bound so far after each run that gave one.  Returns the largest dual bound (``-inf``
        if none)."""
        t0 = time.perf_counter()
        A, c, rl, ru, cl, cu = self.lifted_matrix, *self.lp_arrays()
        late, to_lifted = self._late_rows, None
        reduced = self.null_space_root_lp(c, rl, ru, cl, cu) if self.root_lp == "ipm" else None
        if reduced is not None:
            A, c, rl, ru, cl, cu = reduced.arrays
            late, to_lifted = np.zeros(A.shape[0], dtype=bool), reduced.lifted_row
            self.null_space_root = True
            self.root_timing["null_space_build"] = time.perf_counter() - t0
        tolerance = NULL_SPACE_IPM_TOL if reduced is not None else None

        def without(drop: np.ndarray) -> float:
            keep = ~drop
            return self._interior_bound(sp.csc_array(sp.csr_array(A)[keep]), c, rl[keep], ru[keep], cl, cu,
                                        tolerance)[0]

        def note(value: float) -> None:
            if record is not None and np.isfinite(value):
                record(value)

        bound = -np.inf
        if late.any() and np.isfinite(target):
            bound = without(late)
            self.root_timing["ipm0"] = time.perf_counter() - t0
            note(bound)
        if not meets(bound, target):
            bound = self._whole_root(A, c, rl, ru, cl, cu, tolerance, to_lifted, bound, target, note, t0)
        if reduced is not None and self.null_space_nodes:
            self._to_null_space_nodes(reduced)
        self.ipm_time = self.root_timing["ipm"] = time.perf_counter() - t0
        self.ipm_bound = bound
        return bound

    def _whole_root(self, A, c, rl, ru, cl, cu, tolerance, to_lifted, bound: float, target: float, note,
                    t0: float) -> float:
        """The interior point on the whole root LP: its bound, the dormant rows its duals pick and, unless it
        settles the root, the second run without the rows of zero dual."""
        full, y = self._interior_bound(A, c, rl, ru, cl, cu, tolerance)
        if y is None:
            return bound
        bound = max(bound, full)
        self.root_timing["ipm1"] = time.perf_counter() - t0
        note(bound)
        y_lifted = y
        if to_lifted is not None:  # the pair rows are rows of both LPs, one to one
            y_lifted = np.zeros(self.lifted_matrix.shape[0])
            y_lifted[to_lifted[to_lifted >= 0]] = y[to_lifted >= 0]
        rows = self.dormant_candidates
        sleep = rows[np.abs(y_lifted[rows]) <= DORMANT_DUAL_TOL]
        self.dormant[sleep] = True
        self.nodes.set_row_bounds(sleep, np.full(sleep.size, -np.inf), np.full(sleep.size, np.inf))
        # in null-space coordinates a finite bound far below the incumbent is the LP's own: a relaxation of it
        # cannot close the root, so the time goes to branching
        settled = (to_lifted is not None and np.isfinite(full)
                   and target - full > NULL_SPACE_SETTLED_GAP * max(1.0, abs(target)))
        if not meets(bound, target) and not settled:
            drop = (np.isfinite(rl) ^ np.isfinite(ru)) & (np.abs(y) <= DORMANT_DUAL_TOL)
            keep = ~drop
            second = self._interior_bound(sp.csc_array(sp.csr_array(A)[keep]), c, rl[keep], ru[keep], cl, cu,
                                          tolerance)[0]
            bound = max(bound, second)
            note(bound)
        return bound

    def _to_null_space_nodes(self, reduced) -> None:
        """From here on every node LP is solved in null-space coordinates, the root's dormant rows sleeping in the
        sparse model (and, with ``node_lp="interior"``, held in the full one)."""
        _, row_lower, row_upper, _, _ = self.lp_arrays()
        sleeping = np.flatnonzero(self.dormant)
        if self.node_lp == "interior":
            self.dormant_free = False
        nodes = NullSpaceNodes.of(reduced, self.lifted_matrix, self.layout, self._changed_rows(), row_lower,
                                  row_upper, sleeping)
        if nodes is not None:
            nodes.use("full" if self.node_lp == "interior" else "sparse")
            self.nodes = nodes
            self.nodes_in_null_space = True

    def null_space_root_lp(self, c, rl, ru, cl, cu, basis: str = "tree"):
        """The root LP in the null-space coordinates of :mod:`~blockmpec.solvers.linalg.null_space` (the same LP,
        the same minimum), or None where the lifting does not allow it (not every force tied, copies without
        statics), the structure has no checked basis, or a row that should vanish there does not hold.

        Parameters
        ----------
        c, rl, ru, cl, cu : ndarray
            The lifted LP's cost and bounds (``lp_arrays``).
        basis : str
            The self-stress basis of :func:`~blockmpec.solvers.linalg.null_space.static_null_space`.
        """
        from blockmpec.solvers.linalg.null_space import layout_allows, null_space_lp, static_null_space

        if self.static_copies != "all" or not layout_allows(self.layout, self.form.n_pairs):
            return None
        space = static_null_space(self.form, basis)
        if space is None:
            return None
        try:
            return null_space_lp(self.lifted_matrix, c, rl, ru, cl, cu, self.layout, space)
        except ValueError:
            return None
