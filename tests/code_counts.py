"""Counts of the source tree that say whether ``solvers/`` is a room a maintainer can live in.

Run ``python tests/code_counts.py [ROOT]`` (ROOT: a checkout, default this one) to print them; the checks of
``tests/test_layering.py`` read the same functions.  Everything is read from the source with :mod:`ast` (nothing is
imported but highspy, for the names of its methods), so any checkout can be measured, e.g. an older commit::

    git worktree add /tmp/old e31e02c && python tests/code_counts.py /tmp/old

What is counted, one group per line of the report:

1. HiGHS: calls of highspy's methods and reads of a ``HighsLP``'s ``.highs`` outside ``solvers/engines/highs.py``;
   names imported from that module that are not in its ``__all__``; ``new_highs()`` call sites; raw HiGHS model
   statuses read outside it; modules importing highspy.
2. Scaling by hand: products and quotients with a ``row_scale``, ``column_scale`` or ``slack_scale`` outside the
   units reduction (``solvers/engines/scaling.py``), the HiGHS wrapper and the linear algebra.
3. Units of code: library functions over :data:`FUNCTION_LINES` lines and classes over :data:`CLASS_LINES` (their own
   docstrings left out), module docstrings over :data:`DOCSTRING_LINES`, module docstrings naming an issue or a
   date.
4. The plan: modules of ``solvers/`` that write ``extra["plan"]`` themselves.
5. Verification: calls of the verifier (``residuals``) inside ``solvers/``.
6. The lab: lines of ``studies/``, scripts, scripts reaching past the public API (private names, names outside an
   engine module's ``__all__``, monkeypatches, ``exec``).
7. Dead code and names: the names the issue found dead; the names of the friction coefficient; ``tan(phi) -
   tan(psi)`` derived; the literal default 0.65 in the library.
"""

from __future__ import annotations

import ast
import re
import sys
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the library's source folders
LIBRARY = ("blockmpec", "formulations", "solvers")
FUNCTION_LINES = 80
CLASS_LINES = 400
DOCSTRING_LINES = 80
#: the one HiGHS wrapper and the modules that may hold the units reduction's arrays
HIGHS_WRAPPER = "solvers/engines/highs.py"
SCALING_OWNERS = ("solvers/engines/scaling.py", HIGHS_WRAPPER, "solvers/linalg/")
SCALE_NAMES = {"row_scale", "column_scale", "slack_scale"}
#: the dead names the issue found, each with the file it was defined in
DEAD_NAMES = {"THREADED_FRONT_ROWS": "solvers/plan.py", "friction_gap": "formulations/compiled.py",
              "load_study": "tests/helpers.py", "ALGORITHMS": "solvers/engines/lp_engine.py",
              "solve_scip": "solvers/engines/mip.py", "load_before": "studies/lab/certificate_study.py"}
#: spellings of the friction coefficient (or of tan(phi) - tan(psi)) besides ``friction`` (the library's) and ``mu``
#: (the user parameter of the cases, the drawing readers and make_structure)
OTHER_FRICTION_NAMES = ("friction_gap", "tan_phi", "friction_coefficient")
HISTORY = re.compile(r"\bissues? \d+|\b20\d\d-\d\d-\d\d\b", re.IGNORECASE)


def library_files(root: Path = ROOT) -> list[Path]:
    return [p for folder in LIBRARY for p in sorted((root / folder).rglob("*.py"))]


def relative(path: Path, root: Path = ROOT) -> str:
    return path.relative_to(root).as_posix()


@cache
def parsed(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


# ------------------------------------------------------------------------------------------------- 1. HiGHS
@cache
def highspy_methods() -> frozenset[str]:
    """The camelCase method names of ``highspy.Highs`` (``passModel``, ``changeColsCost`` ...)."""
    import highspy

    return frozenset(n for n in dir(highspy.Highs) if not n.startswith("_") and any(c.isupper() for c in n))


def wrapper_api(root: Path = ROOT) -> set[str]:
    """The names in ``__all__`` of the HiGHS wrapper."""
    for node in parsed(root / HIGHS_WRAPPER).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return set(ast.literal_eval(node.value))
    return set()


def highs_touches(path: Path, root: Path = ROOT) -> list[str]:
    """Where a module outside the wrapper touches HiGHS: a highspy method called, a ``.highs`` read, a name of the
    wrapper imported that is not in its ``__all__``, ``highspy`` imported."""
    api = wrapper_api(root) or wrapper_api(ROOT)  # a checkout from before the wrapper had __all__: today's
    found = []
    for node in ast.walk(parsed(path)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in highspy_methods():
            found.append(f"{node.lineno}: .{node.func.attr}()")
        elif isinstance(node, ast.Attribute) and node.attr == "highs" and isinstance(node.ctx, ast.Load):
            found.append(f"{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").endswith("engines.highs"):
            found += [f"{node.lineno}: import {a.name}" for a in node.names if a.name not in api]
        elif isinstance(node, ast.Import | ast.ImportFrom):
            modules = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            found += [f"{node.lineno}: import highspy" for m in modules if m.split(".")[0] == "highspy"]
    return found


def calls_of(path: Path, names: set[str]) -> list[int]:
    return [node.lineno for node in ast.walk(parsed(path)) if isinstance(node, ast.Call)
            and (getattr(node.func, "id", None) in names or getattr(node.func, "attr", None) in names)]


def highs_counts(root: Path = ROOT) -> dict[str, object]:
    outside = [p for p in library_files(root) if relative(p, root) != HIGHS_WRAPPER]
    touches = {relative(p, root): len(highs_touches(p, root)) for p in outside}
    return {
        "HiGHS touches outside the wrapper": sum(touches.values()),
        "  by module": {k: v for k, v in sorted(touches.items(), key=lambda kv: -kv[1]) if v},
        "new_highs() call sites outside the wrapper": sum(len(calls_of(p, {"new_highs"})) for p in outside),
        "raw HiGHS statuses read outside the wrapper": sum(
            len(calls_of(p, {"highs_status", "getModelStatus", "mip_info"})) for p in outside),
        "modules importing highspy": sorted(relative(p, root) for p in library_files(root) if any(
            "import highspy" in t for t in highs_touches(p, root))),
    }


# ------------------------------------------------------------------------------------------------- 2. scaling
def scaling_by_hand(path: Path) -> list[int]:
    """Lines of products and quotients with one of :data:`SCALE_NAMES` (a name, an attribute or an item of one)."""

    def scale(node) -> bool:
        while isinstance(node, ast.Subscript):
            node = node.value
        return getattr(node, "id", getattr(node, "attr", None)) in SCALE_NAMES

    return [node.lineno for node in ast.walk(parsed(path)) if isinstance(node, ast.BinOp)
            and isinstance(node.op, ast.Mult | ast.Div) and (scale(node.left) or scale(node.right))]


def scaling_counts(root: Path = ROOT) -> dict[str, object]:
    by = {relative(p, root): len(scaling_by_hand(p)) for p in library_files(root)
          if not relative(p, root).startswith(SCALING_OWNERS)}
    return {"scales applied by hand outside the reduction": sum(by.values()),
            "  by module": {k: v for k, v in sorted(by.items(), key=lambda kv: -kv[1]) if v}}


# ------------------------------------------------------------------------------------------------- 3. units of code
def unit_lines(node: ast.AST) -> int:
    """Lines of a function or class, its own docstring left out (a numpydoc schema of the returns is not code)."""
    lines = node.end_lineno - node.lineno + 1
    body = getattr(node, "body", [])
    if body and isinstance(body[0], ast.Expr) and isinstance(getattr(body[0], "value", None), ast.Constant) \
            and isinstance(body[0].value.value, str):
        lines -= body[0].end_lineno - body[0].lineno + 1
    return lines


def long_units(root: Path = ROOT, kind=(ast.FunctionDef, ast.AsyncFunctionDef), limit: int = FUNCTION_LINES):
    """``{"path:name": lines}`` of the library's functions (or classes) longer than ``limit`` lines (docstring
    left out: :func:`unit_lines`)."""
    out = {}
    for p in library_files(root):
        for node in ast.walk(parsed(p)):
            if isinstance(node, kind) and unit_lines(node) > limit:
                out[f"{relative(p, root)}:{node.name}"] = unit_lines(node)
    return out


def module_docstrings(root: Path = ROOT) -> dict[str, str]:
    return {relative(p, root): ast.get_docstring(parsed(p), clean=False) or "" for p in library_files(root)}


def unit_counts(root: Path = ROOT) -> dict[str, object]:
    functions = long_units(root)
    classes = long_units(root, ast.ClassDef, CLASS_LINES)
    docs = module_docstrings(root)
    return {
        f"library functions over {FUNCTION_LINES} lines": len(functions),
        "  longest": dict(sorted(functions.items(), key=lambda kv: -kv[1])[:5]),
        f"classes over {CLASS_LINES} lines": dict(sorted(classes.items(), key=lambda kv: -kv[1])),
        f"module docstrings over {DOCSTRING_LINES} lines": sorted(
            k for k, d in docs.items() if d.count("\n") + 1 > DOCSTRING_LINES),
        "module docstrings naming an issue or a date": sorted(k for k, d in docs.items() if HISTORY.search(d)),
    }


# ------------------------------------------------------------------------------------------------- 4, 5
def plan_writers(root: Path = ROOT) -> list[str]:
    """Modules of ``solvers/`` (but ``plan.py``) with a ``"plan"`` key in a dict or a subscript."""
    out = []
    for p in sorted((root / "solvers").rglob("*.py")):
        if p.name == "plan.py":
            continue
        for node in ast.walk(parsed(p)):
            keys = (node.keys if isinstance(node, ast.Dict) else [node.slice] if isinstance(node, ast.Subscript)
                    else [])
            if any(isinstance(k, ast.Constant) and k.value == "plan" for k in keys):
                out.append(relative(p, root))
                break
    return out


def verifier_calls(root: Path = ROOT) -> dict[str, int]:
    """Calls of the shared verifier (``residuals`` imported from ``blockmpec.verify``) inside ``solvers/``, per module
    (verification with a tolerance of the adapter's own instead of the run's ``verify_tol``)."""
    by = {}
    for p in sorted((root / "solvers").rglob("*.py")):
        names = {a.asname or a.name for node in ast.walk(parsed(p)) if isinstance(node, ast.ImportFrom)
                 and node.module == "blockmpec.verify" for a in node.names if a.name == "residuals"}
        if names:
            by[relative(p, root)] = len(calls_of(p, names))
    return {k: v for k, v in by.items() if v}


# ------------------------------------------------------------------------------------------------- 6. the lab
def module_all(module: str, root: Path = ROOT) -> set[str] | None:
    """``__all__`` of a library module named ``blockmpec.x.y`` (None without one or without the module)."""
    parts = module.split(".")[1:]
    if parts[:1] in (["solvers"], ["formulations"]):
        base = root / parts[0]
        parts = parts[1:]
    else:
        base = root / "blockmpec"
    for path in (base.joinpath(*parts).with_suffix(".py"), base.joinpath(*parts, "__init__.py")):
        if path.is_file():
            for node in parsed(path).body:
                if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                    return set(ast.literal_eval(node.value))
            return None
    return None


#: modules whose imports a study must take from their ``__all__`` (their documented API)
ENGINE_PREFIXES = ("blockmpec.solvers", "blockmpec.formulations")


def study_reaches(path: Path, root: Path = ROOT) -> list[str]:
    """Where a study reaches past the public API: a name imported from an engine, linear-algebra or formulation
    module that is not in that module's ``__all__`` (or from a module without one; a submodule imported whole is
    fine), ``setattr`` on an imported module or class (a monkeypatch), ``exec``/``compile`` of source."""
    tree = parsed(path)
    imported = {alias.asname or alias.name.split(".")[0] for node in ast.walk(tree)
                if isinstance(node, ast.Import | ast.ImportFrom) for alias in node.names}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(ENGINE_PREFIXES):
            public = module_all(node.module, root)
            found += [f"{node.lineno}: from {node.module} import {a.name}" for a in node.names
                      if not is_module(f"{node.module}.{a.name}", root) and (public is None or a.name not in public)]
        elif isinstance(node, ast.Call) and getattr(node.func, "id", None) in ("exec", "compile"):
            found.append(f"{node.lineno}: {node.func.id}()")
        elif (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None)) == "setattr"
              and node.args and isinstance(node.args[0], ast.Name) and node.args[0].id in imported):
            found.append(f"{node.lineno}: setattr({node.args[0].id}, ...)")
    return found


def is_module(name: str, root: Path = ROOT) -> bool:
    """Whether ``blockmpec.x.y`` names a module (or package) of the library."""
    parts = name.split(".")[1:]
    base = root / "blockmpec"
    if parts[:1] in (["solvers"], ["formulations"]):
        base, parts = root / parts[0], parts[1:]
    return base.joinpath(*parts).with_suffix(".py").is_file() or (base.joinpath(*parts) / "__init__.py").is_file()


def lab_counts(root: Path = ROOT) -> dict[str, object]:
    from test_layering import private_uses

    scripts = [p for p in sorted((root / "studies").rglob("*.py"))]
    reaching = sorted(relative(p, root) for p in scripts if private_uses(p.read_text()) or study_reaches(p, root))
    return {"lines of studies/": sum(len(p.read_text().splitlines()) for p in scripts),
            "lines of studies/lab": sum(len(p.read_text().splitlines()) for p in scripts if "/lab/" in p.as_posix()),
            "lab scripts": len([p for p in scripts if "/lab/" in p.as_posix() and not p.name.startswith("_")]),
            "studies reaching past the public API": reaching}


# ------------------------------------------------------------------------------------------------- 7. names
def name_uses(root: Path, names: tuple[str, ...], folders=LIBRARY) -> dict[str, int]:
    counts = dict.fromkeys(names, 0)
    for folder in folders:
        for p in sorted((root / folder).rglob("*.py")):
            for node in ast.walk(parsed(p)):
                name = (node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute)
                        else node.arg if isinstance(node, ast.arg) else node.name
                        if isinstance(node, ast.FunctionDef | ast.ClassDef) else None)
                if name in counts:
                    counts[name] += 1
    return counts


def friction_gap_derivations(root: Path = ROOT) -> list[str]:
    """``friction - dilatancy`` (or ``tan_phi - tan_psi``) written out in the library."""

    def name(node) -> str | None:
        return getattr(node, "attr", getattr(node, "id", None))

    return [f"{relative(p, root)}:{node.lineno}" for p in library_files(root) for node in ast.walk(parsed(p))
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Sub) and name(node.left) in ("friction", "mu")
            and name(node.right) == "dilatancy"]


def literal_uses(root: Path, value: float) -> list[str]:
    return [f"{relative(p, root)}:{node.lineno}" for p in library_files(root) for node in ast.walk(parsed(p))
            if isinstance(node, ast.Constant) and type(node.value) is float and node.value == value]


def defines(path: Path, name: str) -> bool:
    """Whether the module at ``path`` defines ``name`` (a function, class, assignment or property)."""
    if not path.is_file():
        return False
    for node in ast.walk(parsed(path)):
        if isinstance(node, ast.FunctionDef | ast.ClassDef) and node.name == name:
            return True
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == name for t in node.targets):
            return True
    return False


def name_counts(root: Path = ROOT) -> dict[str, object]:
    return {"dead names still defined": sorted(k for k, where in DEAD_NAMES.items() if defines(root / where, k)),
            "other spellings of the friction coefficient in the library": {k: v for k, v in name_uses(
                root, OTHER_FRICTION_NAMES).items() if v},
            "tan(phi) - tan(psi) written out": len(friction_gap_derivations(root)),
            "literal 0.65 in the library": len(literal_uses(root, 0.65))}


def report(root: Path = ROOT) -> dict[str, dict]:
    return {"1. HiGHS behind its wrapper": highs_counts(root), "2. one units reduction": scaling_counts(root),
            "3/4. units of code": unit_counts(root),
            "3. the plan": {"modules of solvers/ writing extra['plan'] themselves": plan_writers(root)},
            "5. verify_tol": {"verifier calls inside solvers/": verifier_calls(root)},
            "6. the lab": lab_counts(root), "7. dead code and names": name_counts(root)}


def main(argv: list[str]) -> None:
    root = Path(argv[0]).resolve() if argv else ROOT
    for group, counts in report(root).items():
        print(group)
        for key, value in counts.items():
            print(f"    {key}: {value}")


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    main(sys.argv[1:])
