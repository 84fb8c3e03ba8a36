"""One LP engine for every cold LP of the methods, chosen by :func:`blockmpec.solvers.plan.lp_algorithm`.

Engines: HiGHS (:class:`~blockmpec.solvers.engines.highs.HighsLP`: ``dual-simplex``, ``primal-simplex``,
``simplex`` (HiGHS's choice), ``ipm`` with crossover) and the block interior-point method
(:class:`~blockmpec.solvers.engines.block_lp.BlockLP`, ``block-ipm``).  Both have
``solve(deadline=...) -> LPOutcome`` (HiGHS dual signs) and ``set_row_upper``, and both work in the load units of
:class:`~blockmpec.solvers.engines.scaling.LoadUnits` when given them.
"""

from __future__ import annotations

from blockmpec.formulations import LinearProgram
from blockmpec.solvers.plan import lp_algorithm

__all__ = ["cold_lp_engine"]


def cold_lp_engine(lp: LinearProgram, algorithm: str = "auto", units=None):
    """A solver for one static LP: :class:`BlockLP` or :class:`HighsLP`, chosen by
    :func:`~blockmpec.solvers.plan.lp_algorithm` (the block IPM with the plan's
    :data:`~blockmpec.solvers.plan.BLOCK_IPM_RULES`); ``units``: a
    :class:`~blockmpec.solvers.engines.scaling.LoadUnits` (None: unscaled)."""
    from blockmpec.solvers.engines.block_lp import BlockLP, interface_blocks
    from blockmpec.solvers.engines.highs import HighsLP
    from blockmpec.solvers.engines.scaling import Scaling
    from blockmpec.solvers.plan import BLOCK_IPM_RULES

    spread = units.load_spread if units is not None else 1.0
    algorithm = lp_algorithm(algorithm, lp.A.shape[0], spread)
    scaling = units.static(lp) if units is not None else Scaling.identity(lp)
    if algorithm == "block-ipm":
        return BlockLP(lp, interface_blocks(lp), scaling=scaling, rules=BLOCK_IPM_RULES)
    return HighsLP(lp, algorithm, scaling=scaling)
