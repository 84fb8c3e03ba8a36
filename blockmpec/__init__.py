"""blockmpec: limit analysis of rigid-block masonry with non-associative Coulomb friction.

What lives here: the problem (geometry, cases, structure files, units, operators), ``Result`` and the verifier,
the plug-in contract and ``solve()`` with the method registry; the comparator in ``blockmpec.bench``; the CLI.
It imports numpy, scipy and pandas, and ``formulations``/``solvers`` only when a method runs (never at import).

The repository's top-level ``formulations/`` and ``solvers/`` folders install as ``blockmpec.formulations`` and
``blockmpec.solvers``.  The layers and the arrows between them are checked by ``tests/test_layering.py``.

>>> import blockmpec as bm
>>> wall = bm.cases.wall(courses=4, blocks_per_course=3)
>>> res = bm.solve(wall, "static-lp")
>>> res.success, round(res.multiplier, 5)  # doctest: +SKIP
>>> res.forces.head()  # interface forces in the structure's ids and units  # doctest: +SKIP
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

from blockmpec import (
    cases,  # noqa: E402
    plot,  # noqa: E402 - drawings (matplotlib is imported when one is drawn)
    three_d,  # noqa: E402 - 3D blocks (registers the 3D cases)
)
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
from blockmpec.report import StructureMap, forces_frame, mechanism_frame
from blockmpec.result import Result, RunOutput, Solution, Status
from blockmpec.solver import SolverBase, run_solver, solve
from blockmpec.structure_file import load_structure, save_structure, structure_from_dict, structure_to_dict
from blockmpec.units import Units
from blockmpec.verify import residuals

__all__ = [
    "BlockmpecError", "GeometryError", "Interfaces", "Operators", "OptionError", "PointLoad", "PrecisionWarning", "Result",
    "RunOutput", "Solution", "SolverBase", "SolverUnavailableError", "Status", "Structure", "StructureError",
    "StructureFileError", "StructureMap", "UnknownNameError", "Units", "assemble", "build_case", "cases",
    "forces_frame", "get_solver", "list_solvers", "load_structure", "make_structure", "mechanism_frame", "plot",
    "pushover", "register_solver", "residuals", "run_solver", "save_structure", "solve", "structure_from_dict",
    "structure_to_dict", "three_d",
]

try:  # the installed distribution's version (pyproject.toml), so that one number is kept in one place
    from importlib.metadata import PackageNotFoundError as _NotFound
    from importlib.metadata import version as _version

    __version__ = _version("blockmpec")
except _NotFound:  # pragma: no cover - a source tree imported without installing it
    __version__ = "0+unknown"
del _NotFound, _version
