"""Keep the layers apart: the core imports no plug-in, listing methods imports no backend."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _modules_after(code: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys; print(' '.join(sys.modules))"],
                         capture_output=True, text=True, check=True, cwd=ROOT)
    return {m.split(".")[0] for m in out.stdout.split()}


def test_core_imports_no_plugin_and_no_backend():
    mods = _modules_after("import blockmpec")
    assert not mods & {"solvers", "formulations", "pyomo", "highspy", "cyipopt"}


def test_listing_methods_imports_no_solver_backend():
    mods = _modules_after("import blockmpec; blockmpec.list_solvers()")
    assert "solvers" in mods
    assert not mods & {"highspy", "cyipopt"}


def test_plugin_packages_are_this_projects():
    # "solvers" and "formulations" are also names of unrelated PyPI packages: make sure ours are imported
    import formulations
    import solvers

    assert hasattr(formulations, "compile_linear") and hasattr(formulations, "static_lp")
    assert (Path(solvers.__file__).parent / "_highs.py").exists()
