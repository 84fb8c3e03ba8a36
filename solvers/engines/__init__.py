"""Algorithm drivers shared by the methods: not methods themselves, never registered.

What lives here: the one HiGHS wrapper (:mod:`.highs`, the only module that imports highspy), the LP engines
(:mod:`.lp_engine`, :mod:`.block_lp`), the units reduction (:mod:`.scaling`), the LP sequence (:mod:`.lp_sequence`),
the interior fixed point, the piece LPs, the Newton system, the MIP engines and the branch and bound, and one
stopping criterion (:mod:`.stopping`).  Engines import ``blockmpec``'s lower layers, ``formulations``, ``linalg``
and ``plan``; they get matrices and a :class:`~.scaling.LoadUnits`, never the operators, and one deadline.
"""
