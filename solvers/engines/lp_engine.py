"""One LP-engine option set and one engine-selection rule for every LP-based method.

Engines: HiGHS (:class:`~blockmpec.solvers.engines.highs.HighsLP`: ``dual-simplex``,
``primal-simplex``, ``simplex`` (HiGHS's choice), ``ipm`` with crossover) and the
block interior-point method (:class:`~blockmpec.solvers.engines.block_ipm.BlockIPM`,
``block-ipm``).  Both have ``solve() -> LPOutcome`` (HiGHS dual signs) and
``set_row_upper``, and both work in the load units of
:func:`blockmpec.solvers.engines.scaling.load_scaling` when given the operators.

``"auto"`` (:func:`select_algorithm`) is the only selection rule:

* a cold solve of a model with more than :data:`AUTO_BLOCK_IPM_ROWS` rows, or whose
  block loads differ by more than :data:`AUTO_BLOCK_IPM_LOAD_SPREAD`, uses the block
  IPM when the caller needs no basis, HiGHS's IPM with crossover when it does (warm
  re-solves of a sequence start from a basis);
* everything else, and every warm re-solve, uses HiGHS's dual simplex.

Measured (``studies/lp_timing.py``, one run): 1,001-block wall, HiGHS IPM + crossover
9.7 s, block IPM 1.6 s; 10,046 blocks, HiGHS > 900 s, block IPM 47 s.  A 1e-3 block on
a unit block (loads 1e-6 apart): HiGHS's absolute tolerances give lam = 0.65 instead
of 0.5, which the verifier rejects; the block IPM in load units gets 0.5.
"""

from __future__ import annotations

from blockmpec.formulations import LinearProgram

#: HiGHS's algorithms
HIGHS_ALGORITHMS = ("simplex", "dual-simplex", "primal-simplex", "ipm")
#: every algorithm a user may name for a cold LP
ALGORITHMS = ("auto", *HIGHS_ALGORITHMS, "block-ipm")
#: algorithms that leave a basis for warm re-solves (the LP sequences need one)
BASIS_ALGORITHMS = ("auto", *HIGHS_ALGORITHMS)
AUTO_BLOCK_IPM_ROWS = 2000
AUTO_BLOCK_IPM_LOAD_SPREAD = 1e4


def select_algorithm(algorithm: str, n_rows: int, load_spread: float = 1.0, need_basis: bool = False,
                     warm: bool = False) -> str:
    """The algorithm ``"auto"`` stands for (any other name is returned unchanged); see the module docstring."""
    if algorithm != "auto":
        return algorithm
    if warm:
        return "dual-simplex"
    if n_rows > AUTO_BLOCK_IPM_ROWS or load_spread > AUTO_BLOCK_IPM_LOAD_SPREAD:
        return "ipm" if need_basis else "block-ipm"
    return "dual-simplex"


def cold_lp_engine(lp: LinearProgram, algorithm: str = "auto", time_limit: float = float("inf"), ops=None):
    """A solver for one static LP: :class:`BlockIPM` or :class:`HighsLP`, chosen by :func:`select_algorithm`."""
    from blockmpec.solvers.engines.block_ipm import BlockIPM, interface_blocks
    from blockmpec.solvers.engines.highs import HighsLP
    from blockmpec.solvers.engines.scaling import load_scaling, load_spread

    spread = load_spread(ops) if ops is not None else 1.0
    algorithm = select_algorithm(algorithm, lp.A.shape[0], spread)
    row_scale, column_scale = load_scaling(lp, ops) if ops is not None else (None, None)
    if algorithm == "block-ipm":
        return BlockIPM(lp, interface_blocks(lp), time_limit=time_limit, row_scale=row_scale, column_scale=column_scale)
    return HighsLP(lp, algorithm, time_limit, row_scale=row_scale, column_scale=column_scale)
