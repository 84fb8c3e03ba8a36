"""Testing methods, built-in or your own: the conformance suite, the reference cases, cross-checks.

* :func:`check_solver` runs the conformance suite every method passes (the built-in ones in blockmpec's own test
  suite): the plug-in contract, closed forms, every built-in case verified or honestly failed, the time limit, the
  options, invariance to frame, order and units, results in the user's units.  It returns a table of checks and
  raises an ``AssertionError`` naming every failed one.
* :func:`reference_cases` gives the built-in cases with their references (closed forms, the certified minimum,
  the associative multiplier, published values), each :class:`Reference` with its source.
* :func:`assert_methods_agree` cross-checks methods on one structure.
* :mod:`blockmpec.testing.transforms`: the same structure moved, mirrored, reordered or in other units.

The pytest plugin ``pytest_blockmpec`` (installed with blockmpec, loaded by every pytest run) adds two fixtures:
``blockmpec_case`` (each quick reference case in turn) and ``blockmpec_cases`` (all of them, by label).
"""

from blockmpec.testing.agreement import assert_methods_agree
from blockmpec.testing.conformance import CHECKS, COLUMNS, ConformanceError, check_solver
from blockmpec.testing.references import Reference, ReferenceCase, reference_cases

__all__ = ["CHECKS", "COLUMNS", "ConformanceError", "Reference", "ReferenceCase", "assert_methods_agree",
           "check_solver", "reference_cases"]
