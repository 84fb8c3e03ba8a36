r"""3D results in the structure's terms: forces per contact point and per contact, the mechanism per block.

The solvers work on the canonical problem of :func:`blockmpec.three_d.operators.assemble_3d` (canonical order,
axes turned so that ``x`` is along the live load, lengths over ``length_scale``, forces over ``force_scale``).
This module turns a solution back into the structure's ids, order, axes and units.

Contact forces (:func:`contact_forces`)
    At each contact point, the force the plus block exerts on the minus block (the structure's minus and plus):
    ``F = R^T (t1 e1 + t2 e2 + n nu) force_scale``, its sign turned where the canonical interface runs the other
    way; ``normal`` is its component along the interface normal (from minus into plus), ``<= 0`` in
    compression, ``shear`` the size of the rest.

Resultants (:func:`contact_resultants`)
    Per interface: the sum of its points' forces and their moment about the mean of its points, split into the
    normal force, the shear, the torsion (the moment about the normal) and the bending moment.

Mechanism (:func:`mechanism_frame_3d`)
    Per free block: the velocity of its centroid ``(u_x, u_y, u_z) = R^T u' / force_scale`` and its angular
    velocity ``(rotation_x, rotation_y, rotation_z) = R^T w' / (force_scale length_scale)``, normalised so that
    the live load's power is one in the structure's units (as in 2D, :mod:`blockmpec.report`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from blockmpec.errors import StructureError

#: Columns of :func:`contact_forces` (``res.forces`` of a 3D result, ``blockmpec solve --forces``).
CONTACT_FORCE_COLUMNS = ("interface", "point", "minus", "plus", "minus_id", "plus_id", "x", "y", "z", "normal",
                         "shear", "force_x", "force_y", "force_z")
#: Columns of :func:`contact_resultants`.
RESULTANT_COLUMNS = ("interface", "minus", "plus", "minus_id", "plus_id", "centre_x", "centre_y", "centre_z",
                     "normal_x", "normal_y", "normal_z", "normal", "shear", "torsion", "bending", "force_x", "force_y",
                     "force_z", "moment_x", "moment_y", "moment_z")
#: Columns of :func:`mechanism_frame_3d` (``res.mechanism`` of a 3D result).
MECHANISM_COLUMNS_3D = ("block", "block_id", "u_x", "u_y", "u_z", "rotation_x", "rotation_y", "rotation_z")


@dataclass(frozen=True, eq=False)
class ContactMap:
    """How the canonical 3D problem's unknowns map onto a structure (travels with a Result; no operator)."""

    structure: Any
    interface_ids: np.ndarray
    interface_flipped: np.ndarray
    contact_interface: np.ndarray
    contact_source: np.ndarray
    normal: np.ndarray
    tangent1: np.ndarray
    tangent2: np.ndarray
    free_blocks: np.ndarray
    rotation: np.ndarray
    length_scale: float
    force_scale: float

    dim = 3

    @classmethod
    def of(cls, ops: Any) -> ContactMap:
        """The map of assembled 3D operators (a map is returned as is)."""
        if isinstance(ops, ContactMap):
            return ops
        if getattr(ops, "structure", None) is None:
            raise StructureError("these operators were not assembled from a Structure3D, so results cannot be "
                                 "reported in a structure's ids and units")
        return cls(ops.structure, ops.interface_ids, ops.interface_flipped, ops.contact_interface, ops.contact_source,
                   ops.normal, ops.tangent1, ops.tangent2, ops.free_blocks, ops.rotation, float(ops.length_scale),
                   float(ops.force_scale))

    def force_vectors(self, x: np.ndarray) -> np.ndarray:
        """Per canonical point, the structure-frame force of the structure's plus block on its minus block, (p, 3)."""
        q = np.asarray(x, float).reshape(-1, 3)
        k = self.contact_interface
        f = q[:, :1] * self.tangent1[k] + q[:, 1:2] * self.tangent2[k] + q[:, 2:] * self.normal[k]
        sign = np.where(self.interface_flipped[k], -1.0, 1.0)[:, None]
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            return (f @ self.rotation) * sign * self.force_scale


def _array(solution: Any, name: str) -> np.ndarray | None:
    value = getattr(solution, name) if hasattr(solution, name) else solution
    return None if value is None else np.asarray(value, float)


def _empty(columns, integer=("interface", "point", "minus", "plus", "block"), text=("minus_id", "plus_id", "block_id")):
    import pandas as pd

    return pd.DataFrame({c: (np.zeros(0, np.int64) if c in integer else np.zeros(0, object) if c in text
                             else np.zeros(0)) for c in columns})


def contact_forces(ops: Any, solution: Any):
    """Forces at every contact point, in the structure's ids, axes and units (module docstring).

    Returns
    -------
    pandas.DataFrame
        One row per contact point of the problem, ordered by the structure's interface and point, with columns
        ``interface, point, minus, plus, minus_id, plus_id, x, y, z, normal, shear, force_x, force_y, force_z``
        (``point``: the row in the structure's ``contacts.points``).  Contacts between two fixed blocks carry no
        unknown and are left out.  Empty (same columns) without forces.
    """
    import pandas as pd

    x = _array(solution, "x")
    if x is None:
        return _empty(CONTACT_FORCE_COLUMNS)
    m = ContactMap.of(ops)
    p = m.contact_source.size
    if x.shape != (3 * p,):
        raise StructureError(f"contact forces: expected shape ({3 * p},) (3 per contact point); got {x.shape}")
    s = m.structure
    c = s.contacts
    itf = m.interface_ids[m.contact_interface]
    force = m.force_vectors(x)
    nu = c.normal[itf]
    normal = np.einsum("pk,pk->p", force, nu)
    shear = np.linalg.norm(force - normal[:, None] * nu, axis=1)
    pts = c.points[m.contact_source]
    ids = np.asarray(s.block_ids, object)
    frame = pd.DataFrame({
        "interface": itf.astype(np.int64), "point": m.contact_source.astype(np.int64),
        "minus": c.minus[itf].astype(np.int64), "plus": c.plus[itf].astype(np.int64),
        "minus_id": ids[c.minus[itf]], "plus_id": ids[c.plus[itf]],
        "x": pts[:, 0], "y": pts[:, 1], "z": pts[:, 2], "normal": normal + 0.0, "shear": shear,
        "force_x": force[:, 0] + 0.0, "force_y": force[:, 1] + 0.0, "force_z": force[:, 2] + 0.0,
    })
    return frame.sort_values(["interface", "point"], kind="stable").reset_index(drop=True)


def contact_resultants(ops: Any, solution: Any):
    """Per interface, the resultant of its points' forces (module docstring): one row per interface with
    unknowns, in the structure's order; columns :data:`RESULTANT_COLUMNS` (moments about ``centre``, the mean of
    its points; ``torsion`` about the normal, ``bending`` the size of the rest)."""
    import pandas as pd

    x = _array(solution, "x")
    if x is None:
        return _empty(RESULTANT_COLUMNS)
    forces = contact_forces(ops, x)
    m = ContactMap.of(ops)
    c = m.structure.contacts
    rows = []
    for k, group in forces.groupby("interface", sort=True):
        pts = c.points[c.point_start[k]: c.point_start[k + 1]]
        centre = pts.mean(axis=0)
        f = group[["force_x", "force_y", "force_z"]].to_numpy()
        r = group[["x", "y", "z"]].to_numpy() - centre
        total, moment = f.sum(axis=0), np.cross(r, f).sum(axis=0)
        nu = c.normal[k]
        n, torsion = float(total @ nu), float(moment @ nu)
        rows.append([k, group["minus"].iat[0], group["plus"].iat[0], group["minus_id"].iat[0], group["plus_id"].iat[0],
                     *centre, *nu, n, float(np.linalg.norm(total - n * nu)), torsion,
                     float(np.linalg.norm(moment - torsion * nu)), *total, *moment])
    if not rows:
        return _empty(RESULTANT_COLUMNS)
    return pd.DataFrame(rows, columns=list(RESULTANT_COLUMNS))


def mechanism_frame_3d(ops: Any, solution: Any):
    """The mechanism per free block, in the structure's block order, ids, axes and units (module docstring)."""
    import pandas as pd

    u = _array(solution, "u")
    if u is None:
        return _empty(MECHANISM_COLUMNS_3D)
    m = ContactMap.of(ops)
    free = np.asarray(m.free_blocks, np.int64)
    if u.shape != (6 * free.size,):
        raise StructureError(f"block velocities: expected shape ({6 * free.size},) (6 per free block); got {u.shape}")
    order = np.argsort(free, kind="stable")
    q = u.reshape(-1, 6)[order]
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        v = (q[:, :3] @ m.rotation) / m.force_scale
        w = (q[:, 3:] @ m.rotation) / m.force_scale / m.length_scale
    ids = np.asarray(m.structure.block_ids, object)
    return pd.DataFrame({"block": free[order], "block_id": ids[free[order]],
                         "u_x": v[:, 0] + 0.0, "u_y": v[:, 1] + 0.0, "u_z": v[:, 2] + 0.0,
                         "rotation_x": w[:, 0] + 0.0, "rotation_y": w[:, 1] + 0.0, "rotation_z": w[:, 2] + 0.0})


def resultants(result):
    """The contact resultants of a 3D :class:`~blockmpec.result.Result` (see :func:`contact_resultants`)."""
    return contact_resultants(result.structure_map, result.solution)
