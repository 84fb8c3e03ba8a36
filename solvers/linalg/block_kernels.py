r"""Compiled kernels (numba) for the block interior-point method's per-interface work.

Each iteration of :class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM` inverts one small augmented
matrix per interface, ``M_i = [[0, B_dual_i^T], [B_i, -I]]`` (``q = k + r``: 7 by 7 on a 2D wall), assembles
``K`` from the products ``a_i H_i^{-1} a_i^T``, and multiplies stacks of the inverses with right-hand sides
several times.  numpy does each of these as a gufunc loop that calls LAPACK or BLAS once per 7-by-7 block, whose
per-call overhead dominates: on 20,100 interfaces ``np.linalg.inv`` takes ~28 ms where one compiled loop takes
~9 ms.  The kernels here are those loops:

* :func:`inverse_blocks`: ``M_i^{-1}`` by Gauss--Jordan elimination with partial pivoting (the pivot of column
  ``j`` is the largest ``|M_{ij}|``, ``i >= j``, as in LAPACK's ``getrf``), row by row on ``[M_i | I]``;
  :func:`inverse_scaled_blocks` the same from the blocks of ``G`` and the scaling, ``M_i`` built in the loop;
* :func:`block_product`: ``X_i v_i`` for a stack of blocks;
* :func:`block_solve`: the block solves of a Newton step in one pass (the right-hand side gathered from the
  inequality rows, scaled, multiplied by ``M_i^{-1}``, and ``dy`` scattered back);
* :func:`max_step`: the step to the boundary of ``z + a dz >= 0`` in one pass (chunks on the usable CPUs: a maximum
  is exact in any order);
* :func:`reduced_values`: ``a_i H_i^{-1} a_i^T`` summed into ``K``'s data array by the scatter index, in the same
  order as ``np.bincount`` adds them;
* :class:`SparseProducts`: ``M x`` and ``M^T y`` for the LP's sparse matrices by row loops over ``M`` and over an
  explicit copy of ``M^T``, with the sums in scipy's order (the same numbers bit for bit), on the CPUs this process
  may use (scipy's products run on one).

:func:`inverse_scaled_blocks`, :func:`block_solve`, :class:`ReducedAssembly` and :class:`SparseProducts` run their
blocks (or rows) on the CPUs this process may use (numba's ``prange``; :func:`blockmpec.solvers.linalg.cpus.usable_cpus`).  Each
block is independent, so the numbers are the same on any number of threads.  In the block IPM they run while the
supernodal Cholesky's worker process waits, so its CPU is free.

They compute the same quantities as the numpy expressions they replace, with another rounding (Gauss--Jordan
instead of LU plus triangular solves): the results agree to round-off, so iterates may differ in late digits.
numba (BSD-2) is optional (``pip install "blockmpec[fast]"``): this module is imported only when the block IPM
chooses compiled kernels (its ``kernels`` setting).  The kernels are compiled on first use and cached on disk
(``cache=True``), so only the first large solve on a machine pays the compilation (a few seconds).
"""

from __future__ import annotations

import os
import threading

import numba
import numpy as np
from numba import njit, prange

from .cpus import usable_cpus

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@njit(**_JIT)
def _gauss_jordan(A, Xb):  # pragma: no cover - compiled
    """``Xb = A^{-1}`` by Gauss--Jordan elimination with partial pivoting (``A`` is overwritten, ``Xb`` enters as
    the identity); False if a pivot column is zero or not finite."""
    q = A.shape[0]
    for j in range(q):
        p = j
        largest = abs(A[j, j])
        for i in range(j + 1, q):
            v = abs(A[i, j])
            if v > largest:
                largest = v
                p = i
        if largest == 0.0 or not np.isfinite(largest):
            return False
        if p != j:
            for col in range(q):
                t = A[j, col]
                A[j, col] = A[p, col]
                A[p, col] = t
                t = Xb[j, col]
                Xb[j, col] = Xb[p, col]
                Xb[p, col] = t
        scale = 1.0 / A[j, j]
        for col in range(q):
            A[j, col] *= scale
            Xb[j, col] *= scale
        for i in range(q):
            if i != j:
                f = A[i, j]
                if f != 0.0:
                    for col in range(q):
                        A[i, col] -= f * A[j, col]
                        Xb[i, col] -= f * Xb[j, col]
    return True


@njit(**_JIT)
def _inverse_blocks(M):  # pragma: no cover - compiled
    n, q, _ = M.shape
    X = np.empty((n, q, q))
    A = np.empty((q, q))
    singular = -1
    for b in range(n):
        Xb = X[b]
        for i in range(q):
            for j in range(q):
                A[i, j] = M[b, i, j]
                Xb[i, j] = 0.0
            Xb[i, i] = 1.0
        if not _gauss_jordan(A, Xb) and singular < 0:
            singular = b
    return X, singular


@njit(parallel=True, **_JIT)
def _inverse_scaled_blocks(g, g_dual, sqrt_d, symmetric, X, top_left, H):  # pragma: no cover - compiled
    n, r, k = g.shape
    q = k + r
    failed = np.zeros(n, dtype=np.bool_)
    for b in prange(n):
        A = np.empty((q, q))
        Xb = X[b]
        for i in range(q):
            for j in range(q):
                A[i, j] = 0.0
                Xb[i, j] = 0.0
            Xb[i, i] = 1.0
        for j in range(r):
            scale = sqrt_d[b, j]
            for i in range(k):
                A[i, k + j] = g_dual[b, j, i] * scale
                A[k + j, i] = g[b, j, i] * scale
            A[k + j, k + j] = -1.0
        failed[b] = not _gauss_jordan(A, Xb)
        for i in range(k):
            for j in range(k):
                top_left[b, i, j] = Xb[i, j]
        if symmetric:
            for i in range(k):
                for j in range(k):
                    H[b, i, j] = 0.5 * (Xb[i, j] + Xb[j, i])
    for b in range(n):
        if failed[b]:
            return b
    return -1


def inverse_blocks(M: np.ndarray) -> np.ndarray:
    """``M_i^{-1}`` for a stack ``M`` of shape ``(n, q, q)`` (as ``np.linalg.inv``, which raises
    ``LinAlgError`` for a singular block; so does this)."""
    X, singular = _inverse_blocks(np.ascontiguousarray(M, dtype=np.float64))
    if singular >= 0:
        raise np.linalg.LinAlgError(f"Singular matrix (block {singular})")
    return X


# numba runs parallel loops on OpenMP threads where it finds OpenMP.  By default they spin for a while after each
# loop, and on two cores that takes the CPU the supernodal Cholesky's worker process needs for its half of every
# solve: at 10,050 blocks the LP took 10.3 s instead of 7.2 s wall-clock, its solves with K 3.4 s instead of 1.3 s
# of CPU (``python studies/lab/lp_timing.py --walls 100x100 --algorithms block-ipm``, without and with
# OMP_WAIT_POLICY=passive, one run each).  So the threads wait passively unless the user chose otherwise (OpenMP
# reads the variable when it is loaded: numba's first parallel loop, after this import).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

#: one parallel kernel at a time in this process: numba's fallback threading layer (``workqueue``, where neither
#: OpenMP nor TBB is found) aborts the process when two Python threads launch parallel kernels at once
_PARALLEL_LAUNCH = threading.Lock()


def _parallel(kernel, *args):
    """``kernel(*args)`` on the CPUs this process may use (:func:`blockmpec.solvers.linalg.cpus.usable_cpus`, which the
    comparator's CPU share caps), at most ``NUMBA_NUM_THREADS``; one launch at a time."""
    with _PARALLEL_LAUNCH:
        numba.set_num_threads(max(1, min(usable_cpus(), numba.config.NUMBA_NUM_THREADS)))
        return kernel(*args)


def inverse_scaled_blocks(g: np.ndarray, g_dual: np.ndarray, sqrt_d: np.ndarray,
                          symmetric: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``(M^{-1}, H~, H^{-1})`` per block without forming the stack ``M``: ``M_i = [[0, B_dual_i^T], [B_i, -I]]``
    with ``B_i = D_i^{1/2} g_i`` (``g``, ``g_dual``: ``(n, r, k)``; ``sqrt_d``: ``(n, r)``), inverted as
    :func:`inverse_blocks` does; ``H~`` the top-left ``k x k`` block of ``M_i^{-1}`` and ``H^{-1}`` its symmetric part
    ``(H~ + H~^T) / 2`` when ``symmetric`` (else ``H~`` itself).  The same numbers bit for bit as building ``M`` with
    numpy and calling :func:`inverse_blocks`, without the stack ``M`` written and read (78 MB at 100,014 blocks):
    0.19 s -> 0.11 s on 200,000 random 7-by-7 blocks (``H~`` and ``H^{-1}`` included, five calls each, one run).
    Raises ``LinAlgError`` for a singular block, as :func:`inverse_blocks`."""
    n, r, k = g.shape
    X = np.empty((n, k + r, k + r))
    top_left = np.empty((n, k, k))
    H = np.empty((n, k, k)) if symmetric else top_left
    singular = _parallel(_inverse_scaled_blocks, np.ascontiguousarray(g, dtype=np.float64),
                         np.ascontiguousarray(g_dual, dtype=np.float64), np.ascontiguousarray(sqrt_d, dtype=np.float64),
                         bool(symmetric), X, top_left, H)
    if singular >= 0:
        raise np.linalg.LinAlgError(f"Singular matrix (block {singular})")
    return X, top_left, H


@njit(**_JIT)
def _block_product(X, v):  # pragma: no cover - compiled
    n, q, p = X.shape
    out = np.empty((n, q))
    for b in range(n):
        for i in range(q):
            acc = 0.0
            for j in range(p):
                acc += X[b, i, j] * v[b, j]
            out[b, i] = acc
    return out


def block_product(X: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``X_i v_i`` for every block: ``X`` of shape ``(n, q, p)``, ``v`` of shape ``(n, p)``."""
    return _block_product(np.ascontiguousarray(X, dtype=np.float64), np.ascontiguousarray(v, dtype=np.float64))


@njit(**_JIT)
def _block_reduced_products(a, H, b, aH, out, position):  # pragma: no cover - compiled
    """``a_b H_b a_b^T`` of block ``b`` into ``out[position:position + s s]`` (row-major), through ``aH``."""
    s, k = a.shape[1], a.shape[2]
    for i in range(s):
        for j in range(k):
            acc = 0.0
            for m in range(k):
                acc += a[b, i, m] * H[b, m, j]
            aH[i, j] = acc
    for i in range(s):
        for j in range(s):
            acc = 0.0
            for m in range(k):
                acc += aH[i, m] * a[b, j, m]
            out[position] = acc
            position += 1


@njit(**_JIT)
def _reduced_values(a, H, targets, n_values):  # pragma: no cover - compiled
    n, s, k = a.shape
    values = np.zeros(n_values + 1)
    aH = np.empty((s, k))
    products = np.empty(s * s)
    position = 0
    for b in range(n):
        _block_reduced_products(a, H, b, aH, products, 0)
        for t in range(s * s):
            values[targets[position]] += products[t]
            position += 1
    return values[:n_values]


@njit(parallel=True, **_JIT)
def _reduced_values_gathered(a, H, order, starts):  # pragma: no cover - compiled
    n, s, k = a.shape
    products = np.empty(n * s * s)
    for b in prange(n):
        _block_reduced_products(a, H, b, np.empty((s, k)), products, b * s * s)
    n_values = starts.size - 1
    values = np.empty(n_values)
    for t in prange(n_values):
        acc = 0.0
        for e in range(starts[t], starts[t + 1]):
            acc += products[order[e]]
        values[t] = acc
    return values


class ReducedAssembly:
    """:func:`reduced_values` on the CPUs this process may use, the same numbers bit for bit: the products
    ``a_i H_i a_i^T`` are computed block by block in parallel, then each value of ``K`` sums its products in the
    order of their positions, which is the order in which the scatter adds them (a stable sort of ``targets``
    made once).  Costs one array of the products (``n s s`` floats) per call."""

    def __init__(self, targets: np.ndarray, n_values: int) -> None:
        targets = np.ascontiguousarray(targets, dtype=np.int64)
        self.order = np.argsort(targets, kind="stable")
        counts = np.bincount(targets, minlength=n_values + 1)[:n_values]  # position n_values: the padding
        self.starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

    def values(self, a: np.ndarray, H: np.ndarray) -> np.ndarray:
        return _parallel(_reduced_values_gathered, np.ascontiguousarray(a, dtype=np.float64),
                         np.ascontiguousarray(H, dtype=np.float64), self.order, self.starts)


def reduced_values(a: np.ndarray, H: np.ndarray, targets: np.ndarray, n_values: int) -> np.ndarray:
    """``sum_i`` of ``a_i H_i a_i^T`` (``a``: ``(n, s, k)``, ``H``: ``(n, k, k)``) scattered into an array of
    ``n_values`` by ``targets`` (``n s s`` positions in row-major order of the products; position ``n_values``
    takes the padding and is dropped)."""
    return _reduced_values(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(H, dtype=np.float64),
                           np.ascontiguousarray(targets, dtype=np.int64), int(n_values))


@njit(parallel=True, **_JIT)
def _block_solve(M_inv, sqrt_d, rhs_dual, rhs_primal, block_rows, with_dy):  # pragma: no cover - compiled
    n, q, _ = M_inv.shape
    r = block_rows.shape[1]
    k = q - r
    dv = np.empty(n * k)
    dy = np.empty(rhs_primal.size if with_dy else 0)
    rows = q if with_dy else k  # without dy: only dv's rows of each inverse are read
    for b in prange(n):
        rhs = np.empty(q)
        for j in range(k):
            rhs[j] = rhs_dual[b * k + j]
        for j in range(r):
            rhs[k + j] = sqrt_d[b, j] * rhs_primal[block_rows[b, j]]
        for i in range(rows):
            acc = 0.0
            for j in range(q):
                acc += M_inv[b, i, j] * rhs[j]
            if i < k:
                dv[b * k + i] = acc
            else:
                dy[block_rows[b, i - k]] = sqrt_d[b, i - k] * acc
    return dv, dy


def block_solve(M_inv: np.ndarray, sqrt_d: np.ndarray, rhs_dual: np.ndarray, rhs_primal: np.ndarray,
                block_rows: np.ndarray, with_dy: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    r"""The block solves of :meth:`~blockmpec.solvers.linalg.block_ipm.BlockIPM.block_solve` in one pass:
    per block ``(x, z) = M_i^{-1} (rhs_dual_i, D_i^{1/2} rhs_primal[rows_i])``, ``dv_i = x``,
    ``dy[rows_i] = D_i^{1/2} z`` (``block_rows`` must cover every inequality row once).  ``with_dy=False``: ``dv``
    alone (the same numbers), from the first ``k`` rows of each ``M_i^{-1}`` (3 of 7 on a wall: less than half the
    memory read), and None for ``dy``."""
    rhs_dual = np.ascontiguousarray(rhs_dual, dtype=np.float64)
    rhs_primal = np.ascontiguousarray(rhs_primal, dtype=np.float64)
    dv, dy = _parallel(_block_solve, M_inv, sqrt_d, rhs_dual, rhs_primal, block_rows, bool(with_dy))
    return dv, (dy if with_dy else None)


@njit(parallel=True, **_JIT)
def _max_step(z, dz):  # pragma: no cover - compiled
    chunks = min(z.size, 64)
    largest = np.full(chunks, -np.inf)
    for c in prange(chunks):
        m = -np.inf
        for i in range(z.size * c // chunks, z.size * (c + 1) // chunks):
            if dz[i] < 0.0:
                ratio = z[i] / dz[i]
                if ratio > m:
                    m = ratio
        largest[c] = m
    m = -np.inf
    for c in range(chunks):
        if largest[c] > m:
            m = largest[c]
    return min(1.0, -m)


def max_step(z: np.ndarray, dz: np.ndarray) -> float:
    """The step to the boundary ``min(1, min over dz_i < 0 of -z_i / dz_i)`` in one pass (numpy: a division into a
    new array, then its maximum); the same divisions, so the same step."""
    z, dz = np.ascontiguousarray(z, dtype=np.float64), np.ascontiguousarray(dz, dtype=np.float64)
    return float(_parallel(_max_step, z, dz)) if z.size else 1.0


@njit(parallel=True, **_JIT)
def _row_products(indptr, indices, data, x, offset, negated, out):  # pragma: no cover - compiled
    """``out = M x``, or ``-offset - M x`` when ``negated`` (``offset`` is not read otherwise)."""
    for i in prange(out.size):
        acc = 0.0
        for e in range(indptr[i], indptr[i + 1]):
            acc += data[e] * x[indices[e]]
        out[i] = -offset[i] - acc if negated else acc


@njit(parallel=True, **_JIT)
def _row_products_with_bound(indptr, indices, data, x, out, bound):  # pragma: no cover - compiled
    for i in prange(out.size):
        acc = 0.0
        size = 0.0
        for e in range(indptr[i], indptr[i + 1]):
            acc += data[e] * x[indices[e]]
            size += abs(data[e]) * abs(x[indices[e]])
        out[i] = acc
        bound[i] = size


class SparseProducts:
    r"""``M x`` and ``M^T y`` for one sparse matrix ``M``, by compiled loops over rows on the CPUs this process may
    use.

    scipy multiplies a CSR matrix by a vector on one thread, one row after another (``csr_matvec``), and its
    transpose by adding row ``j``'s entries into the result for ``j = 0, 1, ...`` (``csc_matvec``).  Here both are
    row loops, the second over an explicit CSR copy of ``M^T`` whose row ``i`` lists the entries of ``M``'s column
    ``i`` with ``j`` ascending.  Each result entry is a sum of the same products in the same order as scipy's,
    started from 0, so the products are scipy's bit for bit on any number of threads (tests), and each row's sum
    is independent, so the rows run in parallel.  :meth:`times_with_bound` gives ``|M| |x|`` with ``M x`` in the
    same pass (each ``|m_ij| |x_j|`` is ``|m_ij x_j|`` exactly).  The copy of ``M^T`` costs the memory of ``M``.
    """

    def __init__(self, M) -> None:
        #: the matrix given (the block IPM checks by identity that it still multiplies by this one)
        self.matrix = M
        M = M.tocsr() if M.format != "csr" else M
        self.shape = M.shape
        self._rows = (M.indptr, M.indices, np.ascontiguousarray(M.data, dtype=np.float64))
        T = M.T.tocsr()  # row i: column i of M, j ascending (a stable counting sort by column)
        self._columns = (T.indptr, T.indices, np.ascontiguousarray(T.data, dtype=np.float64))

    def times(self, x: np.ndarray) -> np.ndarray:
        """``M x``, as scipy's ``M @ x`` bit for bit."""
        out = np.empty(self.shape[0])
        _parallel(_row_products, *self._rows, np.ascontiguousarray(x, dtype=np.float64), out, False, out)
        return out

    def transpose_times(self, y: np.ndarray) -> np.ndarray:
        """``M^T y``, as scipy's ``M.T @ y`` bit for bit."""
        out = np.empty(self.shape[1])
        _parallel(_row_products, *self._columns, np.ascontiguousarray(y, dtype=np.float64), out, False, out)
        return out

    def offset_minus_times(self, offset: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``-offset - M x`` in one pass, as numpy's ``-offset - M @ x`` bit for bit."""
        out = np.empty(self.shape[0])
        _parallel(_row_products, *self._rows, np.ascontiguousarray(x, dtype=np.float64),
                  np.ascontiguousarray(offset, dtype=np.float64), True, out)
        return out

    def times_with_bound(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(M x, |M| |x|)`` in one pass, as scipy's ``M @ x`` and ``abs(M) @ np.abs(x)`` bit for bit."""
        out, bound = np.empty(self.shape[0]), np.empty(self.shape[0])
        _parallel(_row_products_with_bound, *self._rows, np.ascontiguousarray(x, dtype=np.float64), out, bound)
        return out, bound


# --- the centring targets of an iteration (elementwise, one pass each; numpy's roundings) --------------------------


def _weight_arguments(weights, out: np.ndarray) -> tuple[np.ndarray, bool]:
    """The ``(weights, unit)`` arguments of the kernels below: the path weights as float64, or for ``None`` (all ones)
    any float64 array of the right size (``out``, never read) and ``unit`` True."""
    if weights is None:
        return out, True
    return np.ascontiguousarray(weights, dtype=np.float64), False


@njit(parallel=True, **_JIT)
def _centrality_correction(s, ds, y, dy, tp, td, low, high, weights, unit, out):  # pragma: no cover - compiled
    for i in prange(out.size):
        w = 1.0 if unit else weights[i]
        products = (s[i] + tp * ds[i]) * (y[i] + td * dy[i])
        lo, hi = low * w, high * w
        target = min(max(products, lo), hi)
        out[i] = max(target - products, -hi)


def centrality_correction(s, ds, y, dy, tp: float, td: float, low: float, high: float, weights) -> np.ndarray:
    """Gondzio's correction of the complementarity target in one pass: with the trial products
    ``p = (s + tp ds) (y + td dy)``, ``max(clip(p, low w, high w) - p, -high w)`` (``weights`` ``w``; None: ones).
    The same numbers bit for bit as the numpy expression it replaces (its passes and temporaries: 11 of each)."""
    out = np.empty(s.size)
    _parallel(_centrality_correction, s, ds, y, dy, float(tp), float(td), float(low), float(high),
              *_weight_arguments(weights, out), out)
    return out


@njit(parallel=True, **_JIT)
def _centring_target(s, y, ds, dy, scale, weights, unit, out):  # pragma: no cover - compiled
    for i in prange(out.size):
        w = 1.0 if unit else weights[i]
        out[i] = (scale * w - s[i] * y[i]) - ds[i] * dy[i]


def centring_target(s, y, ds, dy, scale: float, weights) -> np.ndarray:
    """Mehrotra's corrector target ``scale w - s y - ds dy`` (``scale = sigma mu``; ``weights`` ``w``, None: ones)
    in one pass, the same numbers bit for bit as numpy's five."""
    out = np.empty(s.size)
    _parallel(_centring_target, s, y, ds, dy, float(scale), *_weight_arguments(weights, out), out)
    return out


@njit(parallel=True, **_JIT)
def _primal_rhs(r_h, r_mu, y, out):  # pragma: no cover - compiled
    for i in prange(out.size):
        out[i] = -r_h[i] - r_mu[i] / y[i]


def primal_rhs(r_h, r_mu, y) -> np.ndarray:
    """The block solves' primal right-hand side ``-r_h - r_mu / y`` in one pass (numpy's roundings)."""
    out = np.empty(r_h.size)
    _parallel(_primal_rhs, r_h, r_mu, y, out)
    return out


@njit(parallel=True, **_JIT)
def _newton_errors(r_h, G_dv, ds, r_mu, y, s, dy, e_h, e_mu, largest):  # pragma: no cover - compiled
    chunks = largest.shape[0]
    p = e_h.size
    for c in prange(chunks):
        m_h, m_mu = 0.0, 0.0
        nan_h, nan_mu = False, False
        for i in range(p * c // chunks, p * (c + 1) // chunks):
            a = (-r_h[i] - G_dv[i]) - ds[i]
            b = r_mu[i] - (y[i] * ds[i] + s[i] * dy[i])
            e_h[i], e_mu[i] = a, b
            a, b = abs(a), abs(b)
            if a != a:  # NaN is kept: numpy's maximum propagates it
                nan_h = True
            elif a > m_h:
                m_h = a
            if b != b:
                nan_mu = True
            elif b > m_mu:
                m_mu = b
        largest[c, 0] = np.nan if nan_h else m_h
        largest[c, 1] = np.nan if nan_mu else m_mu


def newton_errors(r_h, G_dv, ds, r_mu, y, s, dy) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The inequality and complementarity rows' errors of a Newton direction, ``e_h = -r_h - G dv - ds`` and
    ``e_mu = r_mu - (y ds + s dy)``, with their largest magnitudes, in one pass (numpy's roundings; a maximum is
    exact in any order, and NaN propagates as in numpy)."""
    p = r_h.size
    e_h, e_mu = np.empty(p), np.empty(p)
    largest = np.zeros((max(1, min(p, 64)), 2))
    _parallel(_newton_errors, r_h, G_dv, ds, r_mu, y, s, dy, e_h, e_mu, largest)
    high = largest.max(axis=0) if p else np.zeros(2)
    return e_h, e_mu, float(high[0]), float(high[1])
