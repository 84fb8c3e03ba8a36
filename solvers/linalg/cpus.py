"""How many CPUs one solve's automatic settings may use.

:data:`CPUS_VARIABLE` (``BLOCKMPEC_CPUS``) caps them: the comparator sets it for solves that run side by side
(:mod:`blockmpec.bench.runner`), and a user may set it to keep their own parallel solves from competing.
"""

from __future__ import annotations

import os

#: the environment variable that caps the CPUs one solve's automatic settings use (the block IPM's
#: ``factor_processes="auto"``): a positive whole number, unset for every CPU the process may run on
CPUS_VARIABLE = "BLOCKMPEC_CPUS"


def cpu_budget() -> int | None:
    """The CPUs one solve may use by :data:`CPUS_VARIABLE` (None when it is unset or empty).

    Raises
    ------
    ValueError
        When the variable is set to something other than a positive whole number (the message names it).
    """
    value = os.environ.get(CPUS_VARIABLE, "").strip()
    if not value:
        return None
    try:
        budget = int(value)
    except ValueError:
        budget = 0
    if budget < 1:
        raise ValueError(f"{CPUS_VARIABLE}={value!r}: expected a positive whole number of CPUs")
    return budget


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the platform has one), at most :func:`cpu_budget`.
    The automatic settings of a solve (the block IPM's ``factor_processes="auto"``) read it."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    budget = cpu_budget()
    return cpus if budget is None else min(cpus, budget)
