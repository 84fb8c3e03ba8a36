"""The one name of each fact a solver reports in ``Result.extra``.

Solvers write these keys (and only these spellings) when they report the fact;
the comparator, the figures and the tests read them.  Method-specific
diagnostics may add other keys, but a fact listed here never gets a second name.
"""

#: the associative multiplier (static LP (1)) a method computed on the way (start, bound)
ASSOCIATIVE_MULTIPLIER = "associative_multiplier"
#: a certified lower bound on the minimum of (4) (``milp``; upper bound with ``sense="max"``)
BOUND = "bound"
#: ``|multiplier - bound|`` and that over ``max(|multiplier|, 1e-12)``
GAP_ABS = "gap_abs"
GAP_REL = "gap_rel"
#: ``"min"`` or ``"max"``: which extremum of the multiplier over the solutions of (3) a run seeks
SENSE = "sense"
#: which of a method's engines produced the result (``fixed-point``: ``"simplex"``, ``"interior"``, ...;
#: ``milp``: ``"root"``, ``"highs"``, ``"scip"``, ``"bnb"``)
ENGINE = "engine"
#: number of LP solves, and LP time per kind (dict kind -> seconds)
LP_SOLVES = "lp_solves"
LP_TIME_S = "lp_time_s"
#: seconds spent before the timed solve by the adapter's set-up, and in assembly
ASSEMBLY_TIME_S = "assembly_time_s"
