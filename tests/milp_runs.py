"""Runs of ``milp`` with its options and its engine settings in one keyword list (tests only).

``bm.solve`` takes a method's options only; the engine settings (``lifting``, ``root_lp``, ``bigm_scale``,
``heuristic`` ...) are a :class:`~blockmpec.solvers.milp.MILPSettings` of a configured instance, run by
``bm.run_solver``.  ``solve_milp(case, engine="bnb", lifting="rlt")`` sorts the keywords into the two.
"""

from __future__ import annotations

import dataclasses

import blockmpec as bm
from blockmpec.solvers.milp import MILPOptions, MILPSettings, MILPSolver

OPTION_NAMES = frozenset(f.name for f in dataclasses.fields(MILPOptions))


def milp_solver(**keywords) -> MILPSolver:
    """A ``milp`` instance: the keywords that are options of :class:`MILPOptions` as options, the others as its
    :class:`MILPSettings` (a bad setting raises ValueError, a bad option OptionError)."""
    options = {k: v for k, v in keywords.items() if k in OPTION_NAMES}
    settings = {k: v for k, v in keywords.items() if k not in OPTION_NAMES}
    return MILPSolver(settings=MILPSettings(**settings) if settings else None, **options)


def solve_milp(case, **keywords) -> bm.Result:
    """``bm.run_solver`` of :func:`milp_solver` on ``case``."""
    return bm.run_solver(milp_solver(**keywords), case)
