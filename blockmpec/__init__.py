"""blockmpec: limit analysis of rigid-block masonry with non-associative Coulomb friction.

Core package: structures, operators, the result type, the verifier, the solver
registry and the CLI.  Pyomo models live in ``blockmpec.formulations`` and solver
adapters in ``blockmpec.solvers`` (the repository's top-level ``formulations/`` and
``solvers/`` folders, installed under ``blockmpec``); the core never imports them at
import time.

>>> import blockmpec as bm
>>> wall = bm.cases.wall(courses=4, blocks_per_course=3)
>>> res = bm.solve(wall, "static-lp")
>>> res.success, round(res.multiplier, 5)  # doctest: +SKIP
"""

from pathlib import Path as _Path

# In a source checkout that is imported directly (``python -m blockmpec.cli`` from the repository
# root, where the working directory shadows the installed package), the sub-packages
# ``formulations`` and ``solvers`` sit beside this folder instead of inside it: look there too.
# An installed package has them inside and is left alone.
_here = _Path(__file__).resolve().parent
if not (_here / "solvers").is_dir() and all(
        (_here.parent / d / "__init__.py").is_file() for d in ("formulations", "solvers")) and (
        _here.parent / "pyproject.toml").is_file():
    __path__.append(str(_here.parent))  # noqa: F821 - the package's own search path
del _Path, _here

from blockmpec import cases  # noqa: E402
from blockmpec.cases import build_case
from blockmpec.errors import (
    BlockmpecError,
    GeometryError,
    OptionError,
    PrecisionWarning,
    SolverUnavailableError,
    StructureError,
    StructureFileError,
    UnknownNameError,
)
from blockmpec.geometry import Interfaces, PointLoad, Structure, make_structure
from blockmpec.operators import Operators, assemble
from blockmpec.pushover import pushover
from blockmpec.registry import get_solver, list_solvers, register_solver
from blockmpec.result import Result, Solution, Status
from blockmpec.solver import RunOutput, SolverBase, solve
from blockmpec.structure_file import load_structure, save_structure, structure_from_dict, structure_to_dict
from blockmpec.units import Units
from blockmpec.verify import residuals

__all__ = [
    "BlockmpecError", "GeometryError", "Interfaces", "Operators", "OptionError", "PointLoad", "PrecisionWarning", "Result",
    "RunOutput", "Solution", "SolverBase", "SolverUnavailableError", "Status", "Structure", "StructureError",
    "StructureFileError", "UnknownNameError", "Units", "assemble", "build_case", "cases", "get_solver", "list_solvers",
    "load_structure", "make_structure", "pushover", "register_solver", "residuals", "save_structure", "solve",
    "structure_from_dict", "structure_to_dict",
]
__version__ = "0.1.0"
