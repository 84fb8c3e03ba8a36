"""Pyomo statements of the limit-analysis problems, built from the sparse operators.

* :func:`static_lp`      problem (1), and the modified associative LP (5) of the fixed point;
* :func:`kinematic_lp`   problem (2);

Each builder returns a :class:`PyomoProblem`: the ``ConcreteModel`` plus handles to
its variable and constraint groups, so that adapters never search components by
name.  :func:`compile_linear` turns a linear model into sparse matrices once; the
solver adapters work on those.  The models know nothing of any solver.
"""

from formulations._pyomo import LinearProgram, PyomoProblem, compile_linear
from formulations.kinematic_lp import kinematic_lp
from formulations.static_lp import modified_lp, static_lp

__all__ = ["LinearProgram", "PyomoProblem", "compile_linear", "kinematic_lp", "modified_lp", "static_lp"]
