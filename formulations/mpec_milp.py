r"""The MPEC (4) as a mixed-integer program, built from the compiled MCP (3).

Everything here is read from :class:`~blockmpec.formulations.compiled.CompiledMCP`
(``form``): ``A w = rhs`` (equilibrium | compatibility | normalisation), the pair
rows ``G w <= 0`` with slacks ``s = -G w`` and multipliers ``w[pair_column]``,
``pair_kind`` and ``pair_interface``.  No operator is read and no stride is
computed.  Problem (4) is ``min lam`` over the solutions of (3)
(``sense="max"``: ``max lam`` over the same set); every constraint below is a
property of that *set*, so it holds for both senses.

Normalisation (why the multipliers have provable bounds)
--------------------------------------------------------
``(u, z)`` enter (3) homogeneously except for ``f_l^T u = 1``, and ``z != 0`` at
every solution (``z = 0`` gives ``E^T u = 0``, so ``u = 0`` for a structure tied
to its fixed blocks, against ``f_l^T u = 1``).  Dividing ``(u, z)`` by ``1^T z``
maps every solution to ::

    1^T z = 1,    tau := f_l^T u > 0,                                      (N)

and back (divide by ``tau``).  Under (N) ``0 <= z_i <= 1`` *exactly*: the
multiplier bound is a consequence of the normalisation, not a big-M.  The model
keeps ``tau >= tau_min``: ``tau_min = 0`` gives a **relaxation** of (4) (its
optimum is a certified bound), ``tau_min > 0`` a restriction (every point solves (3)).

Complementarity
---------------
One binary ``y_i`` per pair, ::

    s_i <= M_i (1 - y_i),     z_i <= zmax_i y_i.

``M_i`` (the only big-M) is *data proven by LPs* (:class:`MPECBounds`):
``M_i >= max s_i`` over the statically admissible set ``S`` (which contains the
force part of every solution of (3)).  ``zmax_i = max z_i`` over the kinematic
set ``K = {compatibility, 1^T z = 1, z >= 0}`` (``<= 1``).  A slack at its ``M_i``
in the answer means the bound was not proven (the solver then voids the certificate).

Valid cuts
----------
*Work identity.*  Let ``E = A[equilibrium, x]`` (so ``A[compatibility, u] = E^T``,
checked when the model is built), ``F = A[compatibility, z]`` and
``G_x = G[:, x]``.  Multiply equilibrium ``E x + lam f_l = -f_d`` by ``u`` and use
compatibility ``E^T u = -F z``: ``lam tau = -f_d^T u + x^T F z``.  Complementarity
gives ``x^T G_x^T z = -s^T z = 0``, so with ``B := F - G_x^T`` ::

    lam tau = -f_d^T u + x^T B z.                                        (W)

``B`` is zero for associative flow; for Coulomb friction its only entries are
``B[n_k, z_f(k, +-)] = -(tan phi_k - tan psi_k)``, so ``x^T B z =
sum_k (tan phi_k - tan psi_k)(-n_k)(z_f+ + z_f-)_k >= 0`` (the friction work;
``n_k <= 0`` follows from the two friction rows).  ``B`` is computed from the
compiled matrices, not from a formula, so cohesion-free variants stay exact.

* ``dead_work_cut``: ``-f_d^T u <= lam_upper tau`` ((W), ``x^T B z >= 0``,
  ``lam <= lam_upper``).
* ``dead_work_lower``: ``-f_d^T u >= lam_kinematic tau`` (``lam_kinematic`` is
  the optimum of the bounded LP ``min -f_d^T u`` over compatibility, ``f_l^T u = 1``,
  ``z >= 0``; bounded, so the inequality holds on its whole cone, also at ``tau = 0``).
* ``work_envelope`` (``envelope=True``): (W) with its bilinear terms relaxed
  by McCormick envelopes.  Each product ``p_e = x_r z_i`` (one per entry of ``B``)
  with ``x_r in [L_r, U_r]`` (OBBT: LPs over ``S``) and ``z_i in [0, zmax_i]``::

      p >= L z,   p <= U z,   p >= U z + zmax (x - U),   p <= L z + zmax (x - L)

  (from ``(x - L) z >= 0``, ``(U - x) z >= 0``, ``(U - x)(zmax - z) >= 0``,
  ``(x - L)(zmax - z) >= 0``), and ``q = lam tau`` with ``lam in [lam_lower, lam_upper]``,
  ``tau in [0, tau_max]``::

      q >= lam_lower tau,   q >= lam_upper tau + tau_max (lam - lam_upper),
      q <= lam_upper tau,   q <= lam_lower tau + tau_max (lam - lam_lower),

  and the linear row ``q = -f_d^T u + sum_e B_e p_e``.  Every point of (3) in
  normalisation (N) satisfies all of them with ``p_e = x_r z_i`` and ``q = lam tau``.
* ``sliding_direction``: at most one sliding pair per interface
  (``y_+ + y_- <= 1``).  Both friction rows active means
  ``t = n = 0``, hence ``m = 0`` and both rocking rows active; the common part
  ``min(z_+, z_-)`` of the two sliding multipliers is a pure opening that the
  rocking pair reproduces, so every solution of (3) has a representative with one
  sliding direction.  Without it ``z_+ = z_- = 1/2``, ``u = 0`` would satisfy the
  normalised system when ``psi = 0``: a spurious point with ``tau = 0``.

Column bounds ``lam_lower <= lam <= lam_upper`` hold at every solution of (3)
(``lam_upper``: the associative multiplier bounds every non-associative one,
``x`` being statically admissible; ``lam_lower``: ``min lam`` over ``S`` or ``lam_kinematic``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.formulations.compiled import FRICTION, CompiledMCP
from blockmpec.formulations.pyomo_compile import LinearProgram

__all__ = ["MPECBounds", "MixedIntegerMPEC", "work_matrix", "mpec_milp"]


@dataclass(frozen=True)
class MPECBounds:
    """Bounds valid at every solution of (3) (in normalisation (N)), each proven by an LP.

    Attributes
    ----------
    lam_associative : float
        ``max lam`` over ``S`` (the associative multiplier; an upper bound on every solution).
    lam_static_min : float
        ``min lam`` over ``S``.
    lam_kinematic : float or None
        ``min -f_d^T u`` over the non-associative kinematic set with ``f_l^T u = 1`` (None: unbounded).
    lam_dissipation : float or None
        The work identity's LP bound (friction work bounded below by conditional OBBT on ``n``;
        :meth:`blockmpec.solvers.milp.MILPSolver._dissipation_minimum`).
    lam_lower, lam_upper : float
        Column bounds of ``lam``: the LP optima widened by their round-off margin.
    slack_max : ndarray, shape (4c,)
        Proven ``max s_i`` over ``S`` (widened); ``M_i`` of the big-M rows.
    z_max : ndarray, shape (4c,)
        ``max z_i`` over the kinematic set ``K`` (widened, ``<= 1``).
    tau_max : float
        ``max f_l^T u`` over ``K`` (widened; ``inf`` when unbounded).
    x_lower, x_upper : ndarray, shape (3c,)
        Bounds of ``x`` over ``S`` (``-inf``/``inf`` where no LP was solved); the
        work envelope reads the entries of ``x`` that multiply a ``z`` in ``B``.
    x_associative : ndarray
        ``x`` at the associative optimum.
    product_lower, product_upper : ndarray, shape (nnz(B),) or None
        For each entry ``(r, i)`` of :func:`work_matrix` (in its order): bounds of ``x_r`` over
        ``S ∩ {s_i = 0}`` (the pair active).  Valid for the product: ``z_i > 0`` forces ``s_i = 0``
        and ``z_i = 0`` makes ``p = 0``, so ``lo z_i <= x_r z_i <= hi z_i`` at every solution
        (conditional OBBT; a sliding joint that must carry load gets ``hi < 0``: dissipation ``> 0``).
    verified : bool
        Every LP behind the record reported optimal (False: the record must not certify).
    models_complete : bool
        Every ``slack_max`` and ``z_max`` was proven by its LP (False: some are the trivial ``inf`` or 1, left when
        their LPs ran out of time or failed; the big-M model needs every ``slack_max`` finite).
    n_lps : int
    time_s : float
    """

    lam_associative: float
    lam_static_min: float
    lam_kinematic: float | None
    lam_dissipation: float | None
    lam_lower: float
    lam_upper: float
    slack_max: np.ndarray
    z_max: np.ndarray
    tau_max: float
    x_lower: np.ndarray
    x_upper: np.ndarray
    x_associative: np.ndarray
    product_lower: np.ndarray | None = None
    product_upper: np.ndarray | None = None
    verified: bool = True
    models_complete: bool = True
    n_lps: int = 0
    time_s: float = 0.0


@dataclass(kw_only=True)
class MixedIntegerMPEC(LinearProgram):
    r"""A :class:`~blockmpec.formulations.pyomo_compile.LinearProgram` with ``v[integer] in Z``.

    ``v = (w, extra columns)`` where ``w`` is the compiled MCP's vector (so ``v[form.lam]``
    is ``lam``); ``columns`` names the extra ones (``y``, ``tau``, ``p``, ``q``),
    ``rows`` the row groups.  ``objective_sign`` is -1 for ``sense="max"`` (``c = -e_lam``).
    """

    integer: np.ndarray
    bigm: np.ndarray
    work_products: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    @property
    def n_columns(self) -> int:
        return self.c.size


def work_matrix(form: CompiledMCP) -> sp.coo_array:
    """``B = F - G_x^T`` of identity (W) (rows: ``x``, columns: ``z``); checks ``A[compatibility, u] = E^T``."""
    E = form.block(form.equilibrium, form.x)
    Et = form.block(form.compatibility, form.u)
    diff = sp.csr_array(Et - E.T)
    if np.abs(diff.data).max(initial=0.0) > 1e-12 * max(1.0, np.abs(E.data).max(initial=0.0)):
        raise AssertionError("compiled MCP: compatibility's u block is not the transpose of equilibrium's x block")
    B = sp.csr_array(form.block(form.compatibility, form.z) - form.pair_matrix.T)
    B.data[np.abs(B.data) <= 1e-14 * max(1.0, np.abs(B.data).max(initial=0.0))] = 0.0
    B.eliminate_zeros()
    return B.tocoo()


class _Rows:
    """Accumulates sparse rows ``lo <= a^T v <= hi`` by groups."""

    def __init__(self, n_cols: int) -> None:
        self.n_cols = n_cols
        self.blocks: list[sp.csr_array] = []
        self.lo: list[np.ndarray] = []
        self.hi: list[np.ndarray] = []
        self.groups: dict[str, np.ndarray] = {}
        self.count = 0

    def add(self, name: str, M, lo, hi) -> None:
        M = sp.csr_array(M)
        assert M.shape[1] == self.n_cols, (name, M.shape)
        k = M.shape[0]
        self.blocks.append(M)
        self.lo.append(np.broadcast_to(np.asarray(lo, float), (k,)).copy())
        self.hi.append(np.broadcast_to(np.asarray(hi, float), (k,)).copy())
        self.groups[name] = np.arange(self.count, self.count + k)
        self.count += k

    def matrix(self) -> tuple[sp.csr_array, np.ndarray, np.ndarray]:
        A = sp.csr_array(sp.vstack(self.blocks, format="csr"))
        A.sum_duplicates()
        return A, np.concatenate(self.lo), np.concatenate(self.hi)


def _embed(M, n_cols: int, start: int = 0) -> sp.csr_array:
    """``M`` placed in columns ``start:start + M.shape[1]`` of an ``n_cols``-wide matrix."""
    M = sp.coo_array(M)
    return sp.csr_array((M.data, (M.row, M.col + start)), shape=(M.shape[0], n_cols))


def _entries(n_rows: int, n_cols: int, rows, cols, vals) -> sp.csr_array:
    rows, cols = np.asarray(rows, int), np.asarray(cols, int)
    vals = np.broadcast_to(np.asarray(vals, float), rows.shape)
    return sp.csr_array((vals, (rows, cols)), shape=(n_rows, n_cols))


def mpec_milp(form: CompiledMCP, bounds: MPECBounds, sense: str = "min", bigm: np.ndarray | None = None,
              envelope: bool = True, tau_min: float = 0.0) -> MixedIntegerMPEC:
    """Build the mixed-integer form of (4) described in the module docstring.

    Parameters
    ----------
    form : CompiledMCP
    bounds : MPECBounds
    sense : {"min", "max"}
    bigm : ndarray, shape (4c,), optional
        ``M_i`` (default ``bounds.slack_max``; the solver passes a scaled copy only to test detection).
    envelope : bool
        Add the McCormick relaxation of the work identity (W).
    tau_min : float
        Lower bound of ``tau = f_l^T u`` (0: relaxation of (4)).
    """
    if sense not in ("min", "max"):
        raise ValueError(f"sense must be 'min' or 'max'; got {sense!r}")
    nw, npair = form.n_columns, form.n_pairs
    M = np.asarray(bounds.slack_max if bigm is None else bigm, float)
    Bw = work_matrix(form) if envelope else None
    columns = {"y": np.arange(nw, nw + npair), "tau": np.array([nw + npair])}
    if envelope:
        columns["p"] = np.arange(nw + npair + 1, nw + npair + 1 + Bw.nnz)
        columns["q"] = np.array([nw + npair + 1 + Bw.nnz])
    n = nw + npair + 1 + (Bw.nnz + 1 if envelope else 0)
    tau = int(columns["tau"][0])
    lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
    lo[form.lam], hi[form.lam] = bounds.lam_lower, bounds.lam_upper
    lo[form.pair_column], hi[form.pair_column] = 0.0, bounds.z_max
    lo[tau] = tau_min
    if np.isfinite(bounds.tau_max):
        hi[tau] = bounds.tau_max
    lo[columns["y"]], hi[columns["y"]] = 0.0, 1.0
    integer = np.zeros(n, dtype=bool)
    integer[columns["y"]] = True
    R = _Rows(n)
    _mcp_rows(R, form, n, tau)
    _bigm_rows(R, form, n, columns["y"], M, bounds.z_max)
    _dead_work_rows(R, form, n, tau, bounds)
    products = _envelope_rows(R, form, n, columns, Bw, bounds) if envelope else None
    A, rl, ru = R.matrix()
    c = np.zeros(n)
    sign = 1.0 if sense == "min" else -1.0
    c[form.lam] = sign
    return MixedIntegerMPEC(c=c, A=A, row_lower=rl, row_upper=ru, col_lower=lo, col_upper=hi, integer=integer,
                            columns=columns, rows=R.groups, objective_sign=sign, bigm=M, work_products=products)


def _mcp_rows(R: _Rows, form: CompiledMCP, n: int, tau: int) -> None:
    """The rows of (3) in normalisation (N): equilibrium, compatibility, ``1^T z = 1``, ``f_l^T u = tau`` and the
    pair rows ``G w <= 0``."""
    eq, cp, nm = form.equilibrium, form.compatibility, form.normalisation
    R.add("equilibrium", _embed(form.A[eq], n), form.rhs[eq], form.rhs[eq])
    R.add("compatibility", _embed(form.A[cp], n), 0.0, 0.0)
    R.add("normalisation", _entries(1, n, np.zeros(form.n_pairs), form.pair_column, 1.0), 1.0, 1.0)
    # live work: f_l^T u - tau = 0 (the compiled normalisation row is f_l^T u)
    R.add("live_work", _embed(form.A[nm], n) - _entries(1, n, [0], [tau], 1.0), 0.0, 0.0)
    R.add("pairs", _embed(form.G, n), -np.inf, 0.0)


def _bigm_rows(R: _Rows, form: CompiledMCP, n: int, y: np.ndarray, M: np.ndarray, z_max: np.ndarray) -> None:
    """Complementarity by big-M: ``s_i <= M_i (1 - y_i)``, ``z_i <= zmax_i y_i``, and one sliding direction per
    interface (``y_+ + y_- <= 1``)."""
    npair = form.n_pairs
    G = _embed(form.G, n)
    # s_i <= M_i (1 - y_i):  -G_i w + M_i y_i <= M_i
    R.add("bigm", -G + _entries(npair, n, np.arange(npair), y, M), -np.inf, M)
    R.add("switch", _entries(npair, n, np.arange(npair), form.pair_column, 1.0)
          - _entries(npair, n, np.arange(npair), y, z_max), -np.inf, 0.0)
    by_interface: dict[int, list[int]] = {}
    for i in np.flatnonzero(form.pair_kind == FRICTION):
        by_interface.setdefault(int(form.pair_interface[i]), []).append(int(i))
    two = np.array([v for v in by_interface.values() if len(v) == 2])
    if two.size:
        R.add("sliding_direction", _entries(len(two), n, np.repeat(np.arange(len(two)), 2), y[two.ravel()], 1.0),
              -np.inf, 1.0)


def _dead_work_rows(R: _Rows, form: CompiledMCP, n: int, tau: int, bounds: MPECBounds) -> None:
    """``-f_d^T u <= lam_upper tau`` and, when bounded, ``-f_d^T u >= lam_kinematic tau``."""
    u_cols = np.arange(form.u.start, form.u.stop)
    dead = -form.f_d  # -f_d^T u is the dead-load work
    R.add("dead_work_cut", _entries(1, n, np.zeros(u_cols.size + 1), np.append(u_cols, tau),
                                    np.append(dead, -bounds.lam_upper)), -np.inf, 0.0)
    if bounds.lam_kinematic is not None:
        R.add("dead_work_lower", _entries(1, n, np.zeros(u_cols.size + 1), np.append(u_cols, tau),
                                          np.append(dead, -bounds.lam_kinematic)), 0.0, np.inf)


def _envelope_rows(R: _Rows, form: CompiledMCP, n: int, columns: dict, Bw, bounds: MPECBounds) -> tuple:
    """The work identity ``q = -f_d^T u + sum_e B_e p_e`` with McCormick envelopes of ``p_e = x_r z_i`` and
    ``q = lam tau``; returns ``(x_r columns, z_i columns, B_e)`` of the products."""
    p, q, tau = columns["p"], int(columns["q"][0]), int(columns["tau"][0])
    u_cols = np.arange(form.u.start, form.u.stop)
    xr, zi = form.x.start + Bw.row, form.z.start + Bw.col  # columns of x_r and z_i in w
    L, U = bounds.x_lower[Bw.row], bounds.x_upper[Bw.row]
    # the rows p >= L z and p <= U z may use the pair-active bounds (see MPECBounds)
    Lz = L if bounds.product_lower is None else np.maximum(L, bounds.product_lower)
    Uz = U if bounds.product_upper is None else np.minimum(U, bounds.product_upper)
    Z = bounds.z_max[Bw.col]
    ne = Bw.nnz
    R.add("work_identity", _entries(1, n, np.zeros(u_cols.size + ne + 1), np.concatenate([u_cols, p, [q]]),
                                    np.concatenate([form.f_d, -Bw.data, [1.0]])), 0.0, 0.0)

    def two(name, k, coef, lower, upper):  # rows p_k + coef z_k in [lower, upper]
        R.add(name, _entries(k.size, n, np.r_[np.arange(k.size), np.arange(k.size)], np.r_[p[k], zi[k]],
                             np.r_[np.ones(k.size), coef]), lower, upper)

    def three(name, k, cz, cx, lower, upper):  # rows p_k + cz z_k + cx x_k in [lower, upper]
        R.add(name, _entries(k.size, n, np.tile(np.arange(k.size), 3), np.r_[p[k], zi[k], xr[k]],
                             np.r_[np.ones(k.size), cz, cx]), lower, upper)

    k = np.flatnonzero(np.isfinite(Lz))
    two("envelope_lz", k, -Lz[k], 0.0, np.inf)  # p - L z >= 0
    k = np.flatnonzero(np.isfinite(Uz))
    two("envelope_uz", k, -Uz[k], -np.inf, 0.0)  # p - U z <= 0
    k = np.flatnonzero(np.isfinite(U))
    three("envelope_uzx", k, -U[k], -Z[k], -U[k] * Z[k], np.inf)  # p - U z - Z x >= -U Z
    k = np.flatnonzero(np.isfinite(L))
    three("envelope_lzx", k, -L[k], -Z[k], -np.inf, -L[k] * Z[k])  # p - L z - Z x <= -L Z
    # q = lam tau: McCormick with lam in [ll, lu], tau in [0, T]
    ll, lu, T, lam = bounds.lam_lower, bounds.lam_upper, bounds.tau_max, form.lam
    R.add("lam_tau_lower", _entries(1, n, [0, 0], [q, tau], [1.0, -ll]), 0.0, np.inf)
    R.add("lam_tau_upper", _entries(1, n, [0, 0], [q, tau], [1.0, -lu]), -np.inf, 0.0)
    if np.isfinite(T):
        R.add("lam_tau_lower_t", _entries(1, n, [0, 0, 0], [q, tau, lam], [1.0, -lu, -T]), -lu * T, np.inf)
        R.add("lam_tau_upper_t", _entries(1, n, [0, 0, 0], [q, tau, lam], [1.0, -ll, -T]), -np.inf, -ll * T)
    return xr, zi, Bw.data.copy()
