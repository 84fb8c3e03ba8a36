r"""Results in the structure's terms: interface forces and collapse mechanism as DataFrames.

The solvers work on the *canonical* problem of :func:`blockmpec.operators.assemble`: blocks and
interfaces in canonical order, some interfaces with minus and plus swapped
(``interface_flipped``), the ``x`` axis along the total live load (``mirror = -1`` when that is the
structure's ``-x``), lengths over ``length_scale`` and forces over ``force_scale``.  A
:class:`~blockmpec.result.Solution` holds that problem's unknowns.  This module turns them back
into the structure's ids, order, frame and units; :attr:`blockmpec.result.Result.forces` and
:attr:`~blockmpec.result.Result.mechanism` call it, and so can any helper holding the operators.

Interface forces (:func:`forces_frame`)
    ``(t, n, m)`` of interface ``k`` of the structure are what its plus block exerts on its minus
    block: the force ``t tau + n nu`` and the moment ``m`` about the segment midpoint, with
    ``nu = rot90(end - start) / L`` pointing from minus into plus and ``tau`` = ``nu`` rotated by
    -90 degrees (:mod:`blockmpec.geometry`); ``n <= 0`` in compression.  From the canonical
    ``(t', n', m')`` of the same interface,

    .. math::

        t = \mathrm{mirror}\; F\, t', \qquad n = F\, n', \qquad
        m = \mathrm{mirror}\; s_k\, F \ell\, m',

    with ``F = force_scale``, ``ell = length_scale`` and ``s_k = -1`` for a flipped interface
    (its canonical minus block is the structure's plus block), else ``+1``: a mirror image turns
    the tangent and the sense of rotation, a swap of the two blocks turns the moment (the
    opposite block's moment) while the force on the other block, seen from the swapped normal,
    keeps its components.  Forces are in the units of ``density x area`` (the structure's loads),
    moments in those times its length unit.

Collapse mechanism (:func:`mechanism_frame`)
    The velocity ``(u_x, u_y)`` of each free block's centroid and its rotation rate ``theta``
    (counter-clockwise positive), normalised so that the live load's power is one:
    ``f_l^T u = 1`` in the structure's units (one force unit times one length unit per unit
    time).  From the canonical ``(u_x', u_y', theta')`` (normalised alike in the scaled units),

    .. math::

        u_x = \mathrm{mirror}\; u_x' / F, \qquad u_y = u_y' / F, \qquad
        \theta = \mathrm{mirror}\; \theta' / (F \ell).

    A mechanism is defined up to a positive factor; this normalisation is the one of the
    kinematic problem, where ``lam`` is the power the live load must supply.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from blockmpec.errors import StructureError

#: Columns of :func:`forces_frame` (a contract: ``res.forces``, ``blockmpec solve --forces``).
FORCE_COLUMNS = ("interface", "minus", "plus", "start_x", "start_y", "end_x", "end_y", "shear", "normal", "moment")
#: Columns of :func:`mechanism_frame` (a contract: ``res.mechanism``, ``blockmpec solve --mechanism``).
MECHANISM_COLUMNS = ("block", "u_x", "u_y", "rotation")


@dataclass(frozen=True, eq=False)
class StructureMap:
    """How the unknowns of the canonical problem map onto a structure's ids, frame and units.

    Small enough to travel with a :class:`~blockmpec.result.Result` (references to the
    structure's interface arrays and the canonical permutations, no operator).

    Attributes
    ----------
    minus, plus : ndarray of int, shape (c_s,)
        The structure's interfaces' minus and plus blocks (all ``c_s`` of them).
    start, end : ndarray, shape (c_s, 2)
        Their end points, as in the structure.
    interface_ids : ndarray of int, shape (c,)
        Structure interface of each canonical interface (column of ``E``); the ``c_s - c``
        interfaces between two fixed blocks have none.
    interface_flipped : ndarray of bool, shape (c,)
        Canonical interfaces whose minus and plus blocks are the structure's plus and minus.
    free_blocks : ndarray of int, shape (b,)
        Structure block of each canonical free block (row block of ``E``).
    mirror : float
        -1 when the canonical ``x`` axis is the structure's ``-x``, else +1.
    length_scale, force_scale : float
        The structure's length and force of one canonical unit.
    """

    minus: np.ndarray
    plus: np.ndarray
    start: np.ndarray
    end: np.ndarray
    interface_ids: np.ndarray
    interface_flipped: np.ndarray
    free_blocks: np.ndarray
    mirror: float
    length_scale: float
    force_scale: float

    @classmethod
    def of(cls, ops: Any) -> StructureMap:
        """The map of assembled operators (:class:`~blockmpec.operators.Operators`); a map is returned as is.

        Raises
        ------
        StructureError
            When the operators were not assembled from a structure (``ops.structure`` is None).
        """
        if isinstance(ops, StructureMap) or getattr(ops, "dim", 2) == 3 and not hasattr(ops, "E"):
            return ops
        if getattr(ops, "dim", 2) == 3:  # a 3D problem: its map (blockmpec.three_d.report)
            from blockmpec.three_d.report import ContactMap

            return ContactMap.of(ops)
        structure = getattr(ops, "structure", None)
        if structure is None:
            raise StructureError(
                "these operators were not assembled from a Structure (Operators.structure is None), so results "
                "cannot be reported in a structure's ids and units; solve a Structure or bm.assemble(structure)")
        itf = structure.interfaces
        c = int(np.shape(ops.interface_ids)[0])
        flipped = np.zeros(c, bool) if ops.interface_flipped is None else np.asarray(ops.interface_flipped, bool)
        return cls(minus=itf.minus, plus=itf.plus, start=itf.start, end=itf.end,
                   interface_ids=np.asarray(ops.interface_ids), interface_flipped=flipped,
                   free_blocks=np.asarray(ops.free_blocks), mirror=float(ops.mirror),
                   length_scale=float(ops.length_scale), force_scale=float(ops.force_scale))


def _array(solution: Any, name: str) -> np.ndarray | None:
    """``solution.<name>`` for a :class:`~blockmpec.result.Solution`, else ``solution`` itself (an array or None)."""
    value = getattr(solution, name) if hasattr(solution, name) else solution
    return None if value is None else np.asarray(value, float)


def forces_frame(ops: Any, solution: Any):
    """Interface forces in the structure's ids, order, frame and units (see the module docstring).

    Parameters
    ----------
    ops : Operators or StructureMap or None
        The assembled problem the solution belongs to (assembled from a structure; may be None
        when there are no forces).
    solution : Solution or ndarray of shape (3c,) or None
        The canonical interface forces ``x`` (or a solution holding them).

    Returns
    -------
    pandas.DataFrame
        One row per interface of the structure, in its order (row ``k`` is interface ``k``), with
        columns ``interface, minus, plus, start_x, start_y, end_x, end_y, shear, normal, moment``:
        the structure's interface index, blocks and end points, and ``(t, n, m)``, what the plus
        block exerts on the minus block (moment about the midpoint, ``normal <= 0`` in
        compression).  An interface between two fixed blocks carries no unknown of the problem:
        its forces are NaN.  Without forces (``x`` None) the frame is empty, with these columns.

    Raises
    ------
    StructureError
        When ``ops`` has no structure, or ``x`` does not have 3 entries per canonical interface.
    """
    import pandas as pd

    if getattr(ops, "dim", 2) == 3:  # per contact point (blockmpec.three_d.report)
        from blockmpec.three_d.report import contact_forces

        return contact_forces(ops, solution)
    x = _array(solution, "x")
    if x is None:
        return _empty(FORCE_COLUMNS, ("interface", "minus", "plus"))
    m = StructureMap.of(ops)
    ids = np.asarray(m.interface_ids, int)
    if x.shape != (3 * ids.size,):
        raise StructureError(f"interface forces: expected shape ({3 * ids.size},) (3 per interface of the problem); "
                             f"got {x.shape}")
    x = x.reshape(-1, 3)
    c_s = int(np.shape(m.minus)[0])
    shear, normal, moment = np.full(c_s, np.nan), np.full(c_s, np.nan), np.full(c_s, np.nan)
    swap = np.where(np.asarray(m.interface_flipped, bool), -1.0, 1.0)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        shear[ids] = m.mirror * (x[:, 0] * m.force_scale)
        normal[ids] = x[:, 1] * m.force_scale
        moment[ids] = m.mirror * swap * (x[:, 2] * m.force_scale) * m.length_scale
    shear, normal, moment = shear + 0.0, normal + 0.0, moment + 0.0  # -0.0 (a sign flip of 0) prints as 0
    start, end = np.asarray(m.start, float).reshape(-1, 2), np.asarray(m.end, float).reshape(-1, 2)
    return pd.DataFrame({
        "interface": np.arange(c_s, dtype=np.int64),
        "minus": np.asarray(m.minus, np.int64),
        "plus": np.asarray(m.plus, np.int64),
        "start_x": start[:, 0], "start_y": start[:, 1],
        "end_x": end[:, 0], "end_y": end[:, 1],
        "shear": shear, "normal": normal, "moment": moment,
    })


def mechanism_frame(ops: Any, solution: Any):
    """The collapse mechanism in the structure's ids, order, frame and units (see the module docstring).

    Parameters
    ----------
    ops : Operators or StructureMap or None
        The assembled problem the solution belongs to (assembled from a structure; may be None
        when there is no mechanism).
    solution : Solution or ndarray of shape (3b,) or None
        The canonical block velocities ``u`` (or a solution holding them).

    Returns
    -------
    pandas.DataFrame
        One row per free block, in the structure's block order, with columns
        ``block, u_x, u_y, rotation``: the structure's block index, the velocity of its centroid
        and its rotation rate (counter-clockwise positive), normalised so that the live load's
        power is one, ``f_l^T u = 1`` in the structure's units (force unit x length unit per unit
        time).  Without a mechanism (``u`` None) the frame is empty, with these columns.

    Raises
    ------
    StructureError
        When ``ops`` has no structure, or ``u`` does not have 3 entries per free block.
    """
    import pandas as pd

    if getattr(ops, "dim", 2) == 3:  # six velocities per block (blockmpec.three_d.report)
        from blockmpec.three_d.report import mechanism_frame_3d

        return mechanism_frame_3d(ops, solution)
    u = _array(solution, "u")
    if u is None:
        return _empty(MECHANISM_COLUMNS, ("block",))
    m = StructureMap.of(ops)
    free = np.asarray(m.free_blocks, np.int64)
    if u.shape != (3 * free.size,):
        raise StructureError(f"block velocities: expected shape ({3 * free.size},) (3 per free block); got {u.shape}")
    order = np.argsort(free, kind="stable")
    u = u.reshape(-1, 3)[order]
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        return pd.DataFrame({
            "block": free[order],
            "u_x": m.mirror * u[:, 0] / m.force_scale + 0.0,  # + 0.0: no -0.0 from a sign flip of 0
            "u_y": u[:, 1] / m.force_scale + 0.0,
            "rotation": m.mirror * u[:, 2] / m.force_scale / m.length_scale + 0.0,
        })


def _empty(columns: tuple[str, ...], integer: tuple[str, ...]):
    """An empty DataFrame with ``columns`` (``integer`` ones int64, the others float)."""
    import pandas as pd

    return pd.DataFrame({c: np.zeros(0, np.int64 if c in integer else float) for c in columns})
