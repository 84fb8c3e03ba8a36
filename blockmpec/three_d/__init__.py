"""3D rigid blocks: closed polyhedra, contact polygons with points, the same four problems as in 2D.

What lives here: 3D geometry and validation (:mod:`~blockmpec.three_d.geometry`), contact detection
(:mod:`~blockmpec.three_d.contacts`), the operators on contact points (:mod:`~blockmpec.three_d.operators`, the
layout contract shared with 2D), the built-in 3D cases (:mod:`~blockmpec.three_d.cases`), mesh and JSON input
(:mod:`~blockmpec.three_d.meshes`), results in the structure's terms (:mod:`~blockmpec.three_d.report`), figures
(:mod:`~blockmpec.three_d.plot`) and the exact friction cone (:mod:`~blockmpec.three_d.cone`).  A
:class:`Structure3D` is solved by :func:`blockmpec.solve` like a 2D structure.
"""

from blockmpec.three_d.cases import arch_3d, barrel_vault, block_3d, corner_wall, dome, extrude, extruded
from blockmpec.three_d.contacts import Contacts
from blockmpec.three_d.geometry import Structure3D, make_structure_3d
from blockmpec.three_d.operators import Operators3D, assemble_3d
from blockmpec.three_d.polyhedra import box, convex_block, prism

__all__ = [
    "Contacts", "Operators3D", "Structure3D", "arch_3d", "assemble_3d", "barrel_vault", "block_3d", "box",
    "convex_block", "corner_wall", "dome", "extrude", "extruded", "make_structure_3d", "prism",
]
