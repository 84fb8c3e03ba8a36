"""The verifier mutation check: one residual of the shared verifier always 0, in every process of a test run.

``python -m pytest --zero-residual NAME`` (tests/conftest.py) zeroes the residual ``NAME`` of
:func:`blockmpec.verify.residuals` in the test process, and sets :data:`VARIABLE` and puts this folder first on
``PYTHONPATH``, so that every Python process the tests start (the command line, the comparator's workers, xdist's
workers) imports this file at start-up and does the same.  Nothing in the library knows of it: the public function
``residuals`` is replaced, in :mod:`blockmpec.verify` and wherever it was imported by name, by one that calls it and
sets ``NAME`` to 0.  ``studies/lab/verifier_mutation.py`` runs the suite once per residual and reports which tests
fail; a residual that no test catches is a residual the suite does not check.
"""

from __future__ import annotations

import functools
import os
import sys

#: the environment variable naming the residual to zero (empty or unset: none)
VARIABLE = "BLOCKMPEC_ZERO_RESIDUAL"


def zero_residual(name: str) -> None:
    """Make :func:`blockmpec.verify.residuals` report ``name`` as 0 from now on, in this process."""
    import blockmpec.verify as verify

    if name not in verify.RESIDUAL_NAMES:
        raise ValueError(f"--zero-residual: no residual {name!r}; the residuals are {', '.join(verify.RESIDUAL_NAMES)}")
    original = verify.residuals
    if getattr(original, "zeroed", None) == name:
        return

    @functools.wraps(original)
    def residuals(*args, **kwargs):
        out = original(*args, **kwargs)
        if name in out:
            out[name] = 0.0
        return out

    residuals.zeroed = name
    for module in list(sys.modules.values()):  # every module that imported the function by name
        namespace = getattr(module, "__dict__", None) or {}
        for attribute, value in list(namespace.items()):
            if value is original:
                setattr(module, attribute, residuals)


if os.environ.get(VARIABLE):
    zero_residual(os.environ[VARIABLE])
