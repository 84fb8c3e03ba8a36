"""Keep the layers apart: the core imports no plug-in, listing methods imports no backend."""

import subprocess
import sys
from pathlib import Path


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


def test_solvers_read_problem_3_from_the_compiled_formulation():
    # (3) is written once as a model (formulations/mcp.py, compiled by compile_mcp) and checked once
    # (blockmpec/verify.py); no method may rebuild its flow rule from the operators
    import ast

    import blockmpec.solvers as solvers

    forbidden = {"V_f", "friction_operator"}
    found = []
    for path in sorted(Path(solvers.__file__).parent.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            name = node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name) else None
            if name in forbidden:
                found.append(f"{path.name}:{node.lineno}: {name}")
    assert not found, found
