"""The compiled LPs of a sequence of modified LPs (5): the fixed point's and the SLP's step, tie-break and
associative LPs, compiled once per structure, with the data of their friction rows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.formulations.pyomo_compile import LinearProgram, compiled_linear
from blockmpec.formulations.static_lp import cohesion_factor, modified_lp, static_lp, surface_slope
from blockmpec.formulations.tie_break import tie_break_lp
from blockmpec.operators import Operators


@dataclass(frozen=True, eq=False)
class StepLPs:
    """The compiled LPs of a sequence of modified LPs (5) (the fixed point, the SLP), and the data of their rows.

    The step LP's friction rows read ``+-t_k + s_k n_k <= -(tan(phi_k) - s_k) n*_k``: an engine moves ``n*``
    by their right-hand side, ``-cohesion_factor * n*`` on both rows of each interface, and never rebuilds
    them.

    Attributes
    ----------
    step : LinearProgram
        (5) with slope ``s`` at ``n* = 0`` (:func:`modified_lp`).
    tie_break : LinearProgram or None
        Its tie-break LP (:func:`~blockmpec.formulations.tie_break_lp`), if asked for.
    associative : LinearProgram or None
        The static LP (1) (friction ``tan(phi)``), if asked for; the same rows and columns as ``step``.
    friction, dilatancy, slope : ndarray, shape (c,)
        ``tan(phi)``, ``tan(psi)`` and the step LP's slope ``s`` per interface.
    coulomb : csr_array, shape (2c, 3c)
        ``N_f^T``: the Coulomb rows' values ``N_f^T x`` (friction admissibility ``<= 0``).
    normal_index : ndarray of int, shape (c,)
        Positions of the normal forces in ``x`` (``ops.normal_index``).
    friction_contact : ndarray of int, shape (friction rows,)
        Contact of each friction row (``ops.friction_contact``): the rows' right-hand side is
        ``-cohesion_factor[friction_contact] * n*[friction_contact]``.
    """

    step: LinearProgram
    tie_break: LinearProgram | None
    associative: LinearProgram | None
    friction: np.ndarray
    dilatancy: np.ndarray
    slope: np.ndarray
    coulomb: sp.csr_array
    normal_index: np.ndarray
    friction_contact: np.ndarray

    @property
    def cohesion_factor(self) -> np.ndarray:
        """``tan(phi) - s`` per interface: the friction rows' right-hand side is ``-cohesion_factor * n*``."""
        return cohesion_factor(self.friction, self.slope)


def step_lps(ops: Operators, alpha: float = 0.0, tie_break: bool = True, associative: bool = True) -> StepLPs:
    """Compile the LPs of a sequence of modified LPs with slope ``s = tan(psi) + alpha (tan(phi) - tan(psi))``
    (``alpha = 0``: eq. (5)), through the compiled-formulation cache."""
    c = ops.n_contacts
    slope = np.broadcast_to(surface_slope(ops.friction, ops.dilatancy, alpha), (c,)).astype(float)
    return StepLPs(
        step=compiled_linear(modified_lp, ops, np.zeros(c), slope=slope),
        tie_break=compiled_linear(tie_break_lp, ops, np.zeros(c), slope=slope) if tie_break else None,
        associative=compiled_linear(static_lp, ops) if associative else None,
        friction=np.broadcast_to(np.asarray(ops.friction, float), (c,)).copy(),
        dilatancy=np.broadcast_to(np.asarray(ops.dilatancy, float), (c,)).copy(),
        slope=slope,
        coulomb=sp.csr_array(ops.N_f.T),
        normal_index=ops.normal_index,
        friction_contact=ops.friction_contact,
    )
