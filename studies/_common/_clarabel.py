"""Clarabel (pip ``clarabel``, Apache-2.0; not a dependency of blockmpec) on a compiled LP, for the studies that
measure it side by side with the project's engines: ``lp_timing.py`` (the static LP) and ``root_lp_engines.py``
(``milp``'s root LP).

Imported by path (``sys.path`` holds ``studies/`` when a script runs), like ``_tables``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class ClarabelProblem:
    """``min c^T w`` s.t. ``row_lower <= A w <= row_upper``, ``col_lower <= w <= col_upper`` as Clarabel's
    ``min c^T w`` s.t. ``M w + s = q``, ``s`` in (zero cone of the equality rows) x (nonnegative cone of the
    one-sided rows and the column bounds): a ``>=`` row is ``-a w + s = -l``, a ``<=`` row ``a w + s = u``.
    Built once (set-up); :meth:`solve` returns the row duals in HiGHS's signs: ``-z`` on the rows written
    ``a w + s = u`` (equalities included), ``+z`` on the negated ones."""

    def __init__(self, A, c, row_lower, row_upper, col_lower, col_upper) -> None:
        try:
            import clarabel
        except ImportError:
            raise SystemExit("clarabel is not installed (pip install clarabel): it is not a dependency of blockmpec")
        self.clarabel = clarabel
        A = sp.csr_array(A)
        rl, ru, cl, cu = row_lower, row_upper, col_lower, col_upper
        eq = np.isfinite(rl) & np.isfinite(ru) & (rl == ru)
        lo, up = np.isfinite(rl) & ~eq, np.isfinite(ru) & ~eq
        n = A.shape[1]
        eye = sp.identity(n, format="csr")
        has_lower, has_upper = np.isfinite(cl), np.isfinite(cu)
        self.M = sp.csc_matrix(sp.vstack([A[eq], -A[lo], A[up], -eye[has_lower], eye[has_upper]]))
        self.q = np.concatenate([rl[eq], -rl[lo], ru[up], -cl[has_lower], cu[has_upper]])
        self.cones = [clarabel.ZeroConeT(int(eq.sum())),
                      clarabel.NonnegativeConeT(int(lo.sum() + up.sum() + has_lower.sum() + has_upper.sum()))]
        self.c = np.asarray(c, float)
        self.rows = A.shape[0]
        self._dual_signs = ((eq, -1.0), (lo, 1.0), (up, -1.0))

    def solve(self, **settings) -> tuple:
        """``(w, row duals in HiGHS's signs, Clarabel's status name, iterations)``; ``settings``: attributes of
        ``clarabel.DefaultSettings`` (output off unless ``verbose=True``)."""
        options = self.clarabel.DefaultSettings()
        options.verbose = False
        for name, value in settings.items():
            setattr(options, name, value)
        n = self.c.size
        sol = self.clarabel.DefaultSolver(sp.csc_matrix((n, n)), self.c, self.M, self.q, self.cones, options).solve()
        z = np.asarray(sol.z)
        y = np.zeros(self.rows)
        start = 0
        for mask, sign in self._dual_signs:
            k = int(mask.sum())
            y[mask] = sign * z[start:start + k]
            start += k
        return np.asarray(sol.x), y, str(sol.status), int(sol.iterations)
