"""Solver adapters: one module per method, each registering itself on import.

Modules whose name starts with an underscore are shared helpers, not methods.
Importing this package imports no solver backend (highspy, cyipopt): each adapter
imports its backend inside ``setup``/``run``.
"""

import importlib
import pkgutil

for _info in pkgutil.iter_modules(__path__):
    if not _info.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_info.name}")
