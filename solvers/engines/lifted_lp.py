r"""The lifted LP of ``milp``'s branch and bound: a level-one RLT relaxation of (4), and bounds from any row duals.

Notation of :mod:`blockmpec.formulations.mpec_milp`: ``w = (lam, x, u, z)``, pair rows ``G x <= 0`` with slacks
``s = -G x``, ``B = F - G_x^T`` (the friction work), and the work identity (W) at every solution of (3) in the
normalisation ``f_l^T u = 1``::

    lam = -f_d^T u + sum_e B_e x_{r_e} z_{i_e}.

Copies.  For each pair ``i`` with a copy let ``x^(i) := z_i x`` and ``zeta_i := z_i lam``.  Multiplying equilibrium
and ``G x <= 0`` by ``z_i >= 0``, and using ``s_i z_i = 0``::

    E x^(i) + zeta_i f_l + f_d z_i = 0,   G x^(i) <= 0,   G_i x^(i) = 0,   lam_lower z_i <= zeta_i <= lam_upper z_i,

so (W) becomes the *linear* ``lam = -f_d^T u + sum_e B_e x^(i_e)_{r_e}``.

Products with the mechanism (the ``lifting`` of ``milp``):

* (M) ``v := lam u`` and ``zeta_j := lam z_j`` for every pair: compatibility and ``f_l^T u = 1`` times ``lam``
  give ``E^T v + F zeta = 0`` and ``f_l^T v = lam``;
* (X) ``W[r, :] := x_r u`` for the tied forces ``r``: compatibility and ``f_l^T u = 1`` times ``x_r`` give
  ``E^T W[r, :] + sum_i F[:, i] x^(i)_r = 0`` and ``f_l^T W[r, :] = x_r``.  So for each ``r`` the vector
  ``(x^(i)_r)_i = x_r z`` is itself a compatible multiplier vector whose mechanism does live work ``x_r``: the
  copies are tied to *one* static field.

Every solution of (3) lifts (:meth:`Layout.lift`) to a point of every row, so the LP's minimum of ``lam`` is a
lower bound on (4), and so is the weak-duality value of any row duals (:func:`dual_bound`); an infeasible LP is
pruned only on a checked Farkas certificate (:func:`proves_infeasible`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

#: feasibility tolerance of the lifted LPs' answers: a reduced cost at most this in size on an unbounded side counts
#: as zero in :func:`dual_bound` (the standard every simplex LP of the search is held to)
LP_TOL = 1e-9
#: a row dual at most this (absolute, per-block units) counts as zero
DORMANT_DUAL_TOL = 1e-7
#: :func:`proves_infeasible`: a Farkas value must exceed this times the size of its terms
FARKAS_MARGIN = 1e-7


@dataclass
class Layout:
    """Where each block of the lifted LP sits: its columns and the rows the search changes."""

    n: int
    lam: int
    x: slice
    u: slice
    z: slice
    copies: list  # per copy: (pair i, x-slice or None, zeta column)
    static_pair_rows: np.ndarray  # row of G_j x in the static block, per pair j
    copy_pair_rows: dict  # pair j -> rows of G_j x^(i) over copies
    zeta_lower_rows: np.ndarray  # rows zeta_i - a z_i >= 0, per copy
    zeta_upper_rows: np.ndarray  # rows zeta_i - b z_i <= 0, per copy
    own_rows: np.ndarray  # row of G_i x^(i) in copy i (always active: s_i z_i = 0)
    copy_x: dict  # pair i -> x-slice of its copy
    v: slice | None = None  # lam u (lam_mechanism)
    w: slice | None = None  # W[t, k] = x_{tied[t]} u_k (force_mechanism)
    tied: np.ndarray | None = None
    tied_rows: np.ndarray | None = None  # rows (X) of x_{tied[t]}: tied_rows[t] (compatibility times x_r, then f_l^T u)

    def lift(self, lam: float, x: np.ndarray, u: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The lifted point of ``(lam, x, u, z)``: every product column set to its product (a point of (3) in the
        normalisation ``f_l^T u = 1`` satisfies every row of the lifted LP; the tests check it)."""
        out = np.zeros(self.n)
        out[self.lam], out[self.x], out[self.u], out[self.z] = lam, x, u, z
        for i, xi, zeta in self.copies:
            if xi is not None:
                out[xi] = z[i] * x
            out[zeta] = z[i] * lam
        if self.v is not None:
            out[self.v] = lam * u
        if self.w is not None:
            out[self.w] = np.outer(x[self.tied], u).ravel()
        return out


class _Rows:
    """The lifted LP's rows as they are added: sparse blocks of width ``n`` with their bounds."""

    def __init__(self, n: int) -> None:
        self.n, self.blocks, self.lo, self.hi, self.count = n, [], [], [], 0

    def add(self, M, lower, upper) -> np.ndarray:
        M = sp.csr_array(M)
        self.blocks.append(M)
        self.lo.append(np.broadcast_to(np.asarray(lower, float), (M.shape[0],)))
        self.hi.append(np.broadcast_to(np.asarray(upper, float), (M.shape[0],)))
        self.count += M.shape[0]
        return np.arange(self.count - M.shape[0], self.count)

    def place(self, M, start: int) -> sp.csr_array:
        M = sp.coo_array(M)
        return sp.csr_array((M.data, (M.row, M.col + start)), shape=(M.shape[0], self.n))

    def column(self, vec, c: int) -> sp.csr_array:
        vec = np.asarray(vec, float)
        return sp.csr_array((vec, (np.arange(vec.size), np.full(vec.size, c))), shape=(vec.size, self.n))

    def matrix(self) -> tuple[sp.csr_array, np.ndarray, np.ndarray]:
        A = sp.csr_array(sp.vstack(self.blocks, format="csr"))
        A.sum_duplicates()
        return A, np.concatenate(self.lo), np.concatenate(self.hi)


def _columns(form, B, all_copies: bool, lam_mechanism: bool, force_mechanism) -> dict:
    """The lifted LP's column layout: ``lam | x | u | z | (x^(i), zeta_i) per copy | zeta_j per bare pair | v | W``."""
    nx, nu, npair = form.x.stop - form.x.start, form.u.stop - form.u.start, form.n_pairs
    friction = set(int(i) for i in np.unique(B.col))
    xs = slice(1, 1 + nx)
    us = slice(xs.stop, xs.stop + nu)
    zs = slice(us.stop, us.stop + npair)
    col, copies = zs.stop, []
    for i in range(npair):
        if i in friction or all_copies:
            copies.append((i, slice(col, col + nx), col + nx))
            col += nx + 1
    vs = ws = tied = None
    if lam_mechanism:
        for i in range(npair):
            if not (i in friction or all_copies):
                copies.append((i, None, col))
                col += 1
        vs = slice(col, col + nu)
        col += nu
    if force_mechanism is not False and force_mechanism is not None:
        tied = np.arange(nx) if force_mechanism is True else np.asarray(force_mechanism, dtype=int)
        ws = slice(col, col + tied.size * nu)  # W[t, k] = x_{tied[t]} u_k at ws.start + t * nu + k
        col += tied.size * nu
    return dict(n=col, xs=xs, us=us, zs=zs, copies=copies, friction=friction, vs=vs, ws=ws, tied=tied)


def _copy_rows(R: _Rows, form, cols: dict, slack_max, static_copies: str, lam_lower: float, lam_upper: float):
    """Every copy's statics (equilibrium scaled by ``z_i``, pair rows, its own pair row) and its ``zeta`` rows;
    returns ``(copy_pair_rows, zeta_lower_rows, zeta_upper_rows, own_rows)``."""
    E, f_l, f_d, Gx = form.block(form.equilibrium, form.x), form.f_l, form.f_d, form.pair_matrix
    zs = cols["zs"]
    copy_pair_rows = {j: [] for j in range(form.n_pairs)}
    zeta_lower, zeta_upper, own = [], [], []
    for i, xi, zeta in cols["copies"]:
        if xi is not None and (static_copies == "all" or i in cols["friction"]):
            R.add(R.place(E, xi.start) + R.column(f_l, zeta) + R.column(f_d, zs.start + i), 0.0, 0.0)
            rows = R.add(R.place(Gx, xi.start), -np.inf, 0.0)
            for j in range(form.n_pairs):
                copy_pair_rows[j].append(rows[j])
            own.append(rows[i])
            if slack_max is not None:
                # s_j z_i <= slack_max_j z_i:  -G x^(i) - slack_max z_i <= 0
                R.add(R.place(-Gx, xi.start) - R.column(slack_max, zs.start + i), -np.inf, 0.0)
        # lam_lower z_i <= zeta_i <= lam_upper z_i
        zeta_lower.append(R.add(R.column([1.0], zeta) - R.column([lam_lower], zs.start + i), 0.0, np.inf)[0])
        zeta_upper.append(R.add(R.column([1.0], zeta) - R.column([lam_upper], zs.start + i), -np.inf, 0.0)[0])
    return ({j: np.array(r, dtype=int) for j, r in copy_pair_rows.items()}, np.array(zeta_lower),
            np.array(zeta_upper), np.array(own, dtype=int))


def _mechanism_rows(R: _Rows, form, cols: dict) -> np.ndarray | None:
    """Rows (M) (compatibility and ``f_l^T u = 1`` times ``lam``) and, with tied forces, rows (X); returns the rows
    (X) of each tied force (``tied_rows[t]``: compatibility times ``x_r``, then ``f_l^T u`` times ``x_r``)."""
    Ecomp, F, f_l = form.block(form.compatibility, form.u), form.block(form.compatibility, form.z), form.f_l
    copies, vs = cols["copies"], cols["vs"]
    zeta_of = np.array([next(c[2] for c in copies if c[0] == j) for j in range(form.n_pairs)])
    Fc = sp.coo_array(F)
    # lam (E^T u + F z) = 0:  E^T v + F zeta = 0 ;  lam f_l^T u = lam:  f_l^T v - lam = 0
    R.add(R.place(Ecomp, vs.start) + sp.csr_array((Fc.data, (Fc.row, zeta_of[Fc.col])), shape=(Fc.shape[0], R.n)),
          0.0, 0.0)
    R.add(R.place(f_l.reshape(1, -1), vs.start) - R.column([1.0], 0), 0.0, 0.0)
    tied = cols["tied"]
    if tied is None:
        return None
    nt, ncomp, ws = tied.size, Fc.shape[0], cols["ws"]
    copy_x = {i: xi for i, xi, _ in copies if xi is not None}
    I_t = sp.identity(nt, format="csr")
    # x_r (E^T u + F z) = 0:  E^T W[r, :] + sum_i F[:, i] x^(i)_r = 0   (rows t * ncomp + q, r = tied[t])
    rr = (np.arange(nt)[:, None] * ncomp + Fc.row[None, :]).ravel()
    cc = (np.array([copy_x[int(i)].start for i in Fc.col])[None, :] + tied[:, None]).ravel()
    vv = np.broadcast_to(Fc.data[None, :], (nt, Fc.nnz)).ravel()
    compat = R.add(R.place(sp.kron(I_t, Ecomp), ws.start) + sp.csr_array((vv, (rr, cc)), shape=(nt * ncomp, R.n)),
                   0.0, 0.0)
    # x_r (f_l^T u - 1) = 0:  f_l^T W[r, :] - x_r = 0
    nx = form.x.stop - form.x.start
    pick = sp.csr_array((np.ones(nt), (np.arange(nt), tied)), shape=(nt, nx))
    norm = R.add(R.place(sp.kron(I_t, f_l.reshape(1, -1)), ws.start) - R.place(pick, cols["xs"].start), 0.0, 0.0)
    return np.hstack([compat.reshape(nt, ncomp), norm[:, None]])


def lifted_lp(form, B: sp.coo_array, lam_lower: float, lam_upper: float, slack_max: np.ndarray | None = None,
              all_copies: bool = False, lam_mechanism: bool = False, force_mechanism=False,
              static_copies: str = "all"):
    """The lifted relaxation's matrices: ``(A, row_lower, row_upper, col_lower, col_upper, c, layout)``.

    ``all_copies``: a static copy ``x^(i)`` for every pair (not only the friction pairs of ``B``);
    ``lam_mechanism``: the products ``v = lam u`` and ``zeta_j = lam z_j`` for every pair (a bare ``zeta_j`` where
    pair ``j`` has no copy) with the rows (M); ``force_mechanism`` (needs both; ``True`` or the tied forces): the
    products ``W = x u^T`` with the rows (X).  ``static_copies="friction"``: the copies of the other pairs are bare
    products (columns of the rows (X) only, without their own statics).  ``slack_max``: the rows
    ``s_j z_i <= slack_max_j z_i`` in every copy.
    """
    if force_mechanism is not False and force_mechanism is not None and not (all_copies and lam_mechanism):
        raise ValueError("force_mechanism needs all_copies and lam_mechanism")
    cols = _columns(form, B, all_copies, lam_mechanism, force_mechanism)
    n, xs, us, zs = cols["n"], cols["xs"], cols["us"], cols["zs"]
    R = _Rows(n)
    # static: E x + lam f_l = -f_d ; G x <= 0 ; kinematic: E^T u + F z = 0 ; f_l^T u = 1
    R.add(R.place(form.block(form.equilibrium, form.x), xs.start) + R.column(form.f_l, 0), -form.f_d, -form.f_d)
    static_pair_rows = R.add(R.place(form.pair_matrix, xs.start), -np.inf, 0.0)
    R.add(R.place(form.block(form.compatibility, form.u), us.start)
          + R.place(form.block(form.compatibility, form.z), zs.start), 0.0, 0.0)
    R.add(R.place(form.f_l.reshape(1, -1), us.start), 1.0, 1.0)
    copy_pair_rows, zeta_lower, zeta_upper, own = _copy_rows(R, form, cols, slack_max, static_copies, lam_lower,
                                                             lam_upper)
    tied_rows = _mechanism_rows(R, form, cols) if lam_mechanism else None
    copy_x = {i: xi for i, xi, _ in cols["copies"] if xi is not None}
    # work identity: lam + f_d^T u - sum_e B_e x^(i_e)_{r_e} = 0
    starts = np.array([copy_x[int(i)].start for i in B.col]) + B.row
    identity = R.column([1.0], 0) + R.place(form.f_d.reshape(1, -1), us.start) \
        - sp.csr_array((B.data, (np.zeros(B.nnz, dtype=int), starts)), shape=(1, n))
    R.add(identity, 0.0, 0.0)
    A, lo, hi = R.matrix()
    col_lower, col_upper = np.full(n, -np.inf), np.full(n, np.inf)
    col_lower[zs] = 0.0
    col_lower[0], col_upper[0] = lam_lower, lam_upper
    c = np.zeros(n)
    c[0] = 1.0
    layout = Layout(n, 0, xs, us, zs, cols["copies"], static_pair_rows, copy_pair_rows, zeta_lower, zeta_upper, own,
                    copy_x, cols["vs"], cols["ws"], cols["tied"], tied_rows)
    return A, lo, hi, col_lower, col_upper, c, layout


# ---------------------------------------------------------------------------------------------- bounds from duals
def _sign_cleaned(A, c, row_lower, row_upper, col_lower, col_upper, y) -> tuple:
    """``(y, d, open)``: the row duals with every entry of the wrong sign for its row set to 0 (a one-sided row's,
    a free row's), the reduced costs ``d = c - A^T y`` and the columns whose ``d`` points at an open bound (a
    positive ``d`` on a column without lower bound, a negative one without upper bound)."""
    lower_open, upper_open = ~np.isfinite(row_lower), ~np.isfinite(row_upper)
    y = np.array(y, dtype=float)
    y[lower_open & (y > 0)] = 0.0
    y[upper_open & (y < 0)] = 0.0
    y[lower_open & upper_open] = 0.0
    d = c - A.T @ y
    unbounded = ((d > 0) & ~np.isfinite(col_lower)) | ((d < 0) & ~np.isfinite(col_upper))
    return y, d, unbounded


def open_reduced_cost(A, c, row_lower, row_upper, col_lower, col_upper, y) -> float:
    """The largest reduced cost towards an open column bound left by the row duals ``y`` (signs cleaned as in
    :func:`dual_bound`): above ``LP_TOL`` the uncorrected dual bound is ``-inf``."""
    _, d, unbounded = _sign_cleaned(sp.csc_array(A), c, row_lower, row_upper, col_lower, col_upper, y)
    return float(np.abs(d[unbounded]).max(initial=0.0))


def dual_bound(A, c, row_lower, row_upper, col_lower, col_upper, y, tol: float = LP_TOL,
               correct: bool = True) -> float:
    r"""A lower bound on ``min c^T w`` s.t. ``row_lower <= A w <= row_upper``, ``col_lower <= w <= col_upper``
    from row duals ``y`` (any ``y``; weak duality).

    With ``d = c - A^T y``, for every feasible ``w``: ``c^T w = y^T (A w) + d^T w >=
    sum_r min_{t in [l_r, u_r]} y_r t + sum_j min_{w_j in [cl_j, cu_j]} d_j w_j``.  ``y_r`` of the wrong
    sign for a one-sided row is set to 0 first (its term would be ``-inf``).  The interior point's ``y``
    leaves small reduced costs ``d_j`` on the free columns (about 1e-9); ``correct``: where they give
    ``-inf``, a least-squares correction of ``y`` on the equality rows and the inequality rows with
    ``|y_r| > DORMANT_DUAL_TOL`` is tried (kept only if its bound is larger).  A reduced cost at most ``tol`` in size on an unbounded side counts
    as zero, the dual feasibility tolerance under which every simplex LP of this engine is accepted
    as optimal (so this bound is held to the standard of the simplex bounds, not beyond);
    a larger one gives ``-inf``.
    """
    A = sp.csc_array(A)
    lower_open, upper_open = ~np.isfinite(row_lower), ~np.isfinite(row_upper)
    col_lower_open, col_upper_open = ~np.isfinite(col_lower), ~np.isfinite(col_upper)

    def value(y):
        y, d, unbounded = _sign_cleaned(A, c, row_lower, row_upper, col_lower, col_upper, y)
        if np.abs(d[unbounded]).max(initial=0.0) > tol:
            return -np.inf, y, d
        with np.errstate(invalid="ignore"):
            rows = np.where(y > 0, y * np.where(lower_open, 0.0, row_lower),
                            np.where(y < 0, y * np.where(upper_open, 0.0, row_upper), 0.0))
            cols = np.where(unbounded, 0.0, np.where(d > 0, d * np.where(col_lower_open, 0.0, col_lower),
                                                     np.where(d < 0, d * np.where(col_upper_open, 0.0, col_upper),
                                                              0.0)))
        return float(rows.sum() + cols.sum()), y, d

    best, y, d = value(np.asarray(y, float))
    if correct and best == -np.inf:  # (measured: where the plain bound was finite, the correction moved it by 3e-9)
        from scipy.sparse.linalg import lsqr

        # columns whose reduced cost should vanish: the free ones and every one with a small reduced cost (lam's
        # among them: its small d times its bounds was measured to cost 4e-7 of the bound on the 4x3 wall)
        cols = (col_lower_open & col_upper_open) | (np.abs(d) <= 1e-5)
        rows = ~(lower_open | upper_open) | ((lower_open ^ upper_open) & (np.abs(y) > DORMANT_DUAL_TOL))
        M = sp.csr_array(A[:, cols])[rows].T
        y2 = y.copy()
        y2[rows] += lsqr(M, d[cols], atol=1e-16, btol=1e-16, iter_lim=200)[0]
        best = max(best, value(y2)[0])
    return best


def proves_infeasible(A, row_lower, row_upper, col_lower, col_upper, ray) -> bool:
    r"""Whether ``ray`` (row multipliers, either sign) proves ``row_lower <= A w <= row_upper``,
    ``col_lower <= w <= col_upper`` infeasible (Farkas).

    For every feasible ``w`` and any ``y``: ``0 = y^T A w - (A^T y)^T w >= sum_r min_{[l_r, u_r]} y_r t +
    sum_j min_{[cl_j, cu_j]} (-A^T y)_j w_j``, the dual bound of the zero objective (:func:`dual_bound` with
    ``c = 0``); a positive value is a contradiction.  ``y`` is scaled to ``max |y_r| = 1`` and the value must
    exceed ``FARKAS_MARGIN`` times the size of its terms, so round-off cannot make a proof.  Reduced costs of at
    most ``LP_TOL`` on an unbounded side count as zero, as in every bound of this engine."""
    ray = np.asarray(ray, float)
    size = np.abs(ray).max(initial=0.0)
    if not np.isfinite(size) or size == 0.0:
        return False
    A = sp.csc_array(A)
    zero = np.zeros(A.shape[1])
    for y in (ray / size, -ray / size):
        value = dual_bound(A, zero, row_lower, row_upper, col_lower, col_upper, y, correct=False)
        if not np.isfinite(value):
            continue
        y_clean, d, _ = _sign_cleaned(A, zero, row_lower, row_upper, col_lower, col_upper, y)
        bounds = np.where(np.isfinite(row_lower), np.abs(row_lower), 0.0) + np.where(np.isfinite(row_upper),
                                                                                     np.abs(row_upper), 0.0)
        cols = np.where(np.isfinite(col_lower), np.abs(col_lower), 0.0) + np.where(np.isfinite(col_upper),
                                                                                  np.abs(col_upper), 0.0)
        scale = float(np.abs(y_clean) @ bounds + np.abs(d) @ cols) + 1.0
        if value > FARKAS_MARGIN * scale:
            return True
    return False
