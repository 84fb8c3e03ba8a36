r"""Compiled loops (numba) for the supernodal Cholesky: its triangular solves and its numeric factorisation.

A solve with ``L~ L~^T`` (:class:`~blockmpec.solvers.linalg.cholesky.SupernodalCholesky`) walks the supernodes
forward and then backward.  Per supernode ``s`` with ``w`` columns starting at ``f`` and ``r`` rows below:

* forward: ``x[f:f+w] = L11^{-1} x[f:f+w]`` (BLAS ``dtrsv``), then ``x[below] -= L21 x[f:f+w]`` (``dgemv``);
* backward: ``x[f:f+w] -= L21^T x[below]`` (``dgemv``), then ``x[f:f+w] = L11^{-T} x[f:f+w]`` (``dtrsv``).

The Python loop calls scipy's BLAS wrappers once per supernode, and gathers and scatters ``x[below]`` with numpy:
at 100,014 blocks (5,878 supernodes) that overhead was about a third of a solve.  Here the same loop is compiled and
calls the same BLAS routines (scipy's ``cython_blas``, the library scipy's own wrappers call) through their
addresses, so every sum is the one the Python loop makes: the solutions are the same bit for bit.
The measurements of the compiled solves are in ``docs/performance.md``.

The numeric factorisation (:class:`FactorPlan`, the second half of this module) is compiled the same way: its loop
over supernodes makes the Python loop's LAPACK and BLAS calls (``dpotrf``, ``dtrsm``, ``dsyrk``) on the same fronts,
so the factors are the same bit for bit, without the numpy work and the allocations per front.

numba (BSD-2) is optional (``pip install "blockmpec[fast]"``): this module is imported only when the Cholesky's
``compiled_solves`` or ``compiled_factorisation`` is on, which the block IPM sets when its own kernels are compiled.
The loops are compiled on first use and cached on disk; the routines' addresses are arguments, not constants, so
the cache holds across processes.
"""

from __future__ import annotations

import sys

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import get_cython_function_address, intrinsic

_JIT = {"cache": True, "nogil": True}

#: addresses of the Fortran-interface BLAS routines in scipy's ``cython_blas`` (all arguments by reference)
_DTRSV = get_cython_function_address("scipy.linalg.cython_blas", "dtrsv")
_DGEMV = get_cython_function_address("scipy.linalg.cython_blas", "dgemv")


@intrinsic
def _call(typingctx, function, arguments):
    """``function(*arguments)`` for a C function ``void f(void *, ...)`` at the address ``function``, each argument
    an address (64-bit integers, signed or not)."""
    words = (function, *arguments) if isinstance(arguments, types.BaseTuple) else ()
    if not words or not all(isinstance(t, types.Integer) and t.bitwidth == 64 for t in words):
        return None
    signature = types.void(function, arguments)

    def codegen(context, builder, sig, args):
        pointer = cgutils.voidptr_t
        function_type = ir.FunctionType(ir.VoidType(), [pointer] * len(arguments))
        target = builder.inttoptr(args[0], function_type.as_pointer())
        builder.call(target, [builder.inttoptr(a, pointer) for a in cgutils.unpack_tuple(builder, args[1])])
        return context.get_dummy_value()

    return signature, codegen


# The BLAS arguments passed by reference live in arrays that the caller holds (:class:`SolvePanels`), not in
# arrays made here: numba may free a local array after its last use, which would leave its address dangling.
# ``chars`` = "LNT" (uplo, no transpose or unit-free diagonal, transpose), ``ints`` = (w, r, 1), ``reals`` =
# (alpha, beta) of the dgemv.


@njit(**_JIT)
def _forward(dtrsv, dgemv, x, order, first, width, below_count, below, below_start, L11, L21, work, chars, ints,
             reals):  # pragma: no cover
    c, i, a = chars.ctypes.data, ints.ctypes.data, reals.ctypes.data  # reals: (1, 0) for L21 x
    xs, ws = x.ctypes.data, work.ctypes.data
    for s in order:
        f, w, r = first[s], width[s], below_count[s]
        ints[0] = w
        _call(dtrsv, (c, c + 1, c + 1, i, L11[s], i, xs + 8 * f, i + 8))
        if r > 0:
            ints[1] = r
            _call(dgemv, (c + 1, i + 4, i, a, L21[s], i + 4, xs + 8 * f, i + 8, a + 8, ws, i + 8))
            start = below_start[s]
            for k in range(r):
                x[below[start + k]] -= work[k]


@njit(**_JIT)
def _backward(dtrsv, dgemv, x, order, first, width, below_count, below, below_start, L11, L21, work, chars, ints,
              reals):  # pragma: no cover
    c, i, a = chars.ctypes.data, ints.ctypes.data, reals.ctypes.data  # reals: (-1, 1) for x - L21^T x[below]
    xs, ws = x.ctypes.data, work.ctypes.data
    for s in order:
        f, w, r = first[s], width[s], below_count[s]
        ints[0] = w
        if r > 0:
            ints[1] = r
            start = below_start[s]
            for k in range(r):
                work[k] = x[below[start + k]]
            _call(dgemv, (c + 2, i + 4, i, a, L21[s], i + 4, ws, i + 8, a + 8, xs + 8 * f, i + 8))
        _call(dtrsv, (c, c + 2, c + 1, i, L11[s], i, xs + 8 * f, i + 8))


class SolvePanels:
    """The factors of one factorisation as the compiled loops read them: each supernode's ``L11`` and ``L21``
    by address (0 where this process holds none), with the Cholesky's fixed structure
    (:meth:`~blockmpec.solvers.linalg.cholesky.SupernodalCholesky.solve_structure`).  Holds the factor lists, so
    the addresses stay valid while it lives."""

    def __init__(self, structure: tuple, diagonal_blocks: list, below_blocks: list) -> None:
        self.structure = structure
        self._blocks = (diagonal_blocks, below_blocks)  # keeps the arrays alive
        for block in (*diagonal_blocks, *below_blocks):
            if block is not None and not (block.flags.f_contiguous and block.dtype == np.float64):
                raise ValueError("compiled solves need column-major float64 factors")
        self.L11 = np.array([0 if d is None else d.ctypes.data for d in diagonal_blocks], dtype=np.int64)
        self.L21 = np.array([0 if b is None else b.ctypes.data for b in below_blocks], dtype=np.int64)
        self.work = np.empty(max(int(structure[2].max(initial=0)), 1))
        # the by-reference arguments of the BLAS calls (see above _forward)
        self._chars = np.array([ord("L"), ord("N"), ord("T")], dtype=np.int8)
        self._ints = np.array([0, 0, 1], dtype=np.int32)
        self._forward_reals, self._backward_reals = np.array([1.0, 0.0]), np.array([-1.0, 1.0])

    def _order(self, supernodes) -> np.ndarray:
        order = np.asarray(supernodes if isinstance(supernodes, np.ndarray) else list(supernodes), dtype=np.int64)
        if order.size and np.any(self.L11[order] == 0):
            raise ValueError("compiled solve: a supernode without factors in this process")
        return order

    def forward(self, x: np.ndarray, supernodes) -> None:
        """``L~ y = x`` over ``supernodes`` (increasing order), in place on the contiguous float64 vector ``x``."""
        _forward(_DTRSV, _DGEMV, _vector(x), self._order(supernodes), *self.structure, self.L11, self.L21, self.work,
                 self._chars, self._ints, self._forward_reals)

    def backward(self, x: np.ndarray, supernodes) -> None:
        """``L~^T z = x`` over ``supernodes`` (decreasing order), in place on ``x``."""
        _backward(_DTRSV, _DGEMV, _vector(x), self._order(supernodes), *self.structure, self.L11, self.L21, self.work,
                  self._chars, self._ints, self._backward_reals)


def _vector(x: np.ndarray) -> np.ndarray:
    if x.ndim != 1 or x.dtype != np.float64 or not x.flags.c_contiguous:
        raise ValueError("compiled solve: x must be a contiguous float64 vector (it is solved in place)")
    return x



# --- the numeric factorisation -------------------------------------------------------------------------------------

#: factor arrays a :class:`FactorPlan` keeps for reuse (the latest factorisation's blocks and the one before, which
#: a caller may hold while it asks for the next)
FACTOR_ARRAYS = 2

_DPOTRF = get_cython_function_address("scipy.linalg.cython_lapack", "dpotrf")
_DTRSM = get_cython_function_address("scipy.linalg.cython_blas", "dtrsm")
_DSYRK = get_cython_function_address("scipy.linalg.cython_blas", "dsyrk")


@njit(**_JIT)
def _factor(dpotrf, dtrsm, dsyrk, order, values, first, width, rows, assembly_offsets, assembly_destination,
            assembly_source, child_start, child_list, relative_start, relative, update_offset, exported, arena, front,
            factor_offset, factors, chars, ints, reals):  # pragma: no cover
    """The multifrontal factorisation of the supernodes ``order`` (a postorder of their forest); the index of the
    first supernode whose pivot is not positive, else -1.  See :class:`FactorPlan` for the arguments."""
    c, i_, a = chars.ctypes.data, ints.ctypes.data, reals.ctypes.data  # chars "LNTR", ints (w, r, info), reals (1, -1)
    us, xs = arena.ctypes.data, factors.ctypes.data
    for s in order:
        m, w = rows[s], width[s]
        r = m - w
        # the front's lower triangle (column-major, leading dimension m): K's entries, then the children's updates
        for j in range(m):
            front[j * m + j:(j + 1) * m] = 0.0
        for k in range(assembly_offsets[s], assembly_offsets[s + 1]):
            front[assembly_destination[k]] = values[assembly_source[k]]
        for q in range(child_start[s], child_start[s + 1]):
            child = child_list[q]
            rc = rows[child] - width[child]
            u, start = update_offset[child], relative_start[child]
            for j in range(rc):
                column = relative[start + j] * m
                base = u + j * rc
                for i in range(j, rc):
                    front[column + relative[start + i]] += arena[base + i]
        # L11 = chol(F11): its lower triangle copied, the upper zero (as scipy's dpotrf with clean=1)
        o = factor_offset[s]
        for j in range(w):
            factors[o + j * w:o + j * w + j] = 0.0
            factors[o + j * w + j:o + (j + 1) * w] = front[j * m + j:j * m + w]
        ints[0], ints[1] = w, r
        _call(dpotrf, (c, i_, xs + 8 * o, i_, i_ + 8))
        if ints[2] != 0:
            return s
        if r == 0:
            continue
        # L21 = F21 L11^{-T}, then the update F22 - L21 L21^T (its lower triangle) into the arena
        o21 = o + w * w
        for j in range(w):
            factors[o21 + j * r:o21 + (j + 1) * r] = front[j * m + w:(j + 1) * m]
        _call(dtrsm, (c + 3, c, c + 2, c + 1, i_ + 4, i_, a, xs + 8 * o, i_, xs + 8 * o21, i_ + 4))
        u = update_offset[s]
        for j in range(r):
            if exported[s]:
                arena[u + j * r:u + j * r + j] = 0.0
            arena[u + j * r + j:u + (j + 1) * r] = front[(w + j) * m + w + j:(w + j + 1) * m]
        _call(dsyrk, (c, c + 1, i_ + 4, i_, a + 8, xs + 8 * o21, i_ + 4, a, us + 8 * u, i_ + 4))
    return -1


class FactorPlan:
    """How the compiled loop factorises one set of supernodes (a union of whole subtrees, or their top): the order
    (a postorder of the forest they form, each supernode's children in the order the Python loop adds them), and
    the place of every update matrix in one arena.

    The arena holds first the update matrices that come from outside the set (children of its supernodes that it
    does not hold: they are copied in), then a stack: a supernode's children's updates are on its top when it is
    factorised (postorder), are popped, and its own update is pushed.  Updates of the set's roots whose parent is
    outside it stay there (``exported``, upper triangle zero) and are handed back.  The front and the arena are
    reused by every factorisation, and so is the array of the factors once no earlier factorisation's blocks use
    it (:meth:`_free_factors`).

    Per supernode with ``m`` rows of which ``w`` are its own columns (``r = m - w`` below), the same calls on the
    same data as :meth:`~blockmpec.solvers.linalg.cholesky.SupernodalCholesky.factor_supernodes` makes through
    scipy's wrappers: the lower triangle of the front ``F`` (``m`` by ``m``, column-major) is zeroed, ``K``'s
    entries are written in, the children's update matrices added in the same order; ``dpotrf`` on a copy of
    ``F11`` (``w`` by ``w``), ``dtrsm`` for ``L21 = F21 L11^{-T}`` on a copy of ``F21``, ``dsyrk`` for ``F22 - L21
    L21^T`` on a copy of ``F22`` (its lower triangle).  So the factors are the Python loop's bit for bit; what is
    gone is the Python and numpy work per front: at 100,014 blocks one factorisation took 0.94-0.98 s against
    1.18-1.21 s (the 0.65 s of BLAS and LAPACK included), three runs each in one process.
    """

    def __init__(self, chol, supernodes) -> None:
        members = np.zeros(chol.supernodes, dtype=bool)
        members[np.asarray(list(supernodes), dtype=np.int64)] = True
        self.members = members
        widths = (chol.end - chol.first).astype(np.int64)
        rows = np.array([R.size for R in chol.rows], dtype=np.int64)
        below = rows - widths
        parent = chol.supernode_parents()
        self.external = [int(c) for s in np.flatnonzero(members) for c in chol.children[s] if not members[c]]
        update_offset = np.full(chol.supernodes, -1, dtype=np.int64)
        top = 0
        for child in self.external:
            update_offset[child] = top
            top += int(below[child]) ** 2
        roots = [int(s) for s in np.flatnonzero(members) if parent[s] < 0 or not members[parent[s]]]
        order: list[int] = []
        for root in roots:  # iterative postorder, children in chol.children order
            stack = [(root, 0)]
            while stack:
                s, k = stack.pop()
                kids = [c for c in chol.children[s] if members[c]]
                if k < len(kids):
                    stack.append((s, k + 1))
                    stack.append((kids[k], 0))
                else:
                    order.append(s)
        peak = top
        for s in order:
            kids = [c for c in chol.children[s] if members[c]]
            top -= sum(int(below[c]) ** 2 for c in kids)
            if below[s] > 0:
                update_offset[s] = top
                top += int(below[s]) ** 2
            peak = max(peak, top)
        self.order = np.array(order, dtype=np.int64)
        self.exported = np.zeros(chol.supernodes, dtype=np.bool_)
        self.exported[[s for s in roots if below[s] > 0]] = True
        self.update_offset = update_offset
        self.arena = np.empty(max(peak, 1))
        self.front = np.empty(max(int(rows[self.order].max(initial=0)) ** 2, 1))
        self.sizes = (widths, rows, below)
        sizes = np.where(members, widths * widths + below * widths, 0)
        self.factor_offset = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self.factor_size = int(sizes.sum())
        child_start = np.zeros(chol.supernodes + 1, dtype=np.int64)
        child_start[1:] = np.cumsum([len(k) for k in chol.children])
        self.child_start = child_start
        self.child_list = np.array([c for k in chol.children for c in k], dtype=np.int64)
        relative = [chol.rows[c][widths[c]:] for c in range(chol.supernodes)]
        # each child's rows below, as positions in its parent's rows (the flat extend-add map, made once)
        positions = [np.searchsorted(chol.rows[parent[c]], relative[c]) if parent[c] >= 0 else relative[c] * 0
                     for c in range(chol.supernodes)]
        self.relative = np.concatenate([*positions, np.zeros(0, np.int64)]).astype(np.int64)
        self.relative_start = np.concatenate([[0], np.cumsum([p.size for p in positions])[:-1]]).astype(np.int64)
        self._chars = np.array([ord("L"), ord("N"), ord("T"), ord("R")], dtype=np.int8)
        self._ints = np.zeros(3, dtype=np.int32)
        self._reals = np.array([1.0, -1.0])
        self._factor_arrays: list[np.ndarray] = []

    @property
    def factor_arrays(self) -> tuple[np.ndarray, ...]:
        """The arrays kept for the factors (at most :data:`FACTOR_ARRAYS`), each reused by a later factorisation once
        no earlier factorisation's blocks use it."""
        return tuple(self._factor_arrays)

    def _free_factors(self) -> np.ndarray:
        """An array for the factors that no earlier factorisation's blocks still use (their views hold it), else a new
        one (kept for reuse while at most :data:`FACTOR_ARRAYS` are).  Reusing one spares the page faults of a new
        array's first touch, which cost more than the dense work (0.6 s against about 0.45 s of BLAS for the 470 MB of
        the 100,014-block wall's factors)."""
        for k in range(len(self._factor_arrays)):
            if sys.getrefcount(self._factor_arrays[k]) == 2:  # the list's reference and the argument's
                return self._factor_arrays[k]
        factors = np.empty(max(self.factor_size, 1))
        if len(self._factor_arrays) < FACTOR_ARRAYS:
            self._factor_arrays.append(factors)
        return factors

    def factorise(self, chol, values: np.ndarray, updates: dict, diagonal_blocks: list, below_blocks: list) -> bool:
        """Factorise the set's supernodes: ``L11``/``L21`` as views of one new array into ``diagonal_blocks[s]`` /
        ``below_blocks[s]``; the updates of children outside the set are taken from ``updates``, those of its roots
        whose parent is outside it are left there (copies).  False if a pivot is not positive."""
        widths, rows, below = self.sizes
        for child in self.external:
            r, u = int(below[child]), int(self.update_offset[child])
            self.arena[u:u + r * r] = updates.pop(child).ravel(order="F")
        factors = self._free_factors()
        failed = _factor(_DPOTRF, _DTRSM, _DSYRK, self.order, np.ascontiguousarray(values, dtype=np.float64),
                         chol.first.astype(np.int64), widths, rows, chol._assembly_offsets, chol.assembly_destination,
                         chol._assembly_source, self.child_start, self.child_list, self.relative_start, self.relative,
                         self.update_offset, self.exported, self.arena, self.front, self.factor_offset, factors,
                         self._chars, self._ints, self._reals)
        if failed >= 0:
            return False
        for s in self.order.tolist():
            w, r, o = int(widths[s]), int(below[s]), int(self.factor_offset[s])
            diagonal_blocks[s] = factors[o:o + w * w].reshape((w, w), order="F")
            below_blocks[s] = factors[o + w * w:o + w * w + r * w].reshape((r, w), order="F") if r else None
            if self.exported[s]:
                u = int(self.update_offset[s])
                updates[s] = self.arena[u:u + r * r].reshape((r, r), order="F").copy(order="F")
        return True


# --- the symbolic factorisation ------------------------------------------------------------------------------------


@njit(**_JIT)
def _elimination_tree(row_start, row_columns, n):  # pragma: no cover - compiled
    """Liu's algorithm with path compression: ``parent[j]`` of the elimination tree (-1: a root) from the rows of the
    lower triangle (row ``i``'s columns ``k < i`` at ``row_columns[row_start[i]:row_start[i + 1]]``)."""
    parent = np.full(n, -1, dtype=np.int64)
    ancestor = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        for q in range(row_start[i], row_start[i + 1]):
            r = row_columns[q]
            if r >= i:
                continue
            while ancestor[r] != -1 and ancestor[r] != i:
                t = ancestor[r]
                ancestor[r] = i
                r = t
            if ancestor[r] == -1:
                ancestor[r] = i
                parent[r] = i
    return parent


@njit(**_JIT)
def _row_subtrees(row_start, row_columns, parent, n, kept, kept_start, kept_rows):  # pragma: no cover - compiled
    """Each column's count of rows in ``L`` (diagonal included); with ``kept_start[j] >= 0`` also the rows of the
    kept columns ``j``, written at ``kept_rows[kept_start[j]:]`` in increasing order.  Row ``i`` of ``L`` holds the
    columns of the *row subtree*: the paths up the elimination tree from each ``k < i`` of row ``i`` of the lower
    triangle, each stopping at a column already reached (marked ``i``)."""
    counts = np.zeros(n, dtype=np.int64)
    mark = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        mark[i] = i
        if kept[i]:
            kept_rows[kept_start[i] + counts[i]] = i
        counts[i] += 1
        for q in range(row_start[i], row_start[i + 1]):
            r = row_columns[q]
            while 0 <= r < i and mark[r] != i:
                if kept[r]:
                    kept_rows[kept_start[r] + counts[r]] = i
                counts[r] += 1
                mark[r] = i
                r = parent[r]
    return counts


def symbolic_factorisation(lower) -> tuple[np.ndarray, np.ndarray, object]:
    """``(counts, parent, rows_of)`` of ``L`` for the lower triangle ``lower`` (CSC, any sparse array) of a symmetric
    pattern: each column's count of rows (diagonal included), the elimination tree, and ``rows_of(columns)``, the
    sorted rows of the given columns (a list of int64 arrays, each starting with its column), by a second pass that
    stores only those.  The same numbers as :func:`~blockmpec.solvers.linalg.cholesky.column_structures`, in
    ``O(|L|)`` compiled steps and without every column's rows held at once."""
    import scipy.sparse as sp

    rows_lower = sp.csr_array(lower)  # row i: the columns k <= i of the lower triangle
    row_start = rows_lower.indptr.astype(np.int64)
    row_columns = rows_lower.indices.astype(np.int64)
    n = rows_lower.shape[0]
    parent = _elimination_tree(row_start, row_columns, n)
    none = np.zeros(n, dtype=np.bool_)
    counts = _row_subtrees(row_start, row_columns, parent, n, none, np.zeros(n, dtype=np.int64),
                           np.zeros(1, dtype=np.int64))

    def rows_of(columns) -> list[np.ndarray]:
        columns = np.asarray(columns, dtype=np.int64)
        kept = np.zeros(n, dtype=np.bool_)
        kept[columns] = True
        kept_start = np.zeros(n, dtype=np.int64)
        sizes = np.where(kept, counts, 0)
        kept_start[1:] = np.cumsum(sizes)[:-1]
        kept_rows = np.empty(max(int(sizes.sum()), 1), dtype=np.int64)
        _row_subtrees(row_start, row_columns, parent, n, kept, kept_start, kept_rows)
        return [kept_rows[kept_start[j]:kept_start[j] + counts[j]] for j in columns.tolist()]

    return counts, parent, rows_of
