"""Pyomo statements of the limit-analysis problems, built from the sparse operators.

What lives here: the one statement of each problem ((1), (2), (3), (4), the fixed point's LPs) and their compiled
matrices; every engine that needs (3) in matrix form derives it from here (the verifier is the deliberate second
statement).  It imports pyomo and ``blockmpec``'s problem layer, never a solver.

* :func:`static_lp`      problem (1), and the modified associative LP (5) of the fixed point;
* :func:`step_lps`       the compiled LPs of a sequence of (5) (fixed point, SLP) with their rows' data;
* :func:`tie_break_lp`   the fixed point's tie-break LP (picks one optimal point of a step LP (5));
* :func:`kinematic_lp`   problem (2);
* :func:`mcp`            the non-associative MCP (3), with ``pyomo.mpec`` complementarity pairs;
* :func:`mpec`           the MPEC (4): (3) plus ``min lam``;
* :func:`compile_mcp`    (3) compiled once per structure into a :class:`CompiledMCP` (the
                         matrices, pairs and named slices every non-associative solver reads);
* :func:`evaluate_mcp`   evaluates a solution through the Pyomo model (a cross-check of the verifier);

Each builder returns a :class:`PyomoProblem`: the ``ConcreteModel`` plus handles to
its variable and constraint groups, so that adapters never search components by
name.  :func:`compile_linear` turns a linear model into sparse matrices once; the
solver adapters work on those; :func:`compiled_linear` does it through the
compiled-formulation cache (a hit builds nothing), and :func:`pause_gc` runs a
builder with the cyclic garbage collector paused, as the cache does.  The models
know nothing of any solver.
"""

from blockmpec.formulations.compiled import CompiledMCP, compile_mcp
from blockmpec.formulations.kinematic_lp import kinematic_lp
from blockmpec.formulations.mcp import evaluate_mcp, mcp
from blockmpec.formulations.mpec import mpec
from blockmpec.formulations.pyomo_compile import LinearProgram, PyomoProblem, compile_linear, compiled_linear, pause_gc
from blockmpec.formulations.sequence import StepLPs, step_lps
from blockmpec.formulations.static_lp import modified_lp, static_lp
from blockmpec.formulations.tie_break import tie_break_lp

__all__ = [
    "CompiledMCP", "LinearProgram", "PyomoProblem", "StepLPs", "compile_linear", "compile_mcp", "compiled_linear",
    "evaluate_mcp", "kinematic_lp", "mcp", "modified_lp", "mpec", "pause_gc", "static_lp", "step_lps", "tie_break_lp",
]
