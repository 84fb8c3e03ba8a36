"""Methods configured from one flat dictionary of options and engine settings, for the studies' option sets.

A study names a run by one dictionary (``{"start": "random", "acceleration": "anderson"}``, or ``KEY=VALUE`` text on
its command line); the library keeps a method's user-facing options (``bm.solve``) apart from its engine settings
(the method's ``Settings`` dataclass, run by :func:`blockmpec.run_solver`).  :func:`configured` sends each value to
where its name belongs; :func:`solve` runs it.  Only the public API is used.  Imported by path (``sys.path`` holds
``studies/_common`` when a script runs).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import blockmpec as bm


def split(method: str, values: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(options, settings)``: the values named by ``method``'s options, and the rest (its engine settings); a name
    that is neither is one clear error."""
    cls = bm.get_solver(method)
    options = {f.name for f in dataclasses.fields(cls.Options)}
    settings = {f.name for f in dataclasses.fields(cls.Settings)} if cls.Settings is not None else set()
    unknown = sorted(set(values) - options - settings)
    if unknown:
        raise bm.OptionError(f"method {method!r} has no option or setting {unknown[0]!r}; options: "
                             f"{', '.join(sorted(options))}; settings: {', '.join(sorted(settings)) or 'none'}")
    return ({k: v for k, v in values.items() if k in options}, {k: v for k, v in values.items() if k in settings})


def configured(method: str, **values: Any) -> bm.SolverBase:
    """An instance of ``method`` with ``values`` as its options and engine settings (see :func:`split`)."""
    options, settings = split(method, values)
    cls = bm.get_solver(method)
    try:
        engine_settings = cls.Settings(**settings) if settings else None
    except ValueError as exc:  # a bad setting: one line naming it
        raise bm.OptionError(f"method {method!r}: {exc}") from None
    return cls(settings=engine_settings, **options)


def solve(case, method: str, *, verify_tol: float = 1e-6, **values: Any) -> bm.Result:
    """:func:`blockmpec.solve` taking engine settings too (:func:`configured`, run by :func:`blockmpec.run_solver`)."""
    return bm.run_solver(configured(method, **values), case, verify_tol=verify_tol)
