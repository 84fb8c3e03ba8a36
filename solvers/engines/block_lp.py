"""The block interior-point method (:mod:`blockmpec.solvers.linalg.block_ipm`) as an LP engine of the methods.

:class:`BlockLP` is :class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM` whose :meth:`~BlockLP.solve` returns an
:class:`~blockmpec.solvers.engines.highs.LPOutcome` with the library's :class:`~blockmpec.result.Status`: the one
place where the linear-algebra layer's statuses are mapped.  :func:`interface_blocks` gives the block columns of a
static LP (the forces ``(t, n, m)`` of each interface).
"""

from __future__ import annotations

import numpy as np

from blockmpec.deadline import Deadline
from blockmpec.result import Status
from blockmpec.solvers.engines.highs import LPOutcome
from blockmpec.solvers.engines.scaling import Scaling
from blockmpec.solvers.linalg.block_ipm import BlockIPM, IPMOutcome

__all__ = ["BlockLP", "interface_blocks", "lp_outcome"]


def lp_outcome(out: IPMOutcome) -> LPOutcome:
    """The block IPM's outcome with the library's status (the same name: ``optimal``, ``acceptable`` ...)."""
    return LPOutcome(Status(out.status.value), out.raw_status, out.objective, out.v, out.row_dual, out.iterations,
                     out.message)


class BlockLP(BlockIPM):
    """:class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM` returning :class:`LPOutcome` (see the module docstring).

    ``scaling``: the :class:`~blockmpec.solvers.engines.scaling.Scaling` of ``lp`` (load units), handed to the
    block IPM as its ``row_scale`` and ``column_scale`` (which it applies to the equality rows and the columns, and
    inverts on its answer); the other arguments are :class:`~blockmpec.solvers.linalg.block_ipm.BlockIPM`'s.
    """

    def __init__(self, lp, block_columns: np.ndarray, scaling: Scaling | None = None, **kwargs) -> None:
        if scaling is not None:
            kwargs.update(row_scale=scaling.row, column_scale=scaling.column)
        super().__init__(lp, block_columns, **kwargs)

    def solve(self, deadline: Deadline | None = None) -> LPOutcome:
        """Solve the LP within ``deadline`` (None: the one given before; see :meth:`BlockIPM.solve`); the outcome
        with the library's status."""
        return lp_outcome(super().solve(None if deadline is None else deadline.end))


def interface_blocks(lp) -> np.ndarray:
    """Columns of ``x = (t_k, n_k, m_k)`` per interface, shape (c, 3), for a compiled static LP."""
    return lp.columns["x"].reshape(-1, 3)
