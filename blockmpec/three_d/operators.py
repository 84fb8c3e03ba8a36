r"""Sparse operators of the 3D limit-analysis problems: the same contract as 2D, on contact points.

Unknowns
--------
* contact forces ``x``, shape ``(3p,)`` over the ``p`` contact points (the vertices of every contact
  polygon): ``x[3j:3j+3] = (t1_j, t2_j, n_j)``, the shear forces along the interface's tangents
  ``e1, e2`` and the normal force along its normal ``nu`` (from minus into plus), what the plus block
  exerts on the minus block at the point; ``n_j <= 0`` in compression;
* block velocities ``u``, shape ``(6b,)`` over the free blocks: ``(u_x, u_y, u_z, w_x, w_y, w_z)``,
  the velocity of the centroid and the angular velocity;
* flow multipliers ``z_u >= 0``, shape ``(p,)`` (opening at each point) and ``z_f >= 0``, shape ``(s p,)``
  (sliding on each of the ``s`` sides of each point's friction pyramid).

Operators (scipy.sparse CSR)
----------------------------
``E`` (6b x 3p)
    equilibrium ``E x + f_d + lam f_l = 0``: the force ``t1 e1 + t2 e2 + n nu`` at point ``r_j`` acts on the
    minus block with moment ``(r_j - c) x F`` about its centroid ``c``, and opposite on the plus block.
``N_u`` (3p x p)
    no tension ``N_u^T x <= 0``: ``n_j <= 0``.
``N_f`` (3p x sp)
    the inscribed friction pyramid ``N_f^T x <= 0``: for each side ``k`` of point ``j``,
    ``(cos a_k t1 + sin a_k t2) / cos(pi/s) + mu n <= 0``, ``a_k = (2k + 1) pi / s``.  Its vertices are at the
    angles ``2 k pi / s`` from ``e1`` and lie on the Coulomb cone ``|t| = -mu n``: the pyramid is inscribed, so the
    associative multiplier is a lower bound of the cone's, and sliding along a vertex direction is exact.  Each
    row is scaled so that the coefficient of ``n`` is exactly ``mu`` (as in 2D): the fixed point's cohesion is
    ``-n* (tan phi - tan psi)`` on each side.
``V_f`` (3p x sp)
    the friction flow directions: ``N_f`` with ``tan(psi)`` in place of ``tan(phi)``.

Tangents: ``e1`` is the horizontal direction of the contact plane (``z x nu`` normalised), or the canonical ``x``
axis (the live load's horizontal direction) when the plane is horizontal; ``e2 = nu x e1``.  With the default 4
sides the pyramid's vertices lie along ``e1`` and ``e2``: along the global axes that lie in the contact plane
when the live load is along ``x`` or ``y`` (a horizontal bed joint: ``x`` and ``y``; a vertical head joint: the
horizontal axis and ``z``; an inclined joint: its horizontal line and its slope).

Canonical frame and units
-------------------------
As in 2D (:mod:`blockmpec.units`) the solvers see a nondimensional problem in a canonical frame: origin at the
volume-weighted centroid of the free blocks, lengths over ``length_scale`` (the median cube root of the free
blocks' volumes), ``z`` up and ``x`` along the live load's horizontal part (``y = z x x``), coordinates and normals
snapped to a dyadic grid of ``2**-40`` of the smallest block (by the cube root of its volume); each block's volume
and centroid summed in an order fixed by its snapped vertices; forces over ``force_scale`` (the mean live force of the free
blocks), loads snapped alike.  Free blocks are ordered by centroid height, then canonical ``x`` and ``y``; fixed
blocks before them; interfaces from the earlier block (minus) to the later, by minus, plus, then position; the
points of an interface by position.  A translation, a rotation about the vertical with the live load turned
alike, a reordering of the blocks or of their vertices, or a change of units gives the same problem: the same bits
where the snapped coordinates agree (always for a reordering, a quarter turn or a dyadic shift; for other motions
unless a coordinate falls within round-off of a midpoint of the grid, which a large offset makes likely: 1e3
lengths from the origin carry round-off of 1e-13, near the grid).  ``lam`` of the LPs is the same either way to
round-off; a non-unique solution of (3) can then differ.  Results come back in the structure's ids, frame and units through
:mod:`blockmpec.three_d.report`.

The layout contract shared with 2D (``block_dofs``, ``n_contacts``, ``normal_index``, ``unilateral_contact``,
``friction_contact``, ``unilateral_arm``, ``force_arm``, ``friction_operator``) is what lets the formulations,
the verifier and the engines run unchanged in both dimensions.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from blockmpec.errors import StructureError
from blockmpec.three_d.geometry import Structure3D
from blockmpec.three_d.polyhedra import FaceTable
from blockmpec.units import SNAP_BITS, Units, power_of_two, snap

#: dofs per free block: centroid velocity and angular velocity
BLOCK_DOFS = 6
#: positions closer than this (in length units) count as equal in the canonical order (as in 2D)
POSITION_GRID = 1e-7


@dataclass(frozen=True, eq=False)
class ContactUnits(Units):
    """:class:`blockmpec.units.Units` of a 3D problem: per block the load of its six generalised loads, per
    contact point (``interface_force``) the smaller load of its two blocks; every entry of ``x`` is a force."""

    pyramid_sides: int = 4

    def equilibrium_row_scale(self) -> np.ndarray:
        """``1 / l_i`` repeated over block ``i``'s six equilibrium rows, shape (6b,)."""
        return np.repeat(1.0 / self.block_load, BLOCK_DOFS)

    def force_column_scale(self) -> np.ndarray:
        """``(l_j, l_j, l_j)`` per contact point: the units of ``(t1, t2, n)``, shape (3p,)."""
        return np.repeat(self.interface_force, 3)

    def multiplier_column_scale(self, friction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Units of ``z_u`` (``1/l_j``) and ``z_f`` (``1/(l_j max(1, mu_j))`` on each side)."""
        f = self.interface_force
        return 1.0 / f, np.repeat(1.0 / (f * np.maximum(1.0, np.asarray(friction, float))), self.pyramid_sides)

    def forces_to_physical(self, x: np.ndarray) -> np.ndarray:
        """Contact forces ``x`` (3p,) in the structure's force unit (still in the canonical frame)."""
        return np.asarray(x, float) * self.force_scale


@dataclass(frozen=True, eq=False)
class Operators3D:
    """The assembled 3D problem; see the module docstring for the maths.

    Attributes
    ----------
    E : csr_array, shape (6b, 3p)
    N_u : csr_array, shape (3p, p)
    N_f, V_f : csr_array, shape (3p, s p)
    f_d, f_l : ndarray, shape (6b,)
    free_blocks : ndarray of int, shape (b,)
        Structure block of each free block (row block of ``E``).
    interface_ids : ndarray of int, shape (c,)
        Structure contact of each canonical interface.
    interface_flipped : ndarray of bool, shape (c,)
        Interfaces whose minus and plus are swapped relative to the structure (their normal is turned).
    contact_interface : ndarray of int, shape (p,)
        Canonical interface of each contact point.
    contact_source : ndarray of int, shape (p,)
        The structure's contact point (row of ``Contacts.points``) of each canonical point.
    contact_points : ndarray, shape (p, 3)
        Canonical coordinates of the points.
    normal, tangent1, tangent2 : ndarray, shape (c, 3)
        Canonical unit vectors of each interface.
    friction, dilatancy : ndarray, shape (p,)
        ``tan(phi)``, ``tan(psi)`` per contact point.
    minus_dof, plus_dof : ndarray of int, shape (p,)
        Free-block index of each point's minus and plus block, -1 for a fixed block.
    block_volume : ndarray, shape (b,)
    block_centroid : ndarray, shape (b, 3)
        Canonical.
    origin : ndarray, shape (3,)
    rotation : ndarray, shape (3, 3)
        Canonical coordinates are ``rotation @ (p - origin) / length_scale``.
    length_scale, force_scale : float
    pyramid_sides : int
    structure : Structure3D
    """

    E: sp.csr_array
    N_u: sp.csr_array
    N_f: sp.csr_array
    V_f: sp.csr_array
    f_d: np.ndarray
    f_l: np.ndarray
    free_blocks: np.ndarray
    interface_ids: np.ndarray
    interface_flipped: np.ndarray
    contact_interface: np.ndarray
    contact_source: np.ndarray
    contact_points: np.ndarray
    normal: np.ndarray
    tangent1: np.ndarray
    tangent2: np.ndarray
    friction: np.ndarray
    dilatancy: np.ndarray
    minus_dof: np.ndarray
    plus_dof: np.ndarray
    block_volume: np.ndarray
    block_centroid: np.ndarray
    origin: np.ndarray
    rotation: np.ndarray
    length_scale: float
    force_scale: float
    pyramid_sides: int
    structure: Structure3D | None = None

    dim = 3
    block_dofs = BLOCK_DOFS

    # ------------------------------------------------------------------ layout contract
    @property
    def n_free_blocks(self) -> int:
        """Number of free blocks ``b``."""
        return int(self.free_blocks.shape[0])

    @property
    def n_interfaces(self) -> int:
        """Number of interfaces (contact polygons) ``c``."""
        return int(self.interface_ids.shape[0])

    @property
    def n_contacts(self) -> int:
        """Number of contact points ``p`` (each carries three entries of ``x``)."""
        return int(self.contact_interface.shape[0])

    @property
    def normal_index(self) -> np.ndarray:
        """Positions of the normal forces in ``x``, shape (p,)."""
        return np.arange(2, 3 * self.n_contacts, 3)

    @property
    def shear_index(self) -> np.ndarray:
        """Positions of the shear forces ``(t1, t2)`` in ``x``, shape (p, 2)."""
        return np.arange(3 * self.n_contacts).reshape(-1, 3)[:, :2]

    @property
    def unilateral_contact(self) -> np.ndarray:
        """Contact point of each no-tension row (column of ``N_u``), shape (p,)."""
        return np.arange(self.n_contacts)

    @property
    def friction_contact(self) -> np.ndarray:
        """Contact point of each friction row (column of ``N_f``), shape (s p,)."""
        return np.repeat(np.arange(self.n_contacts), self.pyramid_sides)

    @property
    def unilateral_arm(self) -> np.ndarray:
        """Length turning each no-tension row into a force: 1 (the rows are forces), shape (p,)."""
        return np.ones(self.n_contacts)

    @property
    def force_arm(self) -> np.ndarray:
        """Length turning each entry of ``x`` into a force: 1, shape (3p,)."""
        return np.ones(3 * self.n_contacts)

    @property
    def is_associative(self) -> bool:
        """True when ``tan(psi) == tan(phi)`` everywhere (then ``V_f == N_f``)."""
        return bool(np.all(self.friction == self.dilatancy))

    @cached_property
    def units(self) -> ContactUnits:
        """The units of this problem (:class:`ContactUnits`)."""
        load = np.linalg.norm(self.f_d.reshape(-1, BLOCK_DOFS), axis=1) + np.linalg.norm(
            self.f_l.reshape(-1, BLOCK_DOFS), axis=1)
        if load.size:
            typical = float(np.median(load))
            load = np.maximum(load, 0.5 * typical * self.block_volume / float(np.mean(self.block_volume)))
        load = np.where(load > 0, load, np.max(load, initial=1.0))
        side = np.column_stack([self.minus_dof, self.plus_dof])
        unit = np.where(side >= 0, load[np.maximum(side, 0)], np.inf).min(axis=1)
        return ContactUnits(np.asarray(self.origin, float), float(self.length_scale), float(self.force_scale), load,
                            unit, np.ones(self.n_contacts), pyramid_sides=self.pyramid_sides)

    def friction_operator(self, coefficient: np.ndarray | float) -> sp.csr_array:
        """``N_f`` built with another friction coefficient per contact point (e.g. ``tan(psi)``)."""
        coef = np.broadcast_to(np.asarray(coefficient, float), (self.n_contacts,))
        return _pyramid(self.n_contacts, self.pyramid_sides, coef)

    def velocities_to_structure(self, u: np.ndarray) -> np.ndarray:
        """Block velocities ``u`` (6b,) in the structure's axes (lengths still in ``length_scale`` units)."""
        q = np.asarray(u, float).reshape(-1, BLOCK_DOFS)
        return np.column_stack([q[:, :3] @ self.rotation, q[:, 3:] @ self.rotation]).ravel()


def _pyramid(p: int, sides: int, coef: np.ndarray) -> sp.csr_array:
    """The inscribed pyramid's rows as columns of a (3p x sp) matrix (see the module docstring)."""
    angle = (2 * np.arange(sides) + 1) * np.pi / sides
    half = np.cos(np.pi / sides)
    j = np.repeat(np.arange(p), sides)
    col = np.arange(p * sides)
    c1 = np.tile(np.cos(angle) / half, p)
    c2 = np.tile(np.sin(angle) / half, p)
    c1[np.abs(c1) < 1e-15] = 0.0
    c2[np.abs(c2) < 1e-15] = 0.0
    rows = np.concatenate([3 * j, 3 * j + 1, 3 * j + 2])
    cols = np.concatenate([col, col, col])
    vals = np.concatenate([c1, c2, coef[j]])
    m = sp.csr_array((vals, (rows, cols)), shape=(3 * p, sides * p))
    m.eliminate_zeros()
    return m


# --------------------------------------------------------------------------- assembly


def canonical_frame(s: Structure3D) -> tuple[np.ndarray, float, np.ndarray, float]:
    """``(origin, length_scale, rotation, grid)`` of a structure (see the module docstring)."""
    free = ~s.fixed
    vol = s.volume
    origin = (vol[free, None] * s.centroid[free]).sum(axis=0) / vol[free].sum()
    ell = float(np.median(np.cbrt(vol[free])))
    if not ell > 0 or not np.isfinite(ell):
        raise StructureError("blocks: the free blocks have no volume")
    d = np.asarray(s.live_direction, float)
    h = np.array([d[0], d[1], 0.0])
    x = h / np.linalg.norm(h) if np.linalg.norm(h) > 1e-12 else np.array([1.0, 0.0, 0.0])
    z = np.array([0.0, 0.0, 1.0])
    rotation = np.vstack([x, np.cross(z, x), z])
    smallest = float(np.min(np.cbrt(vol))) / ell  # a size that turns with the structure (a box's sides do not)
    grid = float(np.ldexp(power_of_two(smallest) if smallest > 0 else 1.0, -SNAP_BITS))
    return origin, ell, rotation, grid


def _ranks(points: np.ndarray) -> np.ndarray:
    """Rank of each point in the order height, then ``x``, then ``y`` (on a grid of ``POSITION_GRID``), ties by index."""
    key = np.round(points / POSITION_GRID)
    order = np.lexsort((np.arange(points.shape[0]), key[:, 1], key[:, 0], key[:, 2]))
    rank = np.empty(order.size, int)
    rank[order] = np.arange(order.size)
    return rank


def _tangents(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``e1`` (the plane's horizontal direction, or ``x`` for a horizontal plane) and ``e2 = nu x e1``."""
    e1 = np.cross(np.array([0.0, 0.0, 1.0]), normal)
    length = np.linalg.norm(e1, axis=1, keepdims=True)
    e1 = np.where(length > 1e-9, e1 / np.maximum(length, 1e-300), np.array([1.0, 0.0, 0.0]))
    return e1, np.cross(normal, e1)


def assemble_3d(structure: Structure3D) -> Operators3D:
    """Assemble ``E, N_u, N_f, V_f, f_d, f_l`` of a 3D structure in canonical order (module docstring)."""
    s = structure
    origin, ell, R, grid = canonical_frame(s)

    def to_canonical(p):
        return snap((np.asarray(p, float) - origin) @ R.T / ell, grid)

    table = FaceTable(s.vertices, s.faces)
    volume, centroid = table.canonical(to_canonical(table.points)).mass()
    free = np.flatnonzero(~s.fixed)
    fixed = np.flatnonzero(s.fixed)
    rank = np.empty(s.n_blocks, int)
    rank[free] = _ranks(centroid[free])
    rank[fixed] = _ranks(centroid[fixed]) - fixed.size
    free_blocks = free[np.argsort(rank[free])]
    b = free_blocks.size
    dof = np.full(s.n_blocks, -1)
    dof[free_blocks] = np.arange(b)

    dead, live, force_scale = _loads(s, volume, R, ell)
    dead, live = dead[free_blocks], live[free_blocks]

    c = s.contacts
    keep = np.flatnonzero(~(s.fixed[c.minus] & s.fixed[c.plus]))
    flipped = rank[c.minus[keep]] > rank[c.plus[keep]]
    minus = np.where(flipped, c.plus[keep], c.minus[keep])
    plus = np.where(flipped, c.minus[keep], c.plus[keep])
    # normals snapped like the coordinates (a turned or reordered input gives them to round-off only)
    normal = snap((c.normal[keep] @ R.T) * np.where(flipped, -1.0, 1.0)[:, None], 2.0**-SNAP_BITS)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    points = to_canonical(c.points)
    point_itf = c.point_interface
    centre = np.array([points[c.point_start[k]: c.point_start[k + 1]].mean(axis=0) for k in keep]).reshape(-1, 3)
    key = np.round(centre / POSITION_GRID)
    order = np.lexsort((keep, key[:, 1], key[:, 0], key[:, 2], rank[plus], rank[minus]))
    ids, flipped, minus, plus, normal = keep[order], flipped[order], minus[order], plus[order], normal[order]

    # contact points: interface by interface in canonical order, each interface's points by position
    src = []
    for k in ids:
        pts = np.arange(c.point_start[k], c.point_start[k + 1])
        src.append(pts[np.argsort(_ranks(points[pts]), kind="stable")])
    source = np.concatenate(src) if src else np.zeros(0, int)
    itf_of_point = np.repeat(np.arange(ids.size), [len(x) for x in src]).astype(int)
    assert np.array_equal(ids[itf_of_point], point_itf[source])
    r = points[source]
    p = r.shape[0]
    e1, e2 = _tangents(normal)
    m_dof, p_dof = dof[minus[itf_of_point]], dof[plus[itf_of_point]]

    E = _equilibrium(r, e1[itf_of_point], e2[itf_of_point], normal[itf_of_point], centroid[free_blocks], m_dof, p_dof, b)
    _check_finite(s, E, dead, live, free_blocks)
    N_u = sp.csr_array((np.ones(p), (3 * np.arange(p) + 2, np.arange(p))), shape=(3 * p, p))
    friction = np.full(p, s.friction)
    dilatancy = np.full(p, s.dilatancy)
    sides = s.pyramid_sides
    return Operators3D(
        E=E, N_u=N_u, N_f=_pyramid(p, sides, friction), V_f=_pyramid(p, sides, dilatancy),
        f_d=dead.ravel(), f_l=live.ravel(), free_blocks=free_blocks, interface_ids=ids, interface_flipped=flipped,
        contact_interface=itf_of_point, contact_source=source, contact_points=r, normal=normal, tangent1=e1,
        tangent2=e2, friction=friction, dilatancy=dilatancy, minus_dof=m_dof, plus_dof=p_dof,
        block_volume=volume[free_blocks], block_centroid=centroid[free_blocks], origin=origin, rotation=R,
        length_scale=ell, force_scale=force_scale, pyramid_sides=sides, structure=structure)


def _loads(s: Structure3D, volume: np.ndarray, R: np.ndarray, ell: float):
    """Nondimensional dead and live loads (n, 6) of every block, and the force scale."""
    free = ~s.fixed
    density_unit = power_of_two(float(np.median(s.density[free])))
    weight = (s.density / density_unit) * volume
    direction = R @ np.asarray(s.live_direction, float)
    direction[np.abs(direction) < 1e-15] = 0.0
    dead = np.zeros((s.n_blocks, BLOCK_DOFS))
    live = np.zeros((s.n_blocks, BLOCK_DOFS))
    dead[:, 2] = -weight
    live[:, :3] = (s.live_factor * weight)[:, None] * direction
    unit = float(np.mean(np.linalg.norm(live[free, :3], axis=1)))
    unit = unit if unit > 0 and np.isfinite(unit) else 1.0
    dead, live = dead / unit, live / unit
    positive = np.linalg.norm(dead[free], axis=1) + np.linalg.norm(live[free], axis=1)
    positive = positive[positive > 0]
    if positive.size:
        g = float(np.ldexp(power_of_two(float(positive.min())), -SNAP_BITS))
        dead, live = snap(dead, g), snap(live, g)
    return dead, live, float(density_unit * ell**3 * unit)


def _equilibrium(r, e1, e2, nu, centroid, m_dof, p_dof, b) -> sp.csr_array:
    """``E`` (6b x 3p): each component's force and moment about the centroid, + on minus, - on plus."""
    p = r.shape[0]
    rows, cols, vals = [], [], []
    for side, dof in ((1.0, m_dof), (-1.0, p_dof)):
        has = np.flatnonzero(dof >= 0)
        arm = r[has] - centroid[dof[has]]
        for comp, d in enumerate((e1, e2, nu)):
            force = d[has]
            moment = np.cross(arm, force)
            gen = np.hstack([force, moment]) * side
            rows.append((BLOCK_DOFS * dof[has])[:, None] + np.arange(BLOCK_DOFS)[None, :])
            cols.append(np.repeat((3 * has + comp)[:, None], BLOCK_DOFS, axis=1))
            vals.append(gen)
    E = sp.csr_array((np.concatenate([v.ravel() for v in vals]),
                      (np.concatenate([x.ravel() for x in rows]), np.concatenate([x.ravel() for x in cols]))),
                     shape=(BLOCK_DOFS * b, 3 * p))
    E.sum_duplicates()
    E.data[np.abs(E.data) < 1e-15] = 0.0
    E.eliminate_zeros()
    return E


def _check_finite(s, E, dead, live, free_blocks) -> None:
    bad = np.flatnonzero(~(np.isfinite(dead).all(axis=1) & np.isfinite(live).all(axis=1)))
    if bad.size:
        raise StructureError(f"block {s.block_ids[free_blocks[bad[0]]]}: its load is not finite")
    if not np.all(np.isfinite(E.data)):
        raise StructureError("the equilibrium operator has non-finite entries")
