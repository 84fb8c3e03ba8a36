r"""The MCP (3) / MPEC (4) compiled once per structure into one typed object.

:func:`compile_mcp` builds the Pyomo model of :func:`blockmpec.formulations.mcp.mcp`
(the one statement of (3) as a model), deactivates its ``Complementarity``
components, compiles every row with :func:`~blockmpec.formulations.pyomo_compile.compile_linear`
and puts the columns in the canonical order ::

    w = (lam, x, u, z),   z = (z_u, z_f),   x[3k:3k+3] = (t_k, n_k, m_k)

The result, :class:`CompiledMCP`, holds

* ``A w = rhs``: the equality rows (equilibrium, compatibility, normalisation);
* ``G w <= 0``: the pair rows, one per complementarity pair, and
  ``pair_column[i]``: the multiplier column complementary to pair row ``i``
  (``0 <= -G_i w  _|_  w[pair_column[i]] >= 0``);
* named slices of ``w`` (``lam, x, u, z, z_u, z_f``), index arrays ``t, n, m``
  into ``x``, row slices (``equilibrium, compatibility, normalisation``), pair
  slices (``unilateral``, ``friction``) and per-pair ``pair_kind`` and
  ``pair_interface``,

so that no solver does stride arithmetic or reads an operator.  Everything a
solver needs of (3) is here: ``nlp``, ``mcp-newton`` and ``milp`` consume this
object.

Where (3) is written, and where it is checked: :mod:`blockmpec.formulations.mcp`
(the Pyomo model) together with this module (its compilation) is the one
statement of (3) as a model.  The verifier :mod:`blockmpec.verify` is a
deliberate second, independent statement, written directly on the operators: it
checks every solver's answer and shares no code with this path, so it must not
be rewritten on top of :class:`CompiledMCP`.

The flow rows depend linearly on ``tan(psi)`` of each interface;
:meth:`CompiledMCP.with_dilatancy` gives the system at other values (used by the
continuation of ``mcp-newton``) from two more compiles, at ``tan(psi) = 0`` and ``1``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from blockmpec.operators import Operators
from blockmpec.result import Solution

#: codes of :attr:`CompiledMCP.pair_kind`
UNILATERAL, FRICTION = 0, 1


@dataclass(frozen=True, eq=False)
class CompiledMCP:
    r"""Problem (3) in matrix form; see the module docstring.

    Attributes
    ----------
    A : csr_array, shape (3b + 3c + 1, n)
        Equality rows ``A w = rhs``: ``A[equilibrium]`` is ``[f_l, E, 0, 0]``,
        ``A[compatibility]`` is ``[0, 0, E^T, F]`` with the flow matrix ``F``,
        ``A[normalisation]`` is ``[0, 0, f_l^T, 0]``.
    rhs : ndarray, shape (3b + 3c + 1,)
    G : csr_array, shape (4c, n)
        Pair rows ``G w <= 0`` (nonzero in the ``x`` columns only); the slack of pair
        ``i`` is ``s_i = -G_i w``.
    pair_column : ndarray of int, shape (4c,)
        Column of ``w`` of the multiplier complementary to pair row ``i``.
    pair_kind : ndarray of int, shape (4c,)
        :data:`UNILATERAL` or :data:`FRICTION`.
    pair_interface : ndarray of int, shape (4c,)
        Contact of each pair (two pairs of each kind per interface).
    friction, dilatancy : ndarray, shape (c,)
        ``tan(phi)`` and ``tan(psi)`` per contact (data of the flow rows).

    The shapes are those of 2D (``c`` interfaces, three dofs per block).  In 3D (:mod:`blockmpec.three_d`) the
    contacts are the contact points and the sizes come from the operators' layout: ``block_dofs`` (6) rows per
    block, one no-tension pair per point, one friction pair per side of its pyramid; ``n_interfaces`` counts the
    contacts.
    """

    A: sp.csr_array
    rhs: np.ndarray
    G: sp.csr_array
    pair_column: np.ndarray
    pair_kind: np.ndarray
    pair_interface: np.ndarray
    n_blocks: int
    n_interfaces: int
    friction: np.ndarray
    dilatancy: np.ndarray
    _ops: Operators = field(repr=False)
    _dilatancy_rows: tuple[sp.csr_array, sp.csr_array] | None = field(default=None, repr=False)
    #: the layout of ``x``, ``u`` and the pairs, from the operators (2D defaults: 3 dofs per block, two pairs of
    #: each kind per interface, ``x = (t, n, m)`` per interface)
    block_dofs: int = 3
    normal_index: np.ndarray | None = field(default=None, repr=False)
    shear_index: np.ndarray | None = field(default=None, repr=False)
    n_unilateral: int | None = None
    n_friction: int | None = None

    # ------------------------------------------------------------------ layout
    # ``n_interfaces`` counts the contacts (interfaces in 2D, contact points in 3D), each with three entries of ``x``
    @property
    def _n_x(self) -> int:
        return 3 * self.n_interfaces

    @property
    def _n_u(self) -> int:
        return self.block_dofs * self.n_blocks

    @property
    def _n_zu(self) -> int:
        return 2 * self.n_interfaces if self.n_unilateral is None else self.n_unilateral

    @property
    def _n_zf(self) -> int:
        return 2 * self.n_interfaces if self.n_friction is None else self.n_friction

    @property
    def n_columns(self) -> int:
        """Length of ``w``: ``1 + len(x) + len(u) + len(z)``."""
        return 1 + self._n_x + self._n_u + self._n_zu + self._n_zf

    @property
    def lam(self) -> int:
        """Column of ``lam``."""
        return 0

    @property
    def x(self) -> slice:
        return slice(1, 1 + self._n_x)

    @property
    def u(self) -> slice:
        a = 1 + self._n_x
        return slice(a, a + self._n_u)

    @property
    def z(self) -> slice:
        a = 1 + self._n_x + self._n_u
        return slice(a, a + self._n_zu + self._n_zf)

    @property
    def z_u(self) -> slice:
        a = self.z.start
        return slice(a, a + self._n_zu)

    @property
    def z_f(self) -> slice:
        a = self.z.start + self._n_zu
        return slice(a, a + self._n_zf)

    @property
    def t(self) -> np.ndarray:
        """Positions of the shear forces in ``x`` (2D: ``t_k`` per interface; 3D: ``t1, t2`` of each point, flat)."""
        if self.shear_index is None:
            return np.arange(0, 3 * self.n_interfaces, 3)
        return np.asarray(self.shear_index).ravel()

    def shear_of(self, contacts: np.ndarray) -> np.ndarray:
        """Positions in ``x`` of the shear forces of the contacts selected by the boolean mask ``contacts`` (c,)."""
        if self.shear_index is None:
            return np.arange(0, 3 * self.n_interfaces, 3)[contacts]
        return np.asarray(self.shear_index)[contacts].ravel()

    @property
    def n(self) -> np.ndarray:
        """Positions of the normal forces ``n_k`` in ``x``."""
        if self.normal_index is None:
            return np.arange(1, 3 * self.n_interfaces, 3)
        return np.asarray(self.normal_index)

    @property
    def m(self) -> np.ndarray:
        """Positions of the moments ``m_k`` in ``x`` (none in 3D: the points carry forces only)."""
        taken = np.zeros(self._n_x, bool)
        taken[self.t] = True
        taken[self.n] = True
        return np.flatnonzero(~taken)

    @property
    def equilibrium(self) -> slice:
        """Rows of ``A``: equilibrium (``block_dofs`` per free block)."""
        return slice(0, self._n_u)

    @property
    def compatibility(self) -> slice:
        """Rows of ``A``: compatibility (3 per contact)."""
        return slice(self._n_u, self._n_u + self._n_x)

    @property
    def normalisation(self) -> slice:
        """Row of ``A``: normalisation ``f_l^T u = 1``."""
        a = self._n_u + self._n_x
        return slice(a, a + 1)

    @property
    def unilateral(self) -> slice:
        """Pairs (rows of ``G``) of the no-tension conditions (2 per interface in 2D, 1 per point in 3D)."""
        return slice(0, self._n_zu)

    @property
    def friction_pairs(self) -> slice:
        """Pairs (rows of ``G``) of the Coulomb conditions (2 per interface in 2D, one per pyramid side in 3D)."""
        return slice(self._n_zu, self._n_zu + self._n_zf)

    @property
    def n_pairs(self) -> int:
        return self._n_zu + self._n_zf

    # ------------------------------------------------------------------ data views
    @property
    def f_l(self) -> np.ndarray:
        """Live load (the ``lam`` column of the equilibrium rows)."""
        return self.A[self.equilibrium, [self.lam]].toarray().ravel()

    @property
    def f_d(self) -> np.ndarray:
        """Dead load (``E x + lam f_l = -f_d``)."""
        return -self.rhs[self.equilibrium]

    def block(self, rows: slice, cols: slice) -> sp.csr_array:
        """A sub-block of ``A``, e.g. ``block(form.compatibility, form.z)`` = the flow matrix ``F``."""
        return sp.csr_array(self.A[rows, cols])

    @property
    def pair_matrix(self) -> sp.csr_array:
        """``G`` restricted to the ``x`` columns: the slacks are ``s = -pair_matrix @ x``."""
        return sp.csr_array(self.G[:, self.x])

    # ------------------------------------------------------------------ vectors
    def pack(self, sol: Solution) -> np.ndarray:
        """``w`` of a solution (missing fields are zeros)."""
        w = np.zeros(self.n_columns)
        w[self.lam] = 0.0 if sol.multiplier is None else float(sol.multiplier)
        for sl, v in ((self.x, sol.x), (self.u, sol.u), (self.z_u, sol.z_u), (self.z_f, sol.z_f)):
            if v is not None:
                w[sl] = v
        return w

    def unpack(self, w: np.ndarray) -> Solution:
        """The :class:`~blockmpec.result.Solution` at ``w``."""
        w = np.asarray(w, float)
        return Solution(multiplier=float(w[self.lam]), x=w[self.x].copy(), u=w[self.u].copy(),
                        z_u=w[self.z_u].copy(), z_f=w[self.z_f].copy())

    def slack(self, w: np.ndarray) -> np.ndarray:
        """Pair slacks ``s = -G w`` (``>= 0`` when admissible)."""
        return -(self.G @ w)

    def multipliers(self, w: np.ndarray) -> np.ndarray:
        """Pair multipliers ``w[pair_column]``."""
        return np.asarray(w)[self.pair_column]

    # ------------------------------------------------------------------ variants
    def with_dilatancy(self, dilatancy: np.ndarray | float) -> CompiledMCP:
        """The same system with ``tan(psi)`` = ``dilatancy`` (per interface) in the flow rows.

        The compiled rows are affine in ``tan(psi)``: ``A(d) = A(0) + S diag(d)`` on the
        ``z_f`` columns, where ``A(0)`` and ``S = A(1) - A(0)`` are compiled once (lazily)
        from the Pyomo model at ``tan(psi) = 0`` and ``1``.  The model's flow entries are
        ``tan(psi)`` itself (``S`` holds exact ones), so ``with_dilatancy(d).A`` equals a
        compile at ``d`` entry for entry, with no round-off.
        """
        d = np.broadcast_to(np.asarray(dilatancy, float), self.dilatancy.shape).copy()
        base, S = self._dilatancy_basis()
        col = np.zeros(self.n_columns)
        col[self.z_f] = d[self.pair_interface[self.friction_pairs]]
        A = sp.csr_array(base + S @ sp.diags_array(col))
        A.eliminate_zeros()
        A.sort_indices()
        return replace(self, A=A, dilatancy=d, _dilatancy_rows=(base, S))

    def _dilatancy_basis(self) -> tuple[sp.csr_array, sp.csr_array]:
        if self._dilatancy_rows is None:
            c = self.n_interfaces
            base = _compile(self._ops, np.zeros(c)).A
            S = sp.csr_array(_compile(self._ops, np.ones(c)).A - base)
            S.eliminate_zeros()
            object.__setattr__(self, "_dilatancy_rows", (base, S))
        return self._dilatancy_rows


def compile_mcp(ops: Operators) -> CompiledMCP:
    """Compile the MCP (3) of ``ops``, once: the result is kept on ``ops`` (a reference
    cycle ``ops -> form -> ops`` that the garbage collector frees with ``ops``)."""
    form = getattr(ops, "_compiled_mcp", None)
    if form is None:
        form = _compile(ops, ops.dilatancy)
        object.__setattr__(ops, "_compiled_mcp", form)
    return form


def _compile(ops: Operators, dilatancy: np.ndarray) -> CompiledMCP:
    from blockmpec.formulations.mcp import mcp
    from blockmpec.formulations.pyomo_compile import PyomoProblem, compile_linear

    problem = mcp(ops, dilatancy=dilatancy)
    model = problem.model
    pairs = [model.unilateral_pairs, model.friction_pairs]
    for comp in pairs:
        comp.deactivate()
    try:
        groups = {g: problem.constraints[g] for g in ("equilibrium", "compatibility", "normalisation",
                                                       "unilateral", "friction")}
        lp = compile_linear(PyomoProblem(problem.name, model, problem.variables, groups))
    finally:
        for comp in pairs:
            comp.activate()
    c, b = ops.n_contacts, ops.n_free_blocks
    order = np.concatenate([lp.columns[g] for g in ("lam", "x", "u", "z_u", "z_f")])
    n = order.size
    present = order >= 0
    # P maps the compiler's columns to the canonical ones (absent variables: zero columns)
    P = sp.csr_array((np.ones(int(present.sum())), (order[present], np.flatnonzero(present))),
                     shape=(lp.A.shape[1], n))
    A_all = sp.csr_array(lp.A @ P)
    eq_rows = np.concatenate([lp.rows[g] for g in ("equilibrium", "compatibility", "normalisation")])
    pair_rows = np.concatenate([lp.rows["unilateral"], lp.rows["friction"]])
    if not np.array_equal(lp.row_lower[eq_rows], lp.row_upper[eq_rows]):
        raise AssertionError("compile_mcp: an equilibrium/compatibility/normalisation row is not an equality")
    if np.any(np.isfinite(lp.row_lower[pair_rows])) or np.any(lp.row_upper[pair_rows] != 0.0):
        raise AssertionError("compile_mcp: a pair row is not of the form g(x) <= 0")
    A = sp.csr_array(A_all[eq_rows])
    A.sort_indices()
    G = sp.csr_array(A_all[pair_rows])
    G.sort_indices()
    n_u, n_f = ops.N_u.shape[1], ops.N_f.shape[1]
    z0 = 1 + ops.E.shape[1] + ops.E.shape[0]
    return CompiledMCP(
        A=A,
        rhs=lp.row_upper[eq_rows].copy(),
        G=G,
        pair_column=np.arange(z0, z0 + n_u + n_f),
        pair_kind=np.repeat([UNILATERAL, FRICTION], [n_u, n_f]),
        pair_interface=np.concatenate([ops.unilateral_contact, ops.friction_contact]),
        n_blocks=b,
        n_interfaces=c,
        block_dofs=ops.block_dofs,
        normal_index=ops.normal_index,
        shear_index=ops.shear_index,
        n_unilateral=n_u,
        n_friction=n_f,
        friction=np.asarray(ops.friction, float).copy(),
        dilatancy=np.broadcast_to(np.asarray(dilatancy, float), (c,)).copy(),
        _ops=ops,
    )
