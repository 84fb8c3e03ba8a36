r"""Compiled triangular solves (numba) for the supernodal Cholesky's factors.

A solve with ``L~ L~^T`` (:class:`~blockmpec.solvers.engines.cholesky.SupernodalCholesky`) walks the supernodes
forward and then backward.  Per supernode ``s`` with ``w`` columns starting at ``f`` and ``r`` rows below:

* forward: ``x[f:f+w] = L11^{-1} x[f:f+w]`` (BLAS ``dtrsv``), then ``x[below] -= L21 x[f:f+w]`` (``dgemv``);
* backward: ``x[f:f+w] -= L21^T x[below]`` (``dgemv``), then ``x[f:f+w] = L11^{-T} x[f:f+w]`` (``dtrsv``).

The Python loop calls scipy's BLAS wrappers once per supernode, and gathers and scatters ``x[below]`` with numpy:
at 100,014 blocks (5,878 supernodes) that overhead was about a third of a solve.  Here the same loop is compiled and
calls the same BLAS routines (scipy's ``cython_blas``, the library scipy's own wrappers call) through their
addresses, so every sum is the one the Python loop makes: the solutions are the same bit for bit.
``python studies/cholesky_choice.py --walls 100x100,316x316 --methods supernodal-metis,supernodal-compiled`` (one
run): 10,050 blocks 0.013 s per solve with the Python loop against 0.008 s compiled; 100,014 blocks 0.166 s against
0.109 s.  The 100,014-block LP took 228 s instead of 258 s (``studies/lp_timing.py --ipm-settings
python_solves,default``, README).  (A loop compiled *without* BLAS was slower than the Python loop:
``--methods supernodal-numba``.)

numba (BSD-2) is optional (``pip install "blockmpec[fast]"``): this module is imported only when the Cholesky's
``compiled_solves`` is on, which the block IPM sets when its own kernels are compiled.  The loops are compiled on
first use and cached on disk; BLAS's addresses are arguments, not constants, so the cache holds across processes.
"""

from __future__ import annotations

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
    (:meth:`~blockmpec.solvers.engines.cholesky.SupernodalCholesky.solve_structure`).  Holds the factor lists, so
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

