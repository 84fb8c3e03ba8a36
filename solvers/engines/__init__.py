"""Algorithm drivers shared by the methods: not methods themselves, never registered.

What lives here: the one HiGHS wrapper (:mod:`.highs`, the only module that imports highspy), the LP engines
(:mod:`.lp_engine`, :mod:`.block_lp`), the units reduction (:mod:`.scaling`), the LP sequence (:mod:`.lp_sequence`),
the interior fixed point, the piece LPs, the Newton system, the MIP engines and the branch and bound, and one
stopping criterion (:mod:`.stopping`).  Engines import ``blockmpec``'s lower layers, ``formulations``, ``linalg``
and ``plan``; they get matrices and a :class:`~.scaling.LoadUnits`, never the operators, and one deadline.

HiGHS through its wrapper
-------------------------
An engine that solves an LP by HiGHS holds a :class:`~.highs.HighsLP` and changes it only through its methods,
every value in the problem's units (the wrapper sends it through the LP's scaling)::

    hl = HighsLP(lp, "dual-simplex", scaling=units.static(lp))   # or no scaling
    hl.set_costs(columns, costs)
    hl.set_row_bounds(rows, lower, upper)          # set_row_upper(rows, upper) also updates lp.row_upper
    hl.set_column_bounds(columns, lower, upper)
    hl.set_coefficients(rows, columns, values)     # the basis is kept
    hl.add_rows(matrix, lower, upper)
    hl.set_feasibility_tolerances(1e-9)            # or primal=..., dual=...
    hl.set_presolve(False); hl.set_iteration_limit(n)
    col, row = hl.basis_status(); hl.set_basis(col, row); hl.clear_basis()
    out = hl.solve(deadline=deadline, cold=False)   # LPOutcome: status (mapped once), v, row_dual, iterations
    ray = hl.dual_ray()                             # after an infeasible solve

Algorithms: :data:`~blockmpec.solvers.plan.BASIS_ALGORITHMS` and :data:`~.highs.IPM_WITHOUT_CROSSOVER`.  A MILP
goes to :func:`~.highs.highs_mip`, a one-off LP to :func:`~.highs.solve_lp`.  No module but :mod:`.highs` calls a
highspy method or imports a name outside ``highs.__all__``
(``tests/test_layering.py``, which lists the modules not yet moved).

One units reduction
-------------------
:meth:`LoadUnits.static <.scaling.LoadUnits.static>` and :meth:`~.scaling.LoadUnits.kinematic` give a
:class:`~.scaling.Scaling` of an LP (``R A C``; :meth:`~.scaling.Scaling.apply`, and back by
:meth:`~.scaling.Scaling.primal`, :meth:`~.scaling.Scaling.dual`); :meth:`~.scaling.LoadUnits.mcp` an
:class:`~.scaling.MCPScaling` of (3) (columns, equality rows, pair slacks), whose
:meth:`~.scaling.MCPScaling.lp_scaling` scales an LP made of its rows.  An engine hands the scaling to the
:class:`~.highs.HighsLP` or :class:`~.block_lp.BlockLP` it solves with and gets iterates in the problem's units;
it multiplies by no scale itself.
"""
