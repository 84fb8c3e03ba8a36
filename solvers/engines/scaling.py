r"""The one units reduction of the engines: every block in its own units, and the inverse that travels with it.

An adapter makes ``LoadUnits.of(ops)`` once per structure (the only place this module reads the operators);
the engines get the units object, never the operators.  From it come the reductions of the problems the engines
solve, each a diagonal scaling that carries its own inverse:

* :class:`Scaling` of an LP (:meth:`LoadUnits.static`, :meth:`LoadUnits.kinematic`): :meth:`Scaling.apply` makes
  the scaled LP ``R A C``, ``C c``, ``R b``, column bounds over ``C``; :meth:`Scaling.primal` and
  :meth:`Scaling.dual` map the scaled iterates back (``v = C v^``, ``y = R y^``, HiGHS's dual signs), and the
  other methods map a model change (costs, bounds, coefficients) into the scaled LP.  An engine holds the
  scaling with its problem and sends every value through it:
  :class:`~blockmpec.solvers.engines.highs.HighsLP` and :class:`~blockmpec.solvers.engines.block_lp.BlockLP`
  (whose linear algebra applies the same ``R`` and ``C``, :mod:`blockmpec.solvers.linalg` importing nothing
  of the library).
* :class:`MCPScaling` of the compiled MCP (3) (:meth:`LoadUnits.mcp`): columns, equality rows and pair slacks,
  for ``nlp``, ``milp`` and the piece LPs; :meth:`MCPScaling.lp_scaling` gives the :class:`Scaling` of an LP made
  of some of its rows, pair rows and columns.

The units themselves (block loads ``l_i``, interface force units ``l_k``) are :class:`blockmpec.units.Units`
(``ops.units``), the one units object every method uses.

Why.  LP solvers test feasibility and optimality with absolute tolerances (HiGHS: 1e-7 by default; the block
IPM: relative to the largest right-hand side).  A 1e-3 block on a unit block carries loads 1e-6 times smaller:
its whole equilibrium is then below the tolerance.  Scaling the LP so that each block's rows and each interface's
forces are O(1) makes the solvers' tolerances hold block by block, as the verifier measures equilibrium.

For an LP compiled from :func:`blockmpec.formulations.static_lp` (and its variants with more rows or columns)
with column vector ``v`` and rows ``A v``:

* block ``i`` carries the load ``l_i = ||f_d,i|| + ||f_l,i||``; its three equilibrium rows are divided by ``l_i``;
* interface ``k`` gets the force unit ``l_k = min`` of ``l_i`` over its free blocks (a tiny block on a big one
  loads their interface with its own weight); the columns ``(t_k, n_k, m_k)`` are measured in
  ``(l_k, l_k, l_k L_k)``, a column group named in ``normal_like`` (e.g. the tie-break deviations ``d_k``) in
  ``l_k``;
* ``lam`` (and its copies) in :attr:`LoadUnits.lam_unit` units (1 unless the live load is far below or above the
  block loads);
* every other row is divided by its largest entry after the column scaling.

With ``R`` (rows) and ``C`` (columns) the scaled LP is ``R A C``, ``R b``, ``C c``; ``v = C v^`` and the row duals
``y = R y^`` (HiGHS convention, ``c - A^T y``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from blockmpec.formulations import LinearProgram
from blockmpec.units import Units

__all__ = ["LoadUnits", "MCPScaling", "MULTIPLIER_SCALE_RANGE", "ScaledMCP", "Scaling"]

#: The multiplier is rescaled only when the live load in block units is outside [1/this, this].
MULTIPLIER_SCALE_RANGE = 1e3


class Scaling(NamedTuple):
    """A diagonal units reduction of an LP and its inverse (cvxpy's ``apply``/``invert``; scipy's
    ``_autoscale``/``_postsolve``).

    The LP ``min c^T v`` s.t. ``row_lower <= A v <= row_upper``, ``col_lower <= v <= col_upper`` becomes, with
    ``R = diag(row)``, ``C = diag(column)`` (positive), the LP in ``v^ = C^-1 v``: ``R A C``, ``C c``, row bounds
    ``R row_lower``, ``R row_upper``, column bounds ``col_lower / C``, ``col_upper / C``.  Its iterates map back by
    ``v = C v^`` (:meth:`primal`) and ``y = R y^`` (:meth:`dual`, row duals with HiGHS's signs ``c - A^T y``).
    Every value an engine passes to a scaled model, or reads from it, goes through these methods.

    A named tuple: ``row_scale, column_scale = scaling`` unpacks it.
    """

    row: np.ndarray
    column: np.ndarray

    @classmethod
    def identity(cls, lp: LinearProgram) -> Scaling:
        """No scaling (every scale 1: each map below is then exact)."""
        return cls(np.ones(lp.A.shape[0]), np.ones(lp.c.size))

    @classmethod
    def of(cls, lp: LinearProgram, row: np.ndarray | None = None, column: np.ndarray | None = None) -> Scaling:
        """The scaling of ``lp`` by ``row`` and ``column`` (None: 1)."""
        return cls(np.ones(lp.A.shape[0]) if row is None else np.asarray(row, float),
                   np.ones(lp.c.size) if column is None else np.asarray(column, float))

    def apply(self, lp: LinearProgram) -> LinearProgram:
        """The scaled LP (the same column and row groups): ``R A C``, ``C c``, ``R`` row bounds, ``C^-1`` column
        bounds."""
        A = sp.diags(self.row) @ lp.A @ sp.diags(self.column)
        return LinearProgram(c=self.column * lp.c, A=A, row_lower=self.row * lp.row_lower,
                             row_upper=self.row * lp.row_upper, col_lower=lp.col_lower / self.column,
                             col_upper=lp.col_upper / self.column, columns=lp.columns, rows=lp.rows,
                             objective_sign=lp.objective_sign, objective_offset=lp.objective_offset)

    # ---- into the scaled LP
    def row_values(self, rows, values) -> np.ndarray:
        """Row bounds (or any row quantity) of ``rows`` in the scaled LP: ``R values``."""
        return self.row[rows] * np.asarray(values, float)

    def column_values(self, columns, values) -> np.ndarray:
        """Column bounds (or values) of ``columns`` in the scaled LP: ``values / C``."""
        return np.asarray(values, float) / self.column[columns]

    def costs(self, columns, costs) -> np.ndarray:
        """Costs of ``columns`` in the scaled LP: ``C c``."""
        return self.column[columns] * np.asarray(costs, float)

    def coefficients(self, rows, columns, values) -> np.ndarray:
        """Matrix entries ``A[rows, columns]`` in the scaled LP: ``R A C``."""
        return self.row[rows] * np.asarray(values, float) * self.column[columns]

    # ---- out of the scaled LP
    def primal(self, v) -> np.ndarray:
        """Column values in the LP's units: ``v = C v^``."""
        return self.column * np.asarray(v, float)

    def dual(self, y) -> np.ndarray:
        """Row duals in the LP's units: ``y = R y^``."""
        return self.row * np.asarray(y, float)

    def row_units(self, rows) -> np.ndarray:
        """The unit of each row of ``rows`` in the LP's units (``1 / R``: one unit of the scaled row)."""
        return 1.0 / self.row[rows]

    def reduced_costs(self, d) -> np.ndarray:
        """Reduced costs in the LP's units: ``d = d^ / C``."""
        return np.asarray(d, float) / self.column


class MCPScaling(NamedTuple):
    """The units reduction of a compiled MCP (3) (:meth:`LoadUnits.mcp`): ``w = D w^`` (``column``), its equality
    rows ``A w = rhs`` times ``row``, and each pair slack ``s_i = -G_i w`` in ``slack`` units (the reciprocal of its
    multiplier's unit: ``z^_i s^_i = z_i s_i``, a work in ``lam`` units).

    A named tuple: ``column_scale, row_scale, slack_scale = scaling`` unpacks it.
    """

    column: np.ndarray
    row: np.ndarray
    slack: np.ndarray

    def lp_scaling(self, rows, columns, pair_rows: bool = True, ones: int = 0) -> Scaling:
        """The :class:`Scaling` of an LP over the columns ``columns`` of ``w`` whose rows are the equality rows
        ``rows`` of ``A``, then (``pair_rows``) the pair rows ``G w <= 0`` in slack units (``1 / slack``), then
        ``ones`` unscaled rows."""
        row = [self.row[rows]]
        if pair_rows:
            row.append(1.0 / self.slack)
        if ones:
            row.append(np.ones(ones))
        return Scaling(np.concatenate(row), self.column[columns])

    def to_units(self, w) -> np.ndarray:
        """``w -> w^``."""
        return np.asarray(w, float) / self.column

    def from_units(self, w) -> np.ndarray:
        """``w^ -> w``."""
        return np.asarray(w, float) * self.column

    def nlp_rows(self, form) -> tuple[sp.csr_array, sp.csr_array, np.ndarray]:
        """The rows of (3) for a solver of ``(w^, s^)`` (``w = D w^``, ``s = S s^``): ``R A D`` with right-hand side
        ``R rhs``, and the pair rows ``G w + s = 0`` divided by ``S`` (``S^-1 G D``, the coefficient of ``s^_i`` then
        1)."""
        D = sp.diags_array(self.column)
        return (sp.diags_array(self.row) @ form.A @ D, sp.diags_array(1.0 / self.slack) @ form.G @ D,
                self.row * form.rhs)

    def with_slacks(self) -> np.ndarray:
        """The units of ``(w, s)``: ``(D, S)``."""
        return np.concatenate([self.column, self.slack])

    def pair_sides(self, form, z: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pair multipliers ``z`` and slacks ``s`` in units: ``(z / D_z, s / S)``."""
        return z / self.column[form.pair_column], s / self.slack

    def loads(self, form) -> tuple[np.ndarray, np.ndarray]:
        """The dead and live loads ``(f_d^, f_l^)`` of the scaled equilibrium rows (``f_l`` times ``lam``'s unit)."""
        rows = self.row[form.equilibrium]
        return rows * form.f_d, rows * form.f_l * self.column[form.lam]

    def apply(self, form) -> ScaledMCP:
        """(3) of the compiled MCP ``form`` in these units, with the inverse that travels with it.

        With ``r`` the equilibrium row scale (``1/l_i``), ``C`` the force column scale (interface units of
        ``(t, n, m)``), ``S`` the multiplier column scale (``z_u``, ``z_f``) and ``s`` the multiplier unit
        (:attr:`LoadUnits.lam_unit`, a power of two), the scaled system is (3) of the structure with
        ``E^ = r E C``, ``f_l^ = s r f_l``, ``f_d^ = r f_d``, ``F^ = C F S``, pair rows ``S G C``: rows equilibrium
        ``* r``, compatibility ``* C``, normalisation ``* s`` (right-hand side still 1), pairs ``* S``; columns
        ``lam = s lam^``, ``x = C x^``, ``u = r u^``, ``z = S z^``.  Its solutions are those of (3) with
        ``f_l^T u = 1/s``, so ``w = unit * w^`` with ``unit = (s, C, s r, s S)`` maps a solution of the scaled (3)
        to one of (3) (with ``f_l^T u = 1``), pair by pair with the same active set; ``lam`` bounds map by the
        exact factor ``s``.  Every block's rows and every interface's forces are then O(1), so an engine's absolute
        tolerances hold block by block (a 1e-5 block on a unit block, dead point loads 1e10 times the weights).
        """
        import dataclasses

        column, row = self.column, self.row
        s = float(column[form.lam])
        r = column[form.u]
        A = sp.csr_array(sp.diags_array(row) @ form.A @ sp.diags_array(column))
        G = sp.csr_array(sp.diags_array(column[form.pair_column]) @ form.G @ sp.diags_array(column))
        rhs = form.rhs.copy()
        rhs[form.equilibrium] = form.rhs[form.equilibrium] * r
        scaled = dataclasses.replace(form, A=A, G=G, rhs=rhs, _dilatancy_rows=None)
        unit = column.copy()
        unit[form.u] *= s
        unit[form.z] *= s
        return ScaledMCP(scaled, unit, s)


class ScaledMCP(NamedTuple):
    """A compiled MCP (3) in per-block units (:meth:`MCPScaling.apply`) and its inverse: ``form`` the scaled system,
    ``unit`` (one per column) with ``w = unit * w^``, ``lam_unit`` the multiplier's unit ``s`` (``lam = s lam^``)."""

    form: object
    unit: np.ndarray
    lam_unit: float

    def to_units(self, w) -> np.ndarray:
        """A point of (3) -> the same point of the scaled system: ``w^ = w / unit``."""
        return np.asarray(w, float) / self.unit

    def from_units(self, w) -> np.ndarray:
        """A point of the scaled system -> the same point of (3): ``w = unit * w^``."""
        return np.asarray(w, float) * self.unit


@dataclass(frozen=True, eq=False)
class LoadUnits:
    """The per-block units of one assembled problem, and the LP scalings made from them.

    Attributes
    ----------
    units : Units
        Block loads ``l_i``, interface force units ``l_k`` and lengths (:class:`blockmpec.units.Units`).
    friction : ndarray, shape (c,)
        ``tan(phi)`` per interface (the unit of the friction multipliers, ``1/(l_k max(1, mu_k))``).
    lam_unit : float
        Unit of ``lam`` in the scaled LPs (:meth:`of`).
    """

    units: Units
    friction: np.ndarray
    lam_unit: float

    @classmethod
    def of(cls, ops) -> LoadUnits:
        """The units of assembled operators (:class:`blockmpec.operators.Operators`).

        ``lam_unit`` is 1, unless the live load in block units ``max |f_l,i| / l_i`` is below 1e-3 or
        above 1e3 (a dead point load 1e10 times the weights leaves the live load at 1e-10 of the block's
        load, below HiGHS's smallest matrix entry 1e-9, and the LP turns "unbounded"); then the power of
        two nearest ``1 / max |f_l,i| / l_i``, so that ``lam f_l`` is O(1) in the scaled rows (and ``lam``
        ~1e10 comes out right)."""
        units = ops.units
        live = float(np.max(np.abs(ops.f_l) * units.equilibrium_row_scale(), initial=0.0))
        if live <= 0 or 1 / MULTIPLIER_SCALE_RANGE <= live <= MULTIPLIER_SCALE_RANGE:
            lam_unit = 1.0
        else:
            lam_unit = float(2.0 ** np.round(np.log2(1.0 / live)))
        return cls(units, np.broadcast_to(np.asarray(ops.friction, float), (ops.n_contacts,)), lam_unit)

    @property
    def load_spread(self) -> float:
        """Largest over smallest block load (1 for uniform blocks); :attr:`Units.load_spread`."""
        return self.units.load_spread

    def static(self, lp: LinearProgram, normal_like: tuple[str, ...] = ()) -> Scaling:
        """The :class:`Scaling` ``(R, C)`` of a static-type LP (see the module docstring)."""
        units = self.units
        column_scale = np.ones(lp.c.size)
        _assign(column_scale, lp.columns["x"], units.force_column_scale())
        for group in ("lam", "lam_copy"):
            if group in lp.columns:
                _assign(column_scale, lp.columns[group], np.full(lp.columns[group].size, self.lam_unit))
        for group in normal_like:
            _assign(column_scale, lp.columns[group], units.interface_force)
        scaled = lp.A @ sp.diags(column_scale)
        row_scale = 1.0 / np.maximum(abs(scaled).max(axis=1).toarray().ravel(), 1e-300)
        row_scale[lp.rows["equilibrium"]] = units.equilibrium_row_scale()
        return Scaling(row_scale, column_scale)

    def kinematic(self, lp: LinearProgram) -> Scaling:
        """The :class:`Scaling` of the kinematic LP (2): the dual of :meth:`static`.

        If the static LP is scaled to ``R A C`` (rows ``R``: equilibrium ``1/l_i``, yield rows
        ``S``), its dual is scaled by the same matrices transposed: ``u = R u^`` and
        ``z = S z^`` (column scales), compatibility rows multiplied by ``C`` (the interface
        force units), the normalisation row unscaled.  The yield rows' scales are those
        :meth:`static` gives them: ``1/(l_k L_k)`` for ``m +- n L/2``, ``1/(l_k max(1, mu_k))``
        for ``+-t + mu_k n``.
        """
        units = self.units
        z_u_scale, z_f_scale = units.multiplier_column_scale(self.friction)
        column_scale = np.ones(lp.c.size)
        _assign(column_scale, lp.columns["u"], units.equilibrium_row_scale())
        _assign(column_scale, lp.columns["z_u"], z_u_scale)
        _assign(column_scale, lp.columns["z_f"], z_f_scale)
        row_scale = np.ones(lp.A.shape[0])
        row_scale[lp.rows["compatibility"]] = units.force_column_scale()
        row_scale[lp.rows["normalisation"]] = self.lam_unit
        return Scaling(row_scale, column_scale)

    def mcp(self, form) -> MCPScaling:
        """The :class:`MCPScaling` of a compiled MCP (3) in per-block units: columns, equality rows, pair slacks.

        The static and kinematic scalings of the LPs together: ``lam`` in :attr:`lam_unit`
        units ``s``, ``x`` in the interface force units ``C`` (``(l_k, l_k, l_k L_k)``), ``u`` in
        ``r = 1 / l_i`` per block, ``z_u``, ``z_f`` in the multiplier units ``S``
        (``1 / (l_k L_k)``, ``1 / (l_k max(1, mu_k))``); block ``i``'s equilibrium rows times ``r``,
        the compatibility rows times ``C``, the normalisation row times ``s``.  A pair row scales
        with its multiplier's column: ``column_scale[form.pair_column]``, and each pair slack in the reciprocal
        unit, ``slack = 1 / column_scale[form.pair_column]``, so that the products ``z^ s^`` equal ``z s`` (works in
        ``lam`` units).  ``nlp``, ``milp`` and the piece LPs solve (3) in these units.
        """
        units = self.units
        z_u_unit, z_f_unit = units.multiplier_column_scale(form.friction)
        column_scale = np.ones(form.n_columns)
        column_scale[form.lam] = self.lam_unit
        column_scale[form.x] = units.force_column_scale()
        column_scale[form.u] = units.equilibrium_row_scale()
        column_scale[form.z_u] = z_u_unit
        column_scale[form.z_f] = z_f_unit
        row_scale = np.ones(form.A.shape[0])
        row_scale[form.equilibrium] = units.equilibrium_row_scale()
        row_scale[form.compatibility] = units.force_column_scale()
        row_scale[form.normalisation] = self.lam_unit
        return MCPScaling(column_scale, row_scale, 1.0 / column_scale[form.pair_column])


def _assign(target: np.ndarray, columns: np.ndarray, values: np.ndarray) -> None:
    keep = columns >= 0
    target[columns[keep]] = values[keep]
