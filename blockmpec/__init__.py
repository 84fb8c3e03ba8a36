"""blockmpec: limit analysis of rigid-block masonry with non-associative Coulomb friction.

Core package: structures, operators, the result type, the verifier, the solver
registry and the CLI.  Pyomo models live in the top-level ``formulations``
package and solver adapters in ``solvers``; the core never imports them at
import time.

>>> import blockmpec as bm
>>> wall = bm.cases.wall(courses=4, blocks_per_course=3)
>>> res = bm.solve(wall, "static-lp")
>>> res.success, round(res.multiplier, 5)  # doctest: +SKIP
"""

from blockmpec import cases
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
    "load_structure", "make_structure", "register_solver", "residuals", "save_structure", "solve",
    "structure_from_dict", "structure_to_dict",
]
__version__ = "0.1.0"
