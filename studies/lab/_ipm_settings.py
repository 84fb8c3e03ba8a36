"""Named settings sets of the block IPM that only experiments compare (``--ipm-settings NAME,...``).

Each set is a dict of :meth:`blockmpec.solvers.linalg.block_ipm.BlockIPM.settings` values: the library's
``DEFAULT_SETTINGS`` (what every LP runs) or ``EXACT_INNER_SETTINGS`` (what the interior fixed point runs), with
one or two values changed, mostly to what they were before a measured change.  :func:`named_settings` finds a set
by its lower-case name (``"default"``, ``"exact_inner"``, ``"previous"``, ...).  Lab scripts import this module by
path (their own folder is on ``sys.path``).
"""

from __future__ import annotations

from blockmpec.solvers.linalg.block_ipm import DEFAULT_SETTINGS, EXACT_INNER_SETTINGS, WIDE_DIAGONAL_SHIFT

#: the default with two correctors at every size (``correctors`` 2, the default before ``"auto"``;
#: ``--ipm-settings two_correctors,default``)
TWO_CORRECTORS_SETTINGS = {**DEFAULT_SETTINGS, "correctors": 2}
#: the default with four correctors at every size (``--ipm-settings two_correctors,four_correctors`` on small walls)
FOUR_CORRECTORS_SETTINGS = {**DEFAULT_SETTINGS, "correctors": 4}
#: the default before ``diagonal_shift`` 1e-16 (for ``--ipm-settings wide_shift,default`` comparisons)
WIDE_SHIFT_SETTINGS = {**DEFAULT_SETTINGS, "diagonal_shift": WIDE_DIAGONAL_SHIFT}
#: the refinement before the GMRES fallback (3 corrections and 2 sweeps; the measurement is in the comment above
#: ``DEFAULT_SETTINGS`` in ``blockmpec.solvers.linalg.block_ipm``)
SHORT_REFINEMENT_SETTINGS = {**EXACT_INNER_SETTINGS, "refinements": 3, "final_sweeps": 2}
#: stationary refinement only (the default before the Krylov fallback), with 8 and 4 or 3 and 2 corrections
STATIONARY_SETTINGS = {**EXACT_INNER_SETTINGS, "krylov_iterations": 0}
SHORT_STATIONARY_SETTINGS = {**SHORT_REFINEMENT_SETTINGS, "krylov_iterations": 0}
#: GMRES only after all ``refinements`` stationary corrections failed (the default before ``krylov_switch``)
LATE_KRYLOV_SETTINGS = {**EXACT_INNER_SETTINGS, "krylov_switch": float("inf")}
#: fewer solves per iteration on walls, not robust (a thin-voussoir arch stalls at 1e-8..1e-6; the comment above ``DEFAULT_SETTINGS``); for measurements only
FEWER_SOLVES_SETTINGS = {**DEFAULT_SETTINGS, "correctors": 4, "gondzio_accept": 1.0}
#: the settings before the lazy refinement: every direction refined on the whole system
PREVIOUS_SETTINGS = {**EXACT_INNER_SETTINGS, "lazy_refinement": False}
#: the default with one subtree half of every factorisation and solve of K in a worker process
#: (``factor_processes`` 2; the supernodal Cholesky only: two subtree halves)
TWO_PROCESS_SETTINGS = {**DEFAULT_SETTINGS, "factor_processes": 2}
#: the supernodal Cholesky in this process alone (``factor_processes`` 1, the default before ``"auto"``)
ONE_PROCESS_SETTINGS = {**DEFAULT_SETTINGS, "factor_processes": 1}
#: the default with the supernodal Cholesky's solves by the Python loop over supernodes even with compiled kernels
#: (``compiled_solves`` False, as before it existed; ``--ipm-settings python_solves,default`` measures it)
PYTHON_SOLVES_SETTINGS = {**DEFAULT_SETTINGS, "compiled_solves": False}
#: the default with the supernodal Cholesky's factorisations by the Python loop over supernodes even with compiled
#: kernels (``compiled_factorisation`` False, as before it existed; ``--ipm-settings python_factorisation,default``)
PYTHON_FACTORISATION_SETTINGS = {**DEFAULT_SETTINGS, "compiled_factorisation": False}
#: the default with scipy's sparse products even with compiled kernels (``compiled_products`` False, as before it
#: existed; ``--ipm-settings scipy_products,default``)
SCIPY_PRODUCTS_SETTINGS = {**DEFAULT_SETTINGS, "compiled_products": False}


def named_settings(name: str) -> dict:
    """The settings set ``<NAME>_SETTINGS`` (this module's sets, and the library's ``default`` and ``exact_inner``) by
    its lower-case name, for studies that compare them by name; an unknown name is one clear error."""
    settings = globals().get(f"{name.upper()}_SETTINGS")
    if not isinstance(settings, dict):
        known = sorted(key[:-len("_SETTINGS")].lower() for key, value in globals().items()
                       if key.endswith("_SETTINGS") and isinstance(value, dict))
        raise ValueError(f"block IPM: unknown settings set {name!r}; use one of {', '.join(known)}")
    return settings
