"""Registry of solver adapters (methods).

A solver adapter is a :class:`blockmpec.method.SolverBase` subclass in a module of
the top-level ``solvers`` package, decorated with :func:`register_solver`.  The
``solvers`` package imports every module in its folder, so adding a method is
adding a file.  Plug-ins are loaded on first lookup; the core never imports them
at import time, and a solver's backend library (highspy, cyipopt) is imported only
when that solver runs.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from blockmpec.errors import UnknownNameError

if TYPE_CHECKING:
    from blockmpec.method import SolverBase

_SOLVERS: dict[str, type[SolverBase]] = {}
_loaded = False


def register_solver(cls: type[SolverBase]) -> type[SolverBase]:
    """Class decorator: register a solver under its ``name``."""
    name = cls.name
    if name in _SOLVERS and _SOLVERS[name] is not cls:
        raise ValueError(f"solver name {name!r} is registered twice ({_SOLVERS[name].__module__} and {cls.__module__})")
    _SOLVERS[name] = cls
    return cls


def unregister_solver(name: str) -> None:
    """Remove the solver registered as ``name`` (nothing if there is none): for tests and studies that register
    methods of their own for a while."""
    _SOLVERS.pop(name, None)


def _load_plugins() -> None:
    global _loaded
    if not _loaded:
        importlib.import_module("blockmpec.solvers")
        _loaded = True


def get_solver(name: str) -> type[SolverBase]:
    """The solver class registered as ``name``."""
    _load_plugins()
    try:
        return _SOLVERS[name]
    except KeyError:
        raise UnknownNameError(f"unknown method {name!r}; available methods: {', '.join(list_solvers())}") from None


def list_solvers(problem: str | None = None) -> list[str]:
    """Registered method names, optionally only those answering ``problem``."""
    _load_plugins()
    return [n for n, c in _SOLVERS.items() if problem is None or c.problem == problem]
