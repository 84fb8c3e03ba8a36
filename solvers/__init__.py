"""Solver adapters: one module per method, each registering itself on import; ``plan`` chooses their engines.

What lives here: the methods (``static_lp.py`` ... ``milp.py``), ``plan.py`` (every size threshold), ``engines/``
(the algorithm drivers and the one HiGHS wrapper) and ``linalg/`` (the block IPM and its Cholesky).
Methods may import ``blockmpec``'s problem layer, ``formulations``, ``engines``, ``linalg`` and ``plan``.

Modules whose name starts with an underscore are shared helpers, not methods.
Importing this package imports no solver backend (highspy, cyipopt): each adapter
imports its backend inside ``setup``/``run``.  A module that fails to import is
recorded in :data:`FAILED_PLUGINS` (and listed by ``blockmpec methods``) instead
of breaking every other method.
"""

import importlib
import pkgutil

#: module name -> "ExceptionType: message" for plug-ins that failed to import
FAILED_PLUGINS: dict[str, str] = {}

for _info in pkgutil.iter_modules(__path__):
    if not _info.name.startswith("_") and not _info.ispkg:
        try:
            importlib.import_module(f"{__name__}.{_info.name}")
        except Exception as _exc:  # noqa: BLE001 - reported, not hidden
            FAILED_PLUGINS[_info.name] = f"{type(_exc).__name__}: {_exc}"
