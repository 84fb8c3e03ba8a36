"""The layout's arrows, checked on the import graph of the source (every import, module level or inside a function).

Layers, from the bottom up (a module may import its own layer and the layers below, never one above):

0. ``blockmpec.errors``, ``facts``, ``units``, ``deadline``, ``progress``, ``options`` -- plain values and rules;
1. the problem: ``geometry``, ``operators``, ``cases``, ``structure_file``, ``result``, ``verify``, ``report``,
   ``drawings``, ``contacts``, ``three_d`` (3D blocks; its figures and exact cone are layer 7);
2. ``blockmpec.formulations`` -- the Pyomo statements;
3. ``blockmpec.solvers.linalg`` -- the block IPM and its Cholesky (numpy, scipy, numba, pymetis and threadpoolctl
   only: no other blockmpec module);
4. ``blockmpec.solvers.engines`` and ``blockmpec.solvers.plan``;
5. the plug-in contract: ``blockmpec.method`` (``SolverBase``) and ``blockmpec.registry``;
6. the methods: ``blockmpec.solvers.<method>``;
7. ``blockmpec.solver`` (``solve``, ``run_solver``), ``blockmpec.pushover`` (with its configuration and contact
   updates), ``blockmpec.plot`` (and ``three_d.plot``, ``three_d.cone``) and the package ``blockmpec`` itself;
8. ``blockmpec.bench`` -- the comparator harness, which nothing else in the library imports -- and
   ``blockmpec.testing``, the conformance suite and reference cases for methods' tests;
9. ``blockmpec.cli`` and ``blockmpec.__main__``.

Also: no import cycle among the library's modules; only ``blockmpec.solvers.engines.highs`` imports highspy; no
module of the library or the tests imports ``studies``; tests and studies use blockmpec's public names only (no
private attribute, module or name: the engines are tested through their public functions).  The registry loads the
methods by name at run time (``importlib``), which is not an import arrow.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: source folder -> the package it installs as
PACKAGES = {"blockmpec": "blockmpec", "formulations": "blockmpec.formulations", "solvers": "blockmpec.solvers"}

LAYERS = [
    ("blockmpec.errors", "blockmpec.facts", "blockmpec.units", "blockmpec.deadline", "blockmpec.progress",
     "blockmpec.options"),
    ("blockmpec.geometry", "blockmpec.operators", "blockmpec.cases", "blockmpec.structure_file", "blockmpec.result",
     "blockmpec.verify", "blockmpec.report", "blockmpec.drawings", "blockmpec.contacts", "blockmpec.three_d"),
    ("blockmpec.formulations",),
    ("blockmpec.solvers.linalg",),
    ("blockmpec.solvers.engines", "blockmpec.solvers.plan"),
    ("blockmpec.method", "blockmpec.registry"),
    ("blockmpec.solvers",),
    ("blockmpec.solver", "blockmpec.pushover", "blockmpec.pushover_motion", "blockmpec.pushover_contacts",
     "blockmpec.pushover_plot", "blockmpec.plot", "blockmpec", "blockmpec.three_d.plot", "blockmpec.three_d.cone"),
    ("blockmpec.bench", "blockmpec.testing"),
    ("blockmpec.cli", "blockmpec.pushover_cli", "blockmpec.__main__"),
]


def _modules() -> dict[str, Path]:
    """Module name -> source file of every module of the library."""
    out = {}
    for folder, package in PACKAGES.items():
        base = ROOT / folder
        for path in sorted(base.rglob("*.py")):
            parts = list(path.relative_to(base).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([package, *parts])] = path
    return out


MODULES = _modules()


def _is_package(name: str) -> bool:
    return MODULES[name].name == "__init__.py"


def _type_checking_lines(tree: ast.AST) -> set[int]:
    """Lines inside ``if TYPE_CHECKING:`` blocks (annotations only, never run)."""
    lines = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", getattr(node.test, "attr", None)) == "TYPE_CHECKING":
            for child in node.body:
                lines.update(range(child.lineno, (child.end_lineno or child.lineno) + 1))
    return lines


def imports_of(name: str) -> set[str]:
    """Every module name ``name`` imports (absolute, resolved; modules of other distributions included)."""
    tree = ast.parse(MODULES[name].read_text(), filename=str(MODULES[name]))
    skip = _type_checking_lines(tree)
    package = name if _is_package(name) else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if getattr(node, "lineno", None) in skip:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            submodules = [f"{module}.{alias.name}" for alias in node.names if f"{module}.{alias.name}" in MODULES]
            found.update(submodules)  # "from package import module": an arrow to the module
            if len(submodules) < len(node.names):  # a name defined in the module itself
                found.add(module)
    return found


def _library_target(module: str) -> str | None:
    """The library module an imported name refers to (its longest known prefix), or None for another distribution."""
    parts = module.split(".")
    for k in range(len(parts), 0, -1):
        candidate = ".".join(parts[:k])
        if candidate in MODULES:
            return candidate
    return None


def _graph() -> dict[str, set[str]]:
    graph = {}
    for name in MODULES:
        targets = {_library_target(m) for m in imports_of(name)}
        graph[name] = {t for t in targets if t is not None and t != name}
    return graph


GRAPH = _graph()


def _layer(name: str) -> int:
    """The layer of a module: the most specific prefix listed in :data:`LAYERS`."""
    best, best_len = None, -1
    for level, prefixes in enumerate(LAYERS):
        for prefix in prefixes:
            if (name == prefix or name.startswith(prefix + ".")) and len(prefix) > best_len:
                best, best_len = level, len(prefix)
    assert best is not None, f"{name} is in no layer of tests/test_layering.py: place it"
    return best


def test_every_module_has_a_layer():
    for name in MODULES:
        _layer(name)


def test_arrows_only_point_down():
    """A module imports only its own layer and the layers below (a package's __init__ may re-export its own
    submodules)."""
    up = []
    for name, targets in GRAPH.items():
        for target in targets:
            if target.startswith(name + ".") and _is_package(name):
                continue  # a package re-exporting its own submodules
            if _layer(target) > _layer(name):
                up.append(f"{name} (layer {_layer(name)}) imports {target} (layer {_layer(target)})")
    assert not up, "\n".join(sorted(up))


def test_no_import_cycle_among_the_library_modules():
    """Tarjan's strongly connected components of the import graph: every component is one module."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            components.append(component)

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in GRAPH:
        if v not in index:
            visit(v)
    # a package and its own submodules importing each other is one unit, not a layering cycle
    cycles = [sorted(c) for c in components if len(c) > 1
              and not all(m == min(c, key=len) or m.startswith(min(c, key=len) + ".") for m in c)]
    assert not cycles, cycles


def test_linalg_imports_no_other_blockmpec_module():
    bad = [f"{name} imports {t}" for name, targets in GRAPH.items() if name.startswith("blockmpec.solvers.linalg")
           for t in targets if not t.startswith("blockmpec.solvers.linalg")]
    assert not bad, bad
    allowed = {"numpy", "scipy", "numba", "llvmlite", "pymetis", "threadpoolctl"}
    stdlib = set(sys.stdlib_module_names)
    for name in MODULES:
        if name.startswith("blockmpec.solvers.linalg"):
            for module in imports_of(name):
                top = module.split(".")[0]
                assert top in allowed | stdlib or module.startswith("blockmpec.solvers.linalg"), (name, module)


def test_engines_never_see_the_operators():
    """Engines get matrices and a LoadUnits, never the assembled operators (scaling is one reduction)."""
    bad = [f"{name} imports {t}" for name, targets in GRAPH.items()
           if name.startswith(("blockmpec.solvers.engines", "blockmpec.solvers.linalg", "blockmpec.solvers.plan"))
           for t in targets if t == "blockmpec.operators"]
    assert not bad, bad


def test_only_the_highs_wrapper_imports_highspy():
    importers = sorted(name for name in MODULES if any(m.split(".")[0] == "highspy" for m in imports_of(name)))
    assert importers == ["blockmpec.solvers.engines.highs"], importers


def test_nothing_in_the_library_but_the_cli_imports_the_bench():
    bad = [f"{name} imports {t}" for name, targets in GRAPH.items() for t in targets
           if t.startswith("blockmpec.bench") and not name.startswith(("blockmpec.bench", "blockmpec.cli"))]
    assert not bad, bad


@pytest.mark.parametrize("folder", ["blockmpec", "formulations", "solvers", "tests"])
def test_no_library_module_or_test_imports_studies(folder):
    found = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            found += [f"{path.relative_to(ROOT)}:{node.lineno}" for n in names if n.split(".")[0] == "studies"]
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and "studies/" in node.value \
                    and node.value.rstrip().endswith(".py") and folder != "tests":
                found.append(f"{path.relative_to(ROOT)}:{node.lineno} loads {node.value}")
    assert not found, found


# ------------------------------------------------------------------ the installed package, as a user imports it
# the probes run from "/", away from the source folders, so they import the installed package
def _modules_after(code: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys; print(' '.join(sys.modules))"],
                         capture_output=True, text=True, check=True, cwd="/")
    return set(out.stdout.split())


def test_core_imports_no_plugin_and_no_backend():
    mods = _modules_after("import blockmpec")
    assert not mods & {"blockmpec.solvers", "blockmpec.formulations", "pyomo", "highspy", "cyipopt"}


def test_listing_methods_imports_no_solver_backend():
    mods = _modules_after("import blockmpec; blockmpec.list_solvers()")
    assert "blockmpec.solvers" in mods
    assert not mods & {"highspy", "cyipopt"}


def test_no_generic_top_level_packages_installed():
    # "solvers" and "formulations" are also names of unrelated PyPI packages: ours live under blockmpec
    import blockmpec.formulations as formulations
    import blockmpec.solvers as solvers

    assert hasattr(formulations, "compile_linear") and hasattr(formulations, "static_lp")
    assert (Path(solvers.__file__).parent / "engines" / "highs.py").exists()
    mods = _modules_after("import blockmpec; blockmpec.list_solvers()")
    assert "solvers" not in mods and "formulations" not in mods


def test_methods_read_problem_3_from_the_compiled_formulation():
    """(3) is written once as a model (formulations/mcp.py, compiled by compile_mcp) and checked once
    (blockmpec/verify.py): no module under solvers/ builds a flow rule from the operators' V_f or friction_operator."""
    forbidden = {"V_f", "friction_operator"}
    found = []
    for path in sorted((ROOT / "solvers").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            name = node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name) else None
            if name in forbidden:
                found.append(f"{path.name}:{node.lineno}: {name}")
    assert not found, found


# ------------------------------------------------------------------ tests and studies use the public API only
#: attributes with a leading underscore that are public API of other libraries (none of blockmpec's): the standard
#: library's namedtuple methods
THIRD_PARTY_ATTRIBUTES = {"_asdict", "_fields", "_make", "_replace"}
ATTRIBUTE_FUNCTIONS = {"getattr", "setattr", "hasattr", "delattr"}  # also monkeypatch.setattr / delattr


def _private(name: str) -> bool:
    """A name with one leading underscore (``_x``; dunders such as ``__name__`` are not private)."""
    return name.startswith("_") and not name.startswith("__") and len(name) > 1


def private_uses(source: str) -> list[str]:
    """Where ``source`` reaches into a private name: ``from blockmpec... import _x``, an import of a private
    ``blockmpec`` module, ``obj._x`` with ``obj`` anything but ``self``/``cls``, or ``setattr(obj, "_x", ...)``
    (``getattr``/``hasattr``/``delattr``, ``monkeypatch.setattr`` alike)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "blockmpec":
            names = [*node.module.split("."), *(alias.name for alias in node.names)]
            found += [f"{node.lineno}: from {node.module} import {name}" for name in names if _private(name)][:1]
        elif isinstance(node, ast.Import):
            found += [f"{node.lineno}: import {alias.name}" for alias in node.names
                      if alias.name.split(".")[0] == "blockmpec" and any(map(_private, alias.name.split(".")))]
        elif isinstance(node, ast.Attribute) and _private(node.attr) and node.attr not in THIRD_PARTY_ATTRIBUTES:
            if not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
                found.append(f"{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.Call) and len(node.args) >= 2:
            function = node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", None)
            name = node.args[1]
            if (function in ATTRIBUTE_FUNCTIONS and isinstance(name, ast.Constant) and isinstance(name.value, str)
                    and _private(name.value) and name.value not in THIRD_PARTY_ATTRIBUTES):
                found.append(f"{node.lineno}: {ast.unparse(node.func)}(..., {name.value!r})")
    return found


def test_the_checker_finds_every_kind_of_private_use():
    source = ("from blockmpec.solvers.milp import _BoundFailure\nfrom blockmpec.formulations import _pyomo\n"
              "from blockmpec.formulations._pyomo import compile_linear\nimport blockmpec.formulations._pyomo\n"
              "bnb._apply(state)\nsolver.form._cache\nmonkeypatch.setattr(MILPSolver, '_mechanism', f)\n"
              "getattr(ipm, '_K_pattern')\n")
    assert len(private_uses(source)) == 8, private_uses(source)
    fine = ("from blockmpec.solvers import milp\nimport _common\nself._x = 1\ncls._y\nrow._replace(a=1)\n"
            "type(x).__name__\nmonkeypatch.setattr(plan, 'MILP_BNB_MAX_PAIRS', 0)\n")
    assert private_uses(fine) == []


@pytest.mark.parametrize("folder", ["tests", "studies"])
def test_tests_and_studies_call_no_private_name(folder):
    """Tests and studies test the engines through their public functions and read-only properties: no private
    attribute of a blockmpec object, no private name or module imported from blockmpec."""
    found = [f"{path.relative_to(ROOT)}:{use}" for path in sorted((ROOT / folder).rglob("*.py"))
             for use in private_uses(path.read_text())]
    assert not found, "\n".join(found)


# ------------------------------------------------------------------ one owner of HiGHS
#: modules still holding raw HiGHS calls, each with its reason; the test fails once one no longer needs its entry
HIGHS_NOT_YET_MOVED: dict[str, str] = {}


def test_nothing_outside_the_highs_wrapper_touches_highspy():
    """No library module but ``solvers/engines/highs.py`` calls a highspy method, reads a ``HighsLP``'s ``.highs``,
    imports a wrapper name outside its ``__all__`` or imports highspy (the not-yet-moved modules excepted)."""
    from code_counts import HIGHS_WRAPPER, highs_touches, library_files, relative

    found = {relative(p): highs_touches(p) for p in library_files() if relative(p) != HIGHS_WRAPPER}
    assert_only_listed(found, HIGHS_NOT_YET_MOVED, "HIGHS_NOT_YET_MOVED")


def assert_only_listed(found: dict[str, list], allowed: dict[str, str], name: str) -> None:
    """Every file with findings is in the allow-list ``allowed`` (called ``name``), and every listed file still has
    some (an entry no longer needed must go)."""
    bad = {k: v for k, v in found.items() if v and k not in allowed}
    assert not bad, bad
    stale = [k for k in allowed if not found.get(k)]
    assert not stale, f"nothing found there any more, drop from {name}: {stale}"


def test_the_highs_checker_finds_every_touch(tmp_path):
    from code_counts import highs_touches

    source = ("import highspy\nfrom blockmpec.solvers.engines.highs import new_highs, HighsLP\n"
              "h = new_highs()\nh.changeColsCost(1, [0], [1.0])\nlp = HighsLP(x)\nlp.highs.run()\n")
    path = tmp_path / "module.py"
    path.write_text(source)
    assert len(highs_touches(path)) == 4, highs_touches(path)  # import highspy, new_highs, changeColsCost, .highs


# ------------------------------------------------------------------ units of code a reader can hold
_FIXED_POINT = "the fixed point's engines are being rewritten by their owner: split after that lands"
_DRAWINGS = "the drawing readers are being changed by their owner: split after that lands"
_BENCH = "the comparator is being changed by its owner (plug-ins): split after that lands"

#: library functions longer than code_counts.FUNCTION_LINES lines (docstring left out), each with its reason
LONG_FUNCTIONS = {
    "solvers/linalg/block_ipm.py:_solve": "numerical kernel: one Mehrotra iteration with its correctors, refinement "
                                          "and stopping tests; read whole against the module docstring's algorithm",
    "solvers/linalg/block_ipm.py:__init__": "numerical kernel: the block IPM's standard form (rows split, scaled, "
                                            "interface blocks gathered) in the order the iteration relies on",
    "solvers/linalg/cholesky.py:__init__": "numerical kernel: the supernodal symbolic analysis (elimination tree, "
                                           "supernodes, fronts, relative indices) in one pass",
    "solvers/linalg/null_space.py:static_null_space": "numerical kernel: the static LP's null-space basis, one "
                                                      "elimination read top to bottom",
    "solvers/engines/lp_sequence.py:run_sequence": _FIXED_POINT,
    "solvers/engines/newton_system.py:semismooth_newton": _FIXED_POINT,
    "solvers/engines/interior_fixed_point.py:run_interior": _FIXED_POINT,
    "blockmpec/drawings/image.py:read_image": _DRAWINGS,
    "blockmpec/bench/compare.py:_run": _BENCH,
}
#: classes longer than code_counts.CLASS_LINES lines, each with its reason
LONG_CLASSES: dict[str, str] = {}


def test_no_library_function_or_class_is_longer_than_a_reader_can_hold():
    """No library function over ~80 lines and no class over ~400, but the listed ones (each with its reason); an
    entry no longer needed fails too."""
    from code_counts import CLASS_LINES, long_units

    functions, classes = long_units(), long_units(kind=ast.ClassDef, limit=CLASS_LINES)
    assert not set(functions) - set(LONG_FUNCTIONS), sorted(set(functions) - set(LONG_FUNCTIONS))
    assert not set(classes) - set(LONG_CLASSES), sorted(set(classes) - set(LONG_CLASSES))
    stale = sorted((set(LONG_FUNCTIONS) - set(functions)) | (set(LONG_CLASSES) - set(classes)))
    assert not stale, f"no longer long, drop from the allow-list: {stale}"


# ------------------------------------------------------------------ studies: the public API or a documented engine API
#: studies that still reach past the documented engine API, each with its reason; the test fails once one no
#: longer needs its entry
STUDIES_NOT_YET_MOVED: dict[str, str] = {}


def test_studies_use_the_public_api_or_a_documented_engine_api():
    """A study imports from an engine, linear-algebra or formulation module only the names in its ``__all__`` (its
    documented API), patches no module or class and runs no copy of old source (``exec``); see
    ``code_counts.study_reaches``."""
    from code_counts import relative, study_reaches

    found = {relative(p): study_reaches(p) for p in sorted((ROOT / "studies").rglob("*.py"))}
    assert_only_listed(found, STUDIES_NOT_YET_MOVED, "STUDIES_NOT_YET_MOVED")


def test_the_study_checker_finds_every_reach(tmp_path):
    from code_counts import study_reaches

    source = ("from blockmpec.solvers.engines import complementarity_bnb\n"
              "from blockmpec.solvers.engines.piece_lp import relative_to_largest, piece_descent\n"
              "setattr(complementarity_bnb, 'LP_TOL', 1e-6)\nexec(compile('x = 1', 'old.py', 'exec'))\n"
              "options = {}\nsetattr(options, 'a', 1)\n")
    path = tmp_path / "study.py"
    path.write_text(source)
    found = study_reaches(path)
    # relative_to_largest (not in __all__), the setattr on a module, exec and compile; a whole submodule, a name in
    # __all__ and a setattr on a local object are fine
    assert len(found) == 4, found
