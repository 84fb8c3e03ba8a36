"""3D rigid-block structures: blocks as closed polyhedra, their contacts, material and loads.

Conventions (stated once, used everywhere in :mod:`blockmpec.three_d`)
--------------------------------------------------------------------
* A block is a closed polyhedron given by its vertices ``(k, 3)`` and its faces, each a list of
  vertex indices in counter-clockwise order seen from outside (outward normal by the right-hand
  rule).  Faces may be any planar simple polygons, so a convex block is a few polygons and a
  non-convex one a closed triangle mesh.  Volume and centroid are the divergence-theorem sums over
  a fan triangulation of each face, exact for any closed polyhedron (computed relative to the
  block's first vertex, in units of its size, so that nothing cancels or overflows).
* ``z`` is up.  Dead load: the weight ``density * volume`` along ``-z`` at the centroid.  Live
  load: ``live_factor * weight`` along ``live_direction`` (a 3-vector, default ``+x``), at the
  centroid.  Blocks marked ``fixed`` are supports.
* A contact (interface) joins a *minus* and a *plus* block over a planar polygon where a face of
  one and a face of the other are coplanar with opposite outward normals; its unit normal ``nu``
  is the minus block's outward normal (from minus into plus).  Its *contact points* are the
  polygon's vertices; each carries a normal force ``n <= 0`` (compression) and two shear forces
  ``t1, t2`` along the interface's tangents, what the plus block exerts on the minus block
  (:mod:`blockmpec.three_d.operators`).  Torsion and bending of the interface follow from the
  points.
* Friction ``mu = tan(phi)`` and dilatancy ``tan(psi)``, ``0 <= tan(psi) <= tan(phi)``; the Coulomb
  cone is linearised by an inscribed pyramid of ``pyramid_sides`` sides
  (:mod:`blockmpec.three_d.operators`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from blockmpec.errors import GeometryError, OptionError, StructureError
from blockmpec.geometry import check_supported
from blockmpec.three_d.contacts import Contacts, check_overlaps, detect_contacts
from blockmpec.three_d.polyhedra import FaceTable, face_normals

#: Default relative tolerance for geometric tests (scaled by block size), as in 2D.
DEFAULT_GEOMETRY_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class Structure3D:
    """A validated 3D rigid-block structure; build it with :func:`make_structure_3d`.

    Attributes
    ----------
    vertices : tuple of ndarray, each shape (k_i, 3)
    faces : tuple of tuple of ndarray
        ``faces[i]`` are block ``i``'s faces (vertex indices, counter-clockwise from outside).
    fixed : ndarray of bool, shape (n_blocks,)
    density : ndarray, shape (n_blocks,)
    contacts : Contacts
    friction, dilatancy : float
        ``tan(phi)`` and ``tan(psi)``.
    live_direction : ndarray, shape (3,)
        Unit direction of the live body force.
    live_factor : float
        Live body force as a fraction of the weight.
    pyramid_sides : int
        Sides of the inscribed friction pyramid (4 or more).
    block_ids : tuple of str
        The user's name of each block (an OBJ object name, a file's id; ``str(i)`` by default).
    """

    vertices: tuple
    faces: tuple
    fixed: np.ndarray
    density: np.ndarray
    contacts: Contacts
    friction: float
    dilatancy: float = 0.0
    live_direction: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    live_factor: float = 1.0
    pyramid_sides: int = 4
    block_ids: tuple = ()
    name: str = "structure"
    metadata: dict = field(default_factory=dict)

    dim = 3

    @property
    def n_blocks(self) -> int:
        """Number of blocks, fixed ones included."""
        return len(self.vertices)

    @property
    def n_free(self) -> int:
        """Number of free blocks."""
        return int((~self.fixed).sum())

    @cached_property
    def _mass(self) -> tuple[np.ndarray, np.ndarray]:
        return FaceTable(self.vertices, self.faces).mass()

    @property
    def volume(self) -> np.ndarray:
        """Block volumes, shape (n_blocks,)."""
        return self._mass[0]

    @property
    def centroid(self) -> np.ndarray:
        """Block centroids, shape (n_blocks, 3)."""
        return self._mass[1]

    @property
    def weight(self) -> np.ndarray:
        """Block weights ``density * volume``, shape (n_blocks,)."""
        return self.density * self.volume

    def with_material(self, friction: float | None = None, dilatancy: float | None = None) -> Structure3D:
        """A copy with other material coefficients, validated."""
        s = replace(self, friction=self.friction if friction is None else float(friction),
                    dilatancy=self.dilatancy if dilatancy is None else float(dilatancy))
        _check_material(s.friction, s.dilatancy)
        return s

    def with_loads(self, live_direction=None, live_factor: float | None = None,
                   pyramid_sides: int | None = None) -> Structure3D:
        """A copy with another live load or friction pyramid, validated."""
        direction = self.live_direction if live_direction is None else _unit_direction(live_direction)
        factor = self.live_factor if live_factor is None else _live_factor(live_factor)
        sides = self.pyramid_sides if pyramid_sides is None else _pyramid_sides(pyramid_sides)
        return replace(self, live_direction=direction, live_factor=factor, pyramid_sides=sides)


# --------------------------------------------------------------------------- input checks


def _unit_direction(value) -> np.ndarray:
    try:
        d = np.asarray(value, float).reshape(3)
    except (TypeError, ValueError):
        raise OptionError(f"live_direction: must be a 3-vector such as [1, 0, 0]; got {value!r}") from None
    norm = float(np.linalg.norm(d))
    if not np.all(np.isfinite(d)) or norm == 0:
        raise OptionError(f"live_direction: must be a finite non-zero 3-vector; got {value!r}")
    return d / norm


def _live_factor(value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"live_factor: must be a number > 0; got {value!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise OptionError(f"live_factor: must be a finite number > 0; got {value!r}")
    return v


def _pyramid_sides(value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 3:
        raise OptionError(f"pyramid_sides: must be an integer >= 3 (the sides of the friction pyramid); got {value!r}")
    return int(value)


def _check_material(friction: float, dilatancy: float) -> None:
    for name, value in (("friction", friction), ("dilatancy", dilatancy)):
        if not np.isfinite(value) or value < 0:
            raise StructureError(f"{name}: must be a finite number >= 0; got {value}")
    if dilatancy > friction:
        raise StructureError(f"dilatancy: tan(psi) = {dilatancy} exceeds the friction coefficient tan(phi) = "
                             f"{friction}; the dilatancy angle must not exceed the friction angle")


def _block_arrays(blocks, names) -> tuple[tuple, tuple]:
    """Each block as (vertices (k, 3) float, faces tuple of int arrays), checked for shape and range."""
    verts, faces = [], []
    for i, blk in enumerate(blocks):
        where = f"block {names[i]}"
        try:
            v, f = blk
        except (TypeError, ValueError):
            raise GeometryError(f"{where}: expected (vertices, faces); got {type(blk).__name__}") from None
        try:
            v = np.asarray(v, float)
        except (TypeError, ValueError):
            raise GeometryError(f"{where}: vertices must be a list of [x, y, z] numbers") from None
        if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 4:
            raise GeometryError(f"{where}: vertices must have shape (k, 3) with k >= 4; got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise GeometryError(f"{where}: vertices contain NaN or infinite coordinates")
        fs = []
        for j, face in enumerate(f):
            try:
                a = np.asarray(face)
            except (TypeError, ValueError):
                raise GeometryError(f"{where}, face {j}: must be a list of vertex indices") from None
            if a.ndim != 1 or a.size < 3 or not np.issubdtype(a.dtype, np.integer):
                raise GeometryError(f"{where}, face {j}: must list at least 3 integer vertex indices; got {face!r}")
            if a.min() < 0 or a.max() >= v.shape[0]:
                raise GeometryError(f"{where}, face {j}: vertex index {int(a.max() if a.max() >= v.shape[0] else a.min())} "
                                    f"does not exist (the block has {v.shape[0]} vertices)")
            fs.append(a.astype(int))
        if len(fs) < 4:
            raise GeometryError(f"{where}: a closed polyhedron needs at least 4 faces; got {len(fs)}")
        verts.append(v)
        faces.append(tuple(fs))
    if not verts:
        raise StructureError("a structure needs at least one block; got none")
    return tuple(verts), tuple(faces)


def _check_closed(table: FaceTable, names) -> None:
    """Every directed edge once and its reverse once, in every block: closed, consistently oriented surfaces."""
    a, b = table.directed_edges()
    big = table.points.shape[0]
    key = a.astype(np.int64) * big + b
    unique, counts = np.unique(key, return_counts=True)
    twice = unique[counts > 1]
    if twice.size:
        i, j = divmod(int(twice[np.argmin(table.vertex_block[twice // big])]), big)
        blk = table.vertex_block[i]
        start = table.vertex_start[blk]
        raise GeometryError(f"block {names[blk]}: faces are not consistently oriented (edge {i - start}->{j - start} is "
                            "used twice in the same direction; every face must run counter-clockwise seen from outside)")
    lonely = ~np.isin(b.astype(np.int64) * big + a, unique)
    if lonely.any():
        k = np.flatnonzero(lonely)[np.argmin(table.vertex_block[a[lonely]])]
        blk = table.vertex_block[a[k]]
        start = table.vertex_start[blk]
        raise GeometryError(f"block {names[blk]}: its surface is not closed (the edge between vertices {a[k] - start} "
                            f"and {b[k] - start} belongs to one face only); a block must be a closed polyhedron")


def _first(bad: np.ndarray, block: np.ndarray) -> int:
    """The entry of ``bad`` (indices) of the lowest block."""
    return int(bad[np.argmin(block[bad])])


def _check_blocks(table: FaceTable, names, tol: float) -> np.ndarray:
    """Shape checks of every block, each in its own units (vectorised); returns which blocks are convex."""
    _, size = table.block_frames()
    p = table.local()
    face_start = np.concatenate([[0], np.cumsum(np.bincount(table.face_block, minlength=table.n_blocks))])
    ordered = np.sort(np.where(table.valid, table.index, -1 - np.arange(table.index.shape[1])[None, :]), axis=1)
    bad = np.flatnonzero((ordered[:, 1:] == ordered[:, :-1]).any(axis=1))
    if bad.size:
        f = _first(bad, table.face_block)
        blk = table.face_block[f]
        raise GeometryError(f"block {names[blk]}, face {f - face_start[blk]}: repeats a vertex "
                            f"({(table.index[f, : table.count[f]] - table.vertex_start[blk]).tolist()})")
    _check_closed(table, names)
    area = table.newell(p)
    area2 = np.linalg.norm(area, axis=1)
    bad = np.flatnonzero(area2 <= tol)
    if bad.size:
        f = _first(bad, table.face_block)
        raise GeometryError(f"block {names[table.face_block[f]]}, face {f - face_start[table.face_block[f]]}: "
                            "degenerate (zero area)")
    normal = area / area2[:, None]
    centre = table.centres(p)
    off = np.abs(np.einsum("fkd,fd->fk", p[table.index] - centre[:, None, :], normal)).max(axis=1)
    bad = np.flatnonzero(off > 10 * tol)
    if bad.size:
        f = _first(bad, table.face_block)
        blk = table.face_block[f]
        raise GeometryError(f"block {names[blk]}, face {f - face_start[blk]}: not planar (a vertex lies "
                            f"{off[f] * size[blk]:.3g} off its plane)")
    vol, _ = table.mass(p)
    bad = np.flatnonzero(np.abs(vol) <= tol)
    if bad.size:
        raise GeometryError(f"block {names[bad[0]]}: degenerate polyhedron (volume {vol[bad[0]] * size[bad[0]]**3:.3g})")
    bad = np.flatnonzero(vol < 0)
    if bad.size:
        raise GeometryError(f"block {names[bad[0]]}: its faces are oriented inward (clockwise seen from outside); "
                            "reverse each face")
    # convex: no vertex of a block in front of a face plane of the same block
    offset = np.einsum("fd,fd->f", normal, p[table.index[:, 0]])
    beyond = np.zeros(table.n_blocks)
    nv = np.diff(table.vertex_start)
    for j in range(int(nv.max())):  # vertex j of every block against every face of its block
        has = nv[table.face_block] > j
        v = table.vertex_start[table.face_block[has]] + j
        d = np.einsum("fd,fd->f", normal[has], p[v]) - offset[has]
        np.maximum.at(beyond, table.face_block[has], d)
    convex = beyond <= 10 * tol
    return convex


def _check_self_intersection(p: np.ndarray, faces, where: str, size: float) -> None:
    """Raise when an edge of the surface crosses the inside of a face it does not touch.

    For each face (vectorised over the edges): the point where an edge crosses the face's plane strictly
    between its ends, tested inside the face polygon in the plane (shapely)."""
    import shapely

    normals = face_normals(p, faces)
    edges = np.unique(np.sort(np.concatenate([np.column_stack([f, np.roll(f, -1)]) for f in faces]), axis=1), axis=0)
    p0, p1 = p[edges[:, 0]], p[edges[:, 1]]
    for j, f in enumerate(faces):
        n = normals[j]
        d0, d1 = (p0 - p[f[0]]) @ n, (p1 - p[f[0]]) @ n
        cross = ((d0 > 1e-9) & (d1 < -1e-9)) | ((d0 < -1e-9) & (d1 > 1e-9))
        cross &= ~np.isin(edges, f).any(axis=1)
        if not cross.any():
            continue
        t = d0[cross] / (d0[cross] - d1[cross])
        hit = p0[cross] + t[:, None] * (p1[cross] - p0[cross])
        e1 = p[f[1]] - p[f[0]]
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        poly = shapely.Polygon(np.column_stack([(p[f] - p[f[0]]) @ e1, (p[f] - p[f[0]]) @ e2]))
        rel = hit - p[f[0]]
        inside = shapely.contains_xy(poly, rel @ e1, rel @ e2)
        if inside.any():
            k = int(np.flatnonzero(cross)[np.argmax(inside)])
            raise GeometryError(f"{where}: its surface intersects itself (edge {edges[k, 0]}-{edges[k, 1]} crosses "
                                f"face {j}); a block must be a simple closed polyhedron")


# --------------------------------------------------------------------------- the structure


def make_structure_3d(
    blocks,
    fixed,
    *,
    friction: float,
    dilatancy: float = 0.0,
    density=1.0,
    live_direction=(1.0, 0.0, 0.0),
    live_factor: float = 1.0,
    pyramid_sides: int = 4,
    block_ids=None,
    name: str = "structure",
    metadata: dict | None = None,
    tol: float = DEFAULT_GEOMETRY_TOL,
) -> Structure3D:
    """Build and validate a 3D structure; its contacts are detected (:func:`detect_contacts`).

    Parameters
    ----------
    blocks : list of (vertices, faces)
        Each block's vertices (k, 3) and faces (lists of vertex indices, counter-clockwise from
        outside): closed polyhedra, convex or not (non-convex ones as closed triangle meshes).
    fixed : array_like of bool, shape (n_blocks,)
        Support blocks.
    friction, dilatancy : float
        ``tan(phi)`` and ``tan(psi)``.
    density : float or array_like
        Weight per unit volume, per block or for all.
    live_direction : 3-vector
        Direction of the live body force (normalised), default ``+x``.
    live_factor : float
        Live body force as a fraction of the weight.
    pyramid_sides : int
        Sides of the inscribed friction pyramid (default 4; see :mod:`blockmpec.three_d.operators`).
    block_ids : list of str, optional
        The user's name of each block (used in messages and results).
    tol : float
        Relative geometric tolerance (of each block's size).

    Raises
    ------
    GeometryError, StructureError
        One line naming the block (by its id), face or field: an open or inconsistently oriented
        surface, a self-intersecting block, overlapping blocks, a free block touching nothing, a
        structure without supports.
    """
    blocks = list(blocks)
    names = tuple(str(b) for b in (range(len(blocks)) if block_ids is None else block_ids))
    if len(names) != len(blocks):
        raise StructureError(f"block_ids: expected {len(blocks)} names (one per block); got {len(names)}")
    vertices, faces = _block_arrays(blocks, names)
    n = len(vertices)
    fixed_arr = np.asarray(fixed, dtype=bool).reshape(-1)
    if fixed_arr.shape[0] != n:
        raise StructureError(f"fixed: expected {n} flags (one per block); got {fixed_arr.shape[0]}")
    dens = np.broadcast_to(np.asarray(density, dtype=float), (n,)).copy()
    bad = np.flatnonzero(~np.isfinite(dens) | (dens <= 0))
    if bad.size:
        raise StructureError(f"block {names[bad[0]]}: density must be a finite number > 0; got {dens[bad[0]]}")
    _check_material(float(friction), float(dilatancy))
    table = FaceTable(vertices, faces)
    convex = _check_blocks(table, names, tol)
    for i in np.flatnonzero(~convex):  # a non-convex block: its surface must not cross itself
        v = vertices[i]
        size = float(np.max(v.max(axis=0) - v.min(axis=0)))
        _check_self_intersection((v - v[0]) / size, faces[i], f"block {names[i]}", size)
    check_overlaps(vertices, faces, convex, tol, names, table)
    contacts = detect_contacts(vertices, faces, tol, table)
    s = Structure3D(vertices=vertices, faces=faces, fixed=fixed_arr, density=dens, contacts=contacts,
                    friction=float(friction), dilatancy=float(dilatancy),
                    live_direction=_unit_direction(live_direction), live_factor=_live_factor(live_factor),
                    pyramid_sides=_pyramid_sides(pyramid_sides), block_ids=names, name=name,
                    metadata=dict(metadata or {}))
    _check_connectivity(s)
    return s


def _check_connectivity(s: Structure3D) -> None:
    c = s.contacts
    check_supported(s.fixed, c.minus, c.plus, list(s.block_ids), "contacts")
