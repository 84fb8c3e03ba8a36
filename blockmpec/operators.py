r"""Sparse operators of the rigid-block limit-analysis problems.

Unknowns
--------
* interface forces ``x``, shape ``(3c,)``: ``x[3k:3k+3] = (t_k, n_k, m_k)``
  (shear, normal, moment about the interface midpoint; see :mod:`blockmpec.geometry`
  for the sign conventions);
* block velocities ``u``, shape ``(3b,)`` over the *free* blocks:
  ``u[3i:3i+3] = (u_x, u_y, theta)`` at the block centroid;
* flow multipliers ``z_u >= 0``, shape ``(2c,)`` (rocking about either end) and
  ``z_f >= 0``, shape ``(2c,)`` (sliding either way).

Operators (scipy.sparse CSR)
----------------------------
``E`` (3b x 3c)
    equilibrium: ``E x + f_d + lam f_l = 0``.  ``E = -B^T`` where ``B u`` is the
    velocity jump (plus block relative to minus block) at each interface, in the
    interface frame ``(tau, nu, rotation)``.
``N_u`` (3c x 2c)
    unilateral (no-tension) constraints ``N_u^T x <= 0``:
    ``m + n L/2 <= 0`` and ``-m + n L/2 <= 0``, i.e. ``|m| <= -n L/2``.  The row
    ``n <= 0`` of the paper is their half-sum, so it is redundant and left out
    (the cone of admissible jumps ``N_u z_u`` is unchanged).
``N_f`` (3c x 2c)
    friction constraints ``N_f^T x <= 0``: ``t + mu n <= 0`` and ``-t + mu n <= 0``,
    with ``mu = tan(phi)``.
``V_f`` (3c x 2c)
    friction flow directions: ``N_f`` with ``tan(psi)`` in place of ``tan(phi)``.

Scaling and canonical frame
---------------------------
The solvers see a nondimensional problem (:mod:`blockmpec.units`): lengths are
taken in the structure's :class:`~blockmpec.units.CanonicalFrame`, about the
centre of its bounding box, over ``length_scale`` (the median shorter side of the
free blocks), with the ``x`` axis along the total live load (``mirror = -1``
when that points to ``-x``), and snapped to a dyadic grid of about 1e-12 of the
smallest block; forces are divided by ``force_scale`` (the mean live force of
the free blocks, point loads included; the mean weight for the built-in cases)
and snapped alike.  Areas, centroids and arms are computed from the snapped
coordinates, each polygon from its lowest vertex, without forming a product of
two lengths in the structure's units, so the operators are the same at lengths
1e-150 or 1e140 and at offsets of 1e15, and a translation, a mirror image (live
load mirrored) or a change of units gives the same bits (see
:mod:`blockmpec.units` for the exception and the bound on ``lam`` from the
snapping).  ``lam`` is unchanged; ``x`` holds ``t, n`` in units of
``force_scale`` and ``m`` in units of ``force_scale * length_scale``
(:meth:`Operators.forces_to_physical`).  ``ops.units`` adds the load of each
block and the force unit of each interface for the per-block scalings of the
solvers.  Operators and loads are checked finite (the block is named), so no NaN
ever reaches a solver.

Rows and columns are in canonical order (see :func:`assemble`): the file's
block order, a translation or a mirror image give the same problem.

Compatibility (flow rule) reads ``E^T u + N_u z_u + V_f z_f = 0`` and the
normalisation ``f_l^T u = 1``.  Interfaces between two fixed blocks carry no
unknown that matters and are dropped at assembly.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from blockmpec.errors import StructureError
from blockmpec.geometry import Structure, polygon_shape
from blockmpec.units import SNAP_BITS, CanonicalFrame, Units, block_load, force_unit, power_of_two, snap


@dataclass(frozen=True, eq=False)
class Operators:
    """The assembled problem data; see the module docstring for the maths.

    Attributes
    ----------
    E : csr_array, shape (3b, 3c)
    N_u, N_f, V_f : csr_array, shape (3c, 2c)
    f_d, f_l : ndarray, shape (3b,)
    free_blocks : ndarray of int, shape (b,)
        Structure block index of each free block (row block ``i`` of ``E``).
    interface_ids : ndarray of int, shape (c,)
        Structure interface index of each kept interface.
    length : ndarray, shape (c,)
        Interface lengths ``L`` (in units of ``length_scale``).
    length_scale, force_scale : float
        The units of the nondimensional problem (see the module docstring).
    origin : ndarray, shape (2,)
        The structure point taken as the origin of the nondimensional coordinates.
    interface_flipped : ndarray of bool, shape (c,)
        Interfaces whose minus and plus block are swapped relative to the structure
        (canonical orientation; their ``m`` has the opposite sign).
    block_area : ndarray, shape (b,)
        Free-block areas, in units of ``length_scale`` squared.
    mirror : float
        -1 when the canonical ``x`` axis is the structure's ``-x`` (the total live load points
        to ``-x``), else +1; see :meth:`velocities_to_structure`.
    units : Units
        :class:`blockmpec.units.Units` of the problem (computed on first use).
    structure : Structure or None
        The structure these operators were assembled from (set by :func:`assemble`; a reference,
        not a copy), so that results can be reported in its ids, frame and units
        (:mod:`blockmpec.report`); operators changed after assembly (``dataclasses.replace``)
        keep it, and their results are reported against it.
    minus_dof, plus_dof : ndarray of int, shape (c,)
        Free-block index (row block of ``E``) of each interface's minus and plus
        block, -1 for a fixed block.
    friction, dilatancy : ndarray, shape (c,)
        ``tan(phi)`` and ``tan(psi)`` per interface.
    """

    E: sp.csr_array
    N_u: sp.csr_array
    N_f: sp.csr_array
    V_f: sp.csr_array
    f_d: np.ndarray
    f_l: np.ndarray
    free_blocks: np.ndarray
    interface_ids: np.ndarray
    length: np.ndarray
    friction: np.ndarray
    dilatancy: np.ndarray
    length_scale: float = 1.0
    force_scale: float = 1.0
    minus_dof: np.ndarray | None = None
    plus_dof: np.ndarray | None = None
    origin: np.ndarray | None = None
    interface_flipped: np.ndarray | None = None
    block_area: np.ndarray | None = None
    mirror: float = 1.0
    structure: Structure | None = None

    @cached_property
    def units(self) -> Units:
        """The units of this problem (:class:`blockmpec.units.Units`): length and force scales, and the
        load of each block and force unit of each interface, from the loads (point loads included)."""
        return Units.of(self)

    def forces_to_physical(self, x: np.ndarray) -> np.ndarray:
        """Interface forces ``x`` in the structure's units (``t, n`` x force_scale, ``m`` x force*length),
        still in canonical order and signs (for the structure's ids and signs:
        :func:`blockmpec.report.forces_frame`)."""
        out = np.asarray(x, float) * self.force_scale
        out[2::3] *= self.length_scale
        return out

    def velocities_to_structure(self, u: np.ndarray) -> np.ndarray:
        """Block velocities ``u`` (3b,) of the canonical frame in the structure's axes:
        ``(mirror u_x, u_y, mirror theta)`` (lengths still in units of ``length_scale``)."""
        out = np.array(u, float).reshape(-1, 3)
        out[:, 0] *= self.mirror
        out[:, 2] *= self.mirror
        return out.ravel()

    @property
    def n_interfaces(self) -> int:
        """Number of interfaces ``c``."""
        return int(self.length.shape[0])

    # ------------------------------------------------------------------ the layout contract shared with 3D
    # (:class:`blockmpec.three_d.operators.Operators3D` honours the same): the formulations, the verifier and
    # the engines read the layout of ``x``, ``u`` and the yield rows from these, never from strides.

    #: space dimension
    dim = 2
    #: generalised velocities (and equilibrium rows) per free block: ``(u_x, u_y, theta)``
    block_dofs = 3

    @property
    def n_contacts(self) -> int:
        """Number of contacts, each carrying three entries of ``x`` and one normal force: the interfaces."""
        return self.n_interfaces

    @property
    def normal_index(self) -> np.ndarray:
        """Positions of the normal forces ``n_k`` in ``x``, shape (c,)."""
        return np.arange(1, 3 * self.n_interfaces, 3)

    @property
    def shear_index(self) -> np.ndarray:
        """Positions of the shear forces in ``x``, one column per shear component, shape (c, 1)."""
        return np.arange(0, 3 * self.n_interfaces, 3)[:, None]

    @property
    def unilateral_contact(self) -> np.ndarray:
        """Contact of each no-tension row (column of ``N_u``), shape (2c,)."""
        return np.repeat(np.arange(self.n_interfaces), 2)

    @property
    def friction_contact(self) -> np.ndarray:
        """Contact of each friction row (column of ``N_f``), shape (2c,); each row's ``n`` coefficient is
        exactly ``mu`` of its contact (so the fixed point's cohesion is ``-n* (tan phi - tan psi)`` per row)."""
        return np.repeat(np.arange(self.n_interfaces), 2)

    @property
    def unilateral_arm(self) -> np.ndarray:
        """Length turning each no-tension row ``+-m + n L/2`` into a force: ``L/2``, shape (2c,)."""
        return np.repeat(self.length / 2, 2)

    @property
    def force_arm(self) -> np.ndarray:
        """Length turning each entry of ``x`` into a force: 1 for ``t, n``, ``L/2`` for ``m``, shape (3c,)."""
        return np.column_stack([np.ones(self.n_interfaces), np.ones(self.n_interfaces), self.length / 2]).ravel()

    @property
    def n_free_blocks(self) -> int:
        """Number of free blocks ``b``."""
        return int(self.free_blocks.shape[0])

    @property
    def is_associative(self) -> bool:
        """True when ``tan(psi) == tan(phi)`` on every interface (then ``V_f == N_f``)."""
        return bool(np.all(self.friction == self.dilatancy))

    def friction_operator(self, coefficient: np.ndarray | float) -> sp.csr_array:
        """``N_f`` built with another friction coefficient per interface (e.g. ``tan(psi)``)."""
        c = self.n_interfaces
        coef = np.broadcast_to(np.asarray(coefficient, float), (c,))
        return _friction_matrix(coef)


def shear(x: np.ndarray) -> np.ndarray:
    """Shear forces ``t`` from ``x``, shape (c,)."""
    return x[0::3]


def normal(x: np.ndarray) -> np.ndarray:
    """Normal forces ``n`` (compression negative) from ``x``, shape (c,)."""
    return x[1::3]


def moment(x: np.ndarray) -> np.ndarray:
    """Moments ``m`` from ``x``, shape (c,)."""
    return x[2::3]


def _cross(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    return r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]


def _friction_matrix(coef: np.ndarray) -> sp.csr_array:
    c = coef.shape[0]
    k = np.arange(c)
    rows = np.concatenate([3 * k, 3 * k, 3 * k + 1, 3 * k + 1])
    cols = np.concatenate([2 * k, 2 * k + 1, 2 * k, 2 * k + 1])
    vals = np.concatenate([np.ones(c), -np.ones(c), coef, coef])
    return sp.csr_array((vals, (rows, cols)), shape=(3 * c, 2 * c))


def _canonical_ranks(keys: list[np.ndarray]) -> np.ndarray:
    """Rank of each item in the lexicographic order of ``keys`` (first key primary), ties by index."""
    order = np.lexsort(tuple(reversed(keys)))
    rank = np.empty(order.size, int)
    rank[order] = np.arange(order.size)
    return rank


def _position_key(points: np.ndarray) -> list[np.ndarray]:
    """Sort keys of points (canonical coordinates): height, then ``x``, on a grid of ``POSITION_GRID``."""
    return [np.round(points[:, 1] / POSITION_GRID), np.round(points[:, 0] / POSITION_GRID)]


#: Positions closer than this (in length units) count as equal in the canonical order.
POSITION_GRID = 1e-7


def _canonical_polygons(q: np.ndarray, n_vertices: np.ndarray, reverse: bool) -> np.ndarray:
    """Padded polygons ``q`` (n, k, 2) with each one's vertices reversed (``reverse``: a mirror image,
    to stay counter-clockwise) and rolled to start at its lowest, then leftmost vertex, so that the
    shoelace sums of a polygon do not depend on where its vertex list starts; padding repeats the last."""
    n, k, _ = q.shape
    j = np.arange(k)[None, :]
    nv = n_vertices[:, None]
    valid = j < nv
    y = np.where(valid, q[..., 1], np.inf)
    lowest = valid & (q[..., 1] == y.min(axis=1, keepdims=True))
    first = np.argmin(np.where(lowest, q[..., 0], np.inf), axis=1)[:, None]  # index in the file's order
    start = nv - 1 - first if reverse else first  # its position in the oriented order
    pos = np.where(valid, (start + j) % nv, (start + nv - 1) % nv)
    index = nv - 1 - pos if reverse else pos
    return q[np.arange(n)[:, None], index]


def _snap_loads(dead: np.ndarray, live: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nondimensional loads (b, 3) snapped to ``2**-SNAP_BITS`` of the power of two nearest the smallest
    positive block load (see :mod:`blockmpec.units`)."""
    load = block_load(dead, live)
    positive = load[load > 0]
    if positive.size == 0:
        return dead, live
    grid = float(np.ldexp(power_of_two(float(positive.min())), -SNAP_BITS))
    return snap(dead, grid), snap(live, grid)


def assemble(structure: Structure):
    """Assemble the operators of a structure: :func:`assemble_2d` for a :class:`~blockmpec.geometry.Structure`,
    :func:`blockmpec.three_d.operators.assemble_3d` for a :class:`~blockmpec.three_d.geometry.Structure3D`."""
    if getattr(structure, "dim", 2) == 3:
        from blockmpec.three_d.operators import assemble_3d

        return assemble_3d(structure)
    return assemble_2d(structure)


def assemble_2d(structure: Structure) -> Operators:
    """Assemble ``E, N_u, N_f, V_f, f_d, f_l`` for a structure (vectorised), in canonical order.

    Geometry is taken in the structure's :class:`~blockmpec.units.CanonicalFrame` (origin at the
    centre of its bounding box, lengths over the median shorter side of the free blocks, ``x``
    along the total horizontal live load, coordinates snapped to a dyadic grid ~1e-12 of the
    smallest block) and each polygon from its lowest vertex, so that no product of lengths is
    formed in the structure's units and a translation, a mirror image (with the live load
    mirrored) or a change of length or force unit assembles *the same bits*; loads are divided
    by a density unit, the length unit squared and then the force unit of :mod:`blockmpec.units`
    (point loads included), and snapped alike.  The result is the same at any magnitude
    (1e-150 ... 1e150) and offset.

    *Canonical order*: free blocks (rows of ``E``) are ordered by centroid height, then by
    canonical ``x``, fixed blocks likewise before them; interfaces (columns) are oriented from
    the earlier block (minus; a fixed block is always earlier) to the later one (plus) and
    ordered by minus block, plus block, then midpoint; ``interface_flipped`` marks those whose
    minus and plus are swapped relative to the structure (their ``m`` changes sign, ``t`` and
    ``n`` do not).  In a mirrored frame (``mirror = -1``) velocities ``u_x, theta`` and forces
    ``t, m`` have the opposite sign of the structure's (:meth:`Operators.velocities_to_structure`).
    So the file's block order, a translation or a mirror image give the same problem.

    Parameters
    ----------
    structure : Structure

    Returns
    -------
    Operators

    Raises
    ------
    StructureError
        When a load or an operator entry is not finite (the block is named), e.g. a density
        times an area beyond the floating-point range.
    """
    s = structure
    free = np.flatnonzero(~s.fixed)
    b = free.size
    frame, ell, density_unit, live_sign, mirror = _canonical_frame(s, free)
    area, centroid, dead, live, force_scale = _canonical_loads(s, frame, free, ell, density_unit, live_sign, mirror)
    rank, free_blocks, dof, order = _block_order(s, centroid, free)
    dead, live = dead[order], live[order]
    ids, flipped, minus, plus, mid, tau, nu, length = _interface_geometry(s, frame, rank, mirror)
    E = _equilibrium_matrix(minus, plus, dof, mid, centroid, tau, nu, b)
    _check_finite_operator(E, length, free_blocks, minus, ids)
    friction = s.interface_friction()[ids]
    dilatancy = s.interface_dilatancy()[ids]
    return Operators(
        E=E,
        N_u=_unilateral_matrix(length),
        N_f=_friction_matrix(friction),
        V_f=_friction_matrix(dilatancy),
        f_d=dead.ravel(),
        f_l=live.ravel(),
        free_blocks=free_blocks,
        interface_ids=ids,
        length=length,
        friction=friction,
        dilatancy=dilatancy,
        length_scale=ell,
        force_scale=force_scale,
        minus_dof=dof[minus],
        plus_dof=dof[plus],
        origin=frame.origin,
        interface_flipped=flipped,
        block_area=area[free_blocks],
        mirror=mirror,
        structure=structure,
    )


def _canonical_frame(s: Structure, free: np.ndarray):
    """``(frame, ell, density_unit, live_sign, mirror)``: the canonical frame, its length scale, the density unit
    (a power of two near the median density) and the live load's sign; the frame's ``x`` axis points along the total
    horizontal live load (weights and live point loads): ``mirror = -1`` when that is ``-x`` in the structure."""
    b = free.size
    frame = CanonicalFrame.of(s.vertices, free)
    ell = frame.length_scale
    density_unit = power_of_two(float(np.median(s.density[free]))) if b else 1.0
    live_sign = s.live_direction * s.live_factor
    q = frame(s.vertices)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        scale, area, _ = polygon_shape(q)
        area = area * scale * scale
        live_x = live_sign * (s.density[free] / density_unit) * area[free]
        live_x = list(live_x) + [pl.force[0] / density_unit / ell / ell for pl in s.point_loads
                                 if pl.kind == "live" and not s.fixed[pl.block]]
        total, size = float(np.sum(live_x)), float(np.sum(np.abs(live_x)))
    mirror = -1.0 if total < -1e-12 * size else 1.0
    return frame.mirrored(mirror), ell, density_unit, live_sign, mirror


def _canonical_loads(s: Structure, frame, free: np.ndarray, ell: float, density_unit: float, live_sign: float,
                     mirror: float):
    """``(area, centroid, dead, live, force_scale)``: every block's area and centroid in the canonical frame (each
    polygon from its lowest vertex: its shape data are the same bits), and the free blocks' dead and live loads
    ``(F_x, F_y, M)``, nondimensional (weights in units of ``rho ell^2``, point loads likewise, then all over the
    force unit) and snapped; ``force_scale`` the force unit in the structure's units."""
    q = _canonical_polygons(frame(s.vertices), s.n_vertices, reverse=mirror < 0)
    scale, area, local_centroid = polygon_shape(q)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        area = area * scale * scale
        centroid = q[:, 0, :] + local_centroid * scale[:, None]
        weight = (s.density / density_unit) * area
        dead = np.zeros((s.n_blocks, 3))
        live = np.zeros((s.n_blocks, 3))
        dead[:, 1] = -weight
        live[:, 0] = mirror * live_sign * weight
        for pl in s.point_loads:
            target = live if pl.kind == "live" else dead
            force = frame.vector(pl.force) / density_unit / ell / ell
            arm = frame(np.asarray(pl.point, float)) - centroid[pl.block]
            target[pl.block, :2] += force
            target[pl.block, 2] += arm[0] * force[1] - arm[1] * force[0]
    _check_finite_loads(s, dead, live, free)
    dead, live = dead[free], live[free]
    unit = force_unit(dead[:, :2], live[:, :2])
    dead, live = _snap_loads(dead / unit, live / unit)
    with np.errstate(over="ignore", under="ignore"):
        force_scale = float(density_unit * ell * ell * unit)
    return area, centroid, dead, live, force_scale


def _block_order(s: Structure, centroid: np.ndarray, free: np.ndarray):
    """``(rank, free_blocks, dof, order)``: the canonical rank of every block (fixed blocks first, then by centroid
    height and canonical ``x``), the free blocks in that order, each block's equilibrium row block (-1: fixed) and
    the order of the free blocks' loads."""
    fixed = np.flatnonzero(s.fixed)
    rank = np.empty(s.n_blocks, int)
    rank[free] = _canonical_ranks(_position_key(centroid[free]))
    rank[fixed] = _canonical_ranks(_position_key(centroid[fixed])) - fixed.size  # fixed blocks first
    free_blocks = free[np.argsort(rank[free])]
    dof = np.full(s.n_blocks, -1)
    dof[free_blocks] = np.arange(free.size)
    return rank, free_blocks, dof, np.argsort(rank[free])


def _interface_geometry(s: Structure, frame, rank: np.ndarray, mirror: float):
    """The interfaces in canonical order, oriented from the earlier block to the later: ``(ids, flipped, minus, plus,
    mid, tau, nu, length)``, with their midpoints, unit tangents and normals (normal from minus into plus) and
    lengths; each segment measured in units of a power of two near its size."""
    itf = s.interfaces
    keep = np.flatnonzero(~(s.fixed[itf.minus] & s.fixed[itf.plus]))
    flipped = rank[itf.minus[keep]] > rank[itf.plus[keep]]
    minus = np.where(flipped, itf.plus[keep], itf.minus[keep])
    plus = np.where(flipped, itf.minus[keep], itf.plus[keep])
    start, end = frame(itf.start[keep]).reshape(-1, 2), frame(itf.end[keep]).reshape(-1, 2)
    if mirror < 0:  # a mirror turns the normal: swap the ends to keep it from minus into plus
        start, end = end, start
    start, end = np.where(flipped[:, None], end, start), np.where(flipped[:, None], start, end)
    mid = 0.5 * start + 0.5 * end
    itf_order = np.lexsort((keep,) + tuple(reversed(_position_key(mid))) + (rank[plus], rank[minus]))
    ids, flipped, minus, plus = keep[itf_order], flipped[itf_order], minus[itf_order], plus[itf_order]
    start, end, mid = start[itf_order], end[itf_order], mid[itf_order]
    c = ids.size
    seg = end - start
    seg_unit = np.atleast_1d(power_of_two(np.abs(seg).max(axis=1) if c else np.zeros(0)))
    seg = seg / seg_unit[:, None]
    seg_length = np.sqrt((seg * seg).sum(axis=1))
    tau = seg / seg_length[:, None]
    nu = np.column_stack([-tau[:, 1], tau[:, 0]])
    return ids, flipped, minus, plus, mid, tau, nu, seg_length * seg_unit


def _equilibrium_matrix(minus, plus, dof, mid, centroid, tau, nu, b: int) -> sp.csr_array:
    """``E``: the generalised force (``F_x, F_y``, ``M`` about the centroid) of ``x_k = (t_k, n_k, m_k)`` on interface
    ``k``'s minus block, and minus that on its plus block (rows of free blocks only)."""
    c = minus.size
    rows, cols, vals = [], [], []
    k = np.arange(c)
    for side, blocks in ((1.0, minus), (-1.0, plus)):
        has = dof[blocks] >= 0
        kk = k[has]
        r0 = 3 * dof[blocks[has]]
        arm = mid[has] - centroid[blocks[has]]
        t_dir, n_dir = tau[has], nu[has]
        rows += [r0, r0 + 1, r0 + 2, r0, r0 + 1, r0 + 2, r0 + 2]
        cols += [3 * kk, 3 * kk, 3 * kk, 3 * kk + 1, 3 * kk + 1, 3 * kk + 1, 3 * kk + 2]
        vals += [
            side * t_dir[:, 0],
            side * t_dir[:, 1],
            side * _cross(arm, t_dir),
            side * n_dir[:, 0],
            side * n_dir[:, 1],
            side * _cross(arm, n_dir),
            side * np.ones(kk.size),
        ]
    E = sp.csr_array(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * b, 3 * c)
    )
    E.sum_duplicates()
    E.eliminate_zeros()
    return E


def _unilateral_matrix(length: np.ndarray) -> sp.csr_array:
    """``N_u``: the no-tension rows ``n_k L_k / 2 +- m_k <= 0`` of every interface (``N_u^T x <= 0``)."""
    c = length.size
    k = np.arange(c)
    rows_u = np.concatenate([3 * k + 1, 3 * k + 1, 3 * k + 2, 3 * k + 2])
    cols_u = np.concatenate([2 * k, 2 * k + 1, 2 * k, 2 * k + 1])
    vals_u = np.concatenate([length / 2, length / 2, np.ones(c), -np.ones(c)])
    return sp.csr_array((vals_u, (rows_u, cols_u)), shape=(3 * c, 2 * c))


def _check_finite_loads(s: Structure, dead: np.ndarray, live: np.ndarray, free: np.ndarray) -> None:
    """Raise naming the first free block whose nondimensional load is not finite."""
    bad = free[~(np.isfinite(dead[free]).all(axis=1) & np.isfinite(live[free]).all(axis=1))]
    if bad.size:
        i = int(bad[0])
        raise StructureError(
            f"block {i}: its load is not finite in the structure's units (density {s.density[i]:.3g} and point "
            "loads against the weights of the other blocks overflow the floating-point range)"
        )


def _check_finite_operator(E, length, free_blocks, minus, ids) -> None:
    """Raise naming the block or interface whose operator entries are not finite (never pass NaN to a solver)."""
    bad = np.flatnonzero(~np.isfinite(length) | ~(length > 0))
    if bad.size:
        k = int(bad[0])
        raise StructureError(f"interface {ids[k]}: its length is not a positive finite number in the structure's units")
    if not np.all(np.isfinite(E.data)):
        coo = E.tocoo()
        row = int(coo.row[~np.isfinite(coo.data)][0])
        raise StructureError(f"block {free_blocks[row // 3]}: its equilibrium operator has non-finite entries")
