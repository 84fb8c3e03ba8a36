r"""The one units reduction of the engines: every block in its own units (:class:`LoadUnits`).

An adapter makes ``LoadUnits.of(ops)`` once per structure (the only place this module reads the
operators); the engines get the units object, never the operators, and turn it into diagonal row and
column scales of the LPs (:meth:`LoadUnits.static`, :meth:`~LoadUnits.kinematic`, :meth:`~LoadUnits.mcp`).
Each LP engine applies its scales once when it loads the LP (``R A C``) and inverts them once on its
answer (``v = C v^``, ``y = R y^``): :class:`~blockmpec.solvers.engines.highs.HighsLP` and
:class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM`.  The units themselves (block loads ``l_i``,
interface force units ``l_k``) are :class:`blockmpec.units.Units` (``ops.units``), the one units object
every method uses.

LP solvers test feasibility and optimality with absolute tolerances (HiGHS: 1e-7
by default; the block IPM: relative to the largest right-hand side).  A 1e-3 block
on a unit block carries loads 1e-6 times smaller: its whole equilibrium is then
below the tolerance, and HiGHS returned lam = 0.65 where 0.5 is right (the
verifier rejected it).  Scaling the LP so that each block's rows and each
interface's forces are O(1) makes the solvers' tolerances hold block by block,
as the verifier measures equilibrium.

For an LP compiled from :func:`blockmpec.formulations.static_lp` (and its variants with more
rows or columns) with column vector ``v`` and rows ``A v``:

* block ``i`` carries the load ``l_i = ||f_d,i|| + ||f_l,i||``; its three
  equilibrium rows are divided by ``l_i``;
* interface ``k`` gets the force unit ``l_k = min`` of ``l_i`` over its free blocks
  (a tiny block on a big one loads their interface with its own weight); the
  columns ``(t_k, n_k, m_k)`` are measured in ``(l_k, l_k, l_k L_k)``, a column group
  named in ``normal_like`` (e.g. the tie-break deviations ``d_k``) in ``l_k``;
* ``lam`` (and its copies) in :func:`multiplier_scale` units (1 unless the live
  load is far below or above the block loads);
* every other row is divided by its largest entry after the column scaling.

With ``R`` (rows) and ``C`` (columns) the scaled LP is ``R A C``, ``R b``, ``C c``;
``v = C v^`` and the row duals ``y = R y^`` (HiGHS convention, ``c - A^T y``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.formulations import LinearProgram
from blockmpec.units import Units

#: The multiplier is rescaled only when the live load in block units is outside [1/this, this].
MULTIPLIER_SCALE_RANGE = 1e3


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

    def static(self, lp: LinearProgram, normal_like: tuple[str, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        """Row and column scales ``(R, C)`` of a static-type LP (see the module docstring).

        Returns
        -------
        row_scale : ndarray, shape (rows,)
        column_scale : ndarray, shape (columns,)
        """
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
        return row_scale, column_scale

    def kinematic(self, lp: LinearProgram) -> tuple[np.ndarray, np.ndarray]:
        """Row and column scales of the kinematic LP (2): the dual of :meth:`static`.

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
        return row_scale, column_scale

    def mcp(self, form) -> tuple[np.ndarray, np.ndarray]:
        """Column and equality-row scales of a compiled MCP (3) in per-block units.

        The static and kinematic scalings of the LPs together: ``lam`` in :attr:`lam_unit`
        units ``s``, ``x`` in the interface force units ``C`` (``(l_k, l_k, l_k L_k)``), ``u`` in
        ``r = 1 / l_i`` per block, ``z_u``, ``z_f`` in the multiplier units ``S``
        (``1 / (l_k L_k)``, ``1 / (l_k max(1, mu_k))``); block ``i``'s equilibrium rows times ``r``,
        the compatibility rows times ``C``, the normalisation row times ``s``.  A pair row scales
        with its multiplier's column: ``column_scale[form.pair_column]``.  ``nlp`` and ``milp`` both
        solve (3) in these units.

        Returns
        -------
        column_scale : ndarray, shape (form.n_columns,)
        row_scale : ndarray, shape (rows of ``form.A``,)
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
        return column_scale, row_scale


def _assign(target: np.ndarray, columns: np.ndarray, values: np.ndarray) -> None:
    keep = columns >= 0
    target[columns[keep]] = values[keep]
