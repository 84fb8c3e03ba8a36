"""Registry of solver adapters (methods): the built-in ones, plug-ins of other packages, and classes named directly.

A solver adapter is a :class:`blockmpec.method.SolverBase` subclass.  A method is found in one of three ways:

* **built-in**: a module of the ``blockmpec.solvers`` package, decorated with :func:`register_solver` (the package
  imports every module in its folder, so adding a built-in method is adding a file);
* **plug-in**: a class that another distribution declares under the entry-point group ``blockmpec.methods``
  (:data:`ENTRY_POINT_GROUP`), in its ``pyproject.toml``::

      [project.entry-points."blockmpec.methods"]
      mine = "my_package.solver:MySolver"

  The entry point's name is the method's name and must equal the class's ``name``.  Once the distribution is
  installed, ``bm.solve(s, "mine")``, ``bm.list_solvers()``, ``blockmpec methods`` and ``blockmpec compare`` see it,
  in the comparator's worker processes too (they find the same installed distributions).  A plug-in that cannot be
  loaded (its module fails to import, the object is not a ``SolverBase`` subclass, its name is taken) is skipped
  with one :class:`~blockmpec.errors.PluginWarning` line naming the entry point, its distribution and the reason;
  the other methods work as before.  A built-in name always wins over a plug-in of the same name;
* **class path**: ``"my_module:MySolver"`` (module, colon, class) names a class directly, for a script that is not
  packaged yet: ``bm.solve(s, "my_module:MySolver")``, ``blockmpec solve --method my_module:MySolver`` (the
  command line also looks in the current folder).  The class is imported, checked and used as it is; it is not
  added to :func:`list_solvers`.

Everything is loaded on first lookup, never at ``import blockmpec``: the built-ins when a method is first looked up,
the plug-ins when a name is not a built-in one or when the list of methods is asked for.  A solver's backend library
(highspy, cyipopt) is imported only when that solver runs.
"""

from __future__ import annotations

import dataclasses
import importlib
import sys
import warnings
from typing import TYPE_CHECKING

from blockmpec.errors import OptionError, PluginWarning, UnknownNameError

if TYPE_CHECKING:
    from blockmpec.method import SolverBase

#: the entry-point group under which other distributions declare their methods
ENTRY_POINT_GROUP = "blockmpec.methods"
#: the problems a method may answer (its class attribute ``problem``)
PROBLEMS = ("associative", "non-associative")

_SOLVERS: dict[str, type[SolverBase]] = {}
#: method name -> where a plug-in came from (entry point and distribution)
_PLUGIN_SOURCES: dict[str, str] = {}
#: class path "module:Class" -> the class it names
_CLASS_PATHS: dict[str, type[SolverBase]] = {}
_builtins_loaded = False
#: entry points already tried, as (distribution, name, value): each is loaded (or warned about) once per process
_tried: set[tuple[str, str, str]] = set()
#: ``sys.path`` at the last scan of the entry points (a changed path may hold other distributions)
_scanned_path: tuple[str, ...] | None = None


@dataclasses.dataclass(frozen=True)
class PluginFailure:
    """A plug-in that was not loaded: its entry point (``name = value``), its distribution and why."""

    entry_point: str
    distribution: str
    reason: str

    def __str__(self) -> str:
        return (f"method plug-in {self.entry_point} (entry point of {self.distribution}) not loaded: "
                f"{self.reason}")


_FAILURES: list[PluginFailure] = []


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
    _PLUGIN_SOURCES.pop(name, None)


def _load_builtins() -> None:
    global _builtins_loaded
    if not _builtins_loaded:
        importlib.import_module("blockmpec.solvers")
        _builtins_loaded = True


def _entry_points(name: str | None = None):
    from importlib.metadata import entry_points

    found = entry_points(group=ENTRY_POINT_GROUP)
    return [ep for ep in found if name is None or ep.name == name]


def _distribution(ep) -> str:
    dist = getattr(ep, "dist", None)
    return f"{dist.name} {dist.version}" if dist is not None else "an unknown distribution"


def bad_name(name: object) -> str | None:
    """Why ``name`` cannot name a method, or None: a method's name is a non-empty string without spaces, commas or
    colons (lists of methods on the command line are comma-separated, and ``module:Class`` names a class)."""
    if not isinstance(name, str) or not name or any(c.isspace() or c in ",:" for c in name):
        return f"a method's name is a non-empty string without spaces, commas or colons; got {name!r}"
    return None


def not_a_method(obj: object, name: str | None = None) -> str | None:
    """Why ``obj`` cannot be registered as a method (as ``name``, if given), or None.

    A method is a :class:`~blockmpec.method.SolverBase` subclass with a ``name`` (:func:`bad_name`) and a
    ``problem`` in :data:`PROBLEMS`.  The whole contract is checked by :func:`blockmpec.testing.check_solver`."""
    from blockmpec.method import SolverBase

    if not (isinstance(obj, type) and issubclass(obj, SolverBase)):
        return f"{obj!r} is not a subclass of blockmpec.SolverBase"
    own = getattr(obj, "name", None)
    if bad_name(own):
        return f"class {obj.__name__}: {bad_name(own)}"
    if name is not None and own != name:
        return f"the entry point's name {name!r} and the class's name {own!r} differ; make them equal"
    if getattr(obj, "problem", None) not in PROBLEMS:
        return f"class {obj.__name__}: problem must be one of {', '.join(PROBLEMS)}; got {getattr(obj, 'problem', None)!r}"
    return None


def _load_entry_points(name: str | None = None) -> None:
    """Load the plug-ins not tried yet (only those called ``name``, if given).  With ``name=None`` the scan is skipped
    while ``sys.path`` is unchanged since the last full scan."""
    global _scanned_path
    path = tuple(sys.path)
    if name is None:
        if path == _scanned_path:
            return
        _scanned_path = path
    for ep in _entry_points(name):
        dist = _distribution(ep)
        key = (dist, ep.name, ep.value)
        if key in _tried:
            continue
        _tried.add(key)
        try:
            cls = ep.load()
        except Exception as exc:  # noqa: BLE001 - a broken plug-in is a warning, never a crash
            _fail(ep, dist, f"importing it raised {type(exc).__name__}: {exc}")
            continue
        reason = not_a_method(cls, ep.name)
        if reason is None and _SOLVERS.get(ep.name, cls) is not cls:
            other = _SOLVERS[ep.name]
            reason = f"the name {ep.name!r} is taken by {_describe(ep.name, other)}"
        if reason is not None:
            _fail(ep, dist, reason)
            continue
        _SOLVERS[ep.name] = cls
        _PLUGIN_SOURCES[ep.name] = f"plug-in {ep.name} = {ep.value} (entry point of {dist})"


def _fail(ep, dist: str, reason: str) -> None:
    failure = PluginFailure(f"{ep.name} = {ep.value}", dist, " ".join(reason.split()))
    _FAILURES.append(failure)
    warnings.warn(str(failure), PluginWarning, stacklevel=4)


def _describe(name: str, cls: type) -> str:
    if name in _PLUGIN_SOURCES:
        return _PLUGIN_SOURCES[name]
    if cls.__module__.startswith("blockmpec.solvers."):
        return f"the built-in method ({cls.__module__}.{cls.__qualname__})"
    return f"the method registered by {cls.__module__}.{cls.__qualname__}"


def plugin_failures() -> list[PluginFailure]:
    """The plug-ins that could not be loaded so far in this process (each was also warned about once)."""
    return list(_FAILURES)


def solver_source(name: str) -> str:
    """Where the method ``name`` comes from: ``"built-in"``, ``"plug-in NAME = module:Class (entry point of
    DISTRIBUTION VERSION)"``, ``"registered by module.Class"`` (at run time) or ``"class module:Class"``."""
    cls = get_solver(name)
    if ":" in name and name not in _SOLVERS:
        return f"class {name}"
    if name in _PLUGIN_SOURCES:
        return _PLUGIN_SOURCES[name]
    if cls.__module__.startswith("blockmpec.solvers."):
        return "built-in"
    return f"registered by {cls.__module__}.{cls.__qualname__}"


def _class_from_path(path: str) -> type[SolverBase]:
    """The class named ``module:Class`` (imported, checked, cached); bad names are one-line errors."""
    if path in _CLASS_PATHS:
        return _CLASS_PATHS[path]
    module_name, _, qualname = path.partition(":")
    if not module_name or not qualname or ":" in qualname:
        raise UnknownNameError(f"method {path!r}: expected a method name or MODULE:CLASS, e.g. my_package.solver:MySolver")
    try:
        obj = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and module_name.startswith(exc.name):
            raise UnknownNameError(f"method {path!r}: no module named {exc.name!r} (is it installed, or in the current "
                                   "folder?)") from None
        raise OptionError(f"method {path!r}: importing {module_name} raised {type(exc).__name__}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - the user's module is input: its failure is one line
        raise OptionError(f"method {path!r}: importing {module_name} raised {type(exc).__name__}: {exc}") from None
    for part in qualname.split("."):
        obj = getattr(obj, part, None)
        if obj is None:
            raise UnknownNameError(f"method {path!r}: module {module_name} has no {qualname!r}")
    reason = not_a_method(obj)
    if reason is None:
        _load_builtins()
        taken = _SOLVERS.get(obj.name)
        if taken is not None and taken is not obj:
            reason = f"its name {obj.name!r} is taken by {_describe(obj.name, taken)}; give the class another name"
    if reason is not None:
        raise OptionError(f"method {path!r}: {reason}")
    _CLASS_PATHS[path] = obj
    return obj


def get_solver(name: str) -> type[SolverBase]:
    """The solver class registered as ``name`` (built-in or plug-in), or the class a ``"module:Class"`` path names."""
    _load_builtins()
    if name in _SOLVERS:
        return _SOLVERS[name]
    if isinstance(name, str) and ":" in name:
        return _class_from_path(name)
    _load_entry_points(name)
    try:
        return _SOLVERS[name]
    except (KeyError, TypeError):
        raise UnknownNameError(f"unknown method {name!r}; available methods: {', '.join(list_solvers())}") from None


def list_solvers(problem: str | None = None) -> list[str]:
    """Registered method names (built-ins first, then plug-ins), optionally only those answering ``problem``."""
    _load_builtins()
    _load_entry_points()
    return [n for n, c in _SOLVERS.items() if problem is None or c.problem == problem]
