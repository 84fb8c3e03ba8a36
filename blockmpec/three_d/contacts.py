"""Contact detection and overlap checks between 3D blocks (vectorised; shapely for the planar intersections).

Candidate block pairs come from a k-d tree of bounding boxes (:func:`blockmpec.geometry.candidate_pairs`, which
works in any dimension).  Of each candidate pair every face of one block is tested against every face of the
other at once (numpy, in chunks): opposite outward normals and coplanar within ``tol`` times the smaller block's
size.  Matching faces are linked into groups (connected components: the coplanar triangles of two meshes form one
group), each face pair is intersected in the group's plane by shapely (vectorised), and the pieces of a group are
merged: one contact polygon per group, whose vertices are the contact points.

Geometry is taken relative to the centre of the structure's bounding box and in units of the median block size,
so that tolerances mean the same at any magnitude and offset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockmpec.errors import GeometryError
from blockmpec.geometry import candidate_pairs
from blockmpec.three_d.polyhedra import FaceTable, _fan, face_normals


@dataclass(frozen=True, eq=False)
class Contacts:
    """Contact polygons between blocks.

    Attributes
    ----------
    minus, plus : ndarray of int, shape (c,)
        Block indices; ``normal`` points from ``minus`` into ``plus``.
    normal : ndarray, shape (c, 3)
        Unit normals.
    point_start : ndarray of int, shape (c + 1,)
        Contact ``k`` has the points ``points[point_start[k]:point_start[k + 1]]``.
    points : ndarray, shape (p, 3)
        The contact points: the vertices of each contact polygon, in order around it.
    area : ndarray, shape (c,)
        Contact polygon areas.
    """

    minus: np.ndarray
    plus: np.ndarray
    normal: np.ndarray
    point_start: np.ndarray
    points: np.ndarray
    area: np.ndarray

    def __len__(self) -> int:
        return int(self.minus.shape[0])

    @property
    def point_interface(self) -> np.ndarray:
        """Interface of each contact point, shape (p,)."""
        return np.repeat(np.arange(len(self)), np.diff(self.point_start))

    def polygon(self, k: int) -> np.ndarray:
        """The contact points of interface ``k``, shape (q, 3)."""
        return self.points[self.point_start[k]: self.point_start[k + 1]]



#: Budget of one chunk's face-pair arrays (pairs x faces x faces entries).
_FACE_PAIR_BUDGET = 4_000_000


def _frame(table: FaceTable) -> tuple[np.ndarray, float, np.ndarray]:
    """Centre of the structure's bounding box, the median block size (bounding-box diagonal) and each block's size
    in units of it."""
    p = table.points
    centre = 0.5 * (p.min(axis=0) + p.max(axis=0))
    lo = np.minimum.reduceat(p, table.vertex_start[:-1], axis=0)
    hi = np.maximum.reduceat(p, table.vertex_start[:-1], axis=0)
    size = np.linalg.norm(hi - lo, axis=1)
    unit = float(np.median(size))
    return centre, unit, size / unit


def _padded_vertices(table: FaceTable, points: np.ndarray) -> np.ndarray:
    """Every block's vertices ``(n, k, 3)``, padded by repeating its last."""
    nv = np.diff(table.vertex_start)
    j = np.arange(int(nv.max()))[None, :]
    return points[table.vertex_start[:-1, None] + np.minimum(j, nv[:, None] - 1)]


class _FaceTable:
    """Every face of every block in the local frame: block, vertex count, padded coordinates, unit normal,
    centre, and the faces of each block (``of_block``, padded with -1)."""

    def __init__(self, table: FaceTable, centre: np.ndarray, unit: float):
        points = (table.points - centre) / unit
        self.block = table.face_block
        self.count = table.count
        self.coords = points[table.index]
        self.normal = table.normals(points)
        self.centre = table.centres(points)
        per = np.bincount(self.block, minlength=table.n_blocks)
        self.of_block = -np.ones((table.n_blocks, int(per.max())), int)
        start = np.concatenate([[0], np.cumsum(per)[:-1]])
        j = np.arange(self.block.size) - start[self.block]
        self.of_block[self.block, j] = np.arange(self.block.size)


def _matching_faces(table: _FaceTable, a: np.ndarray, b: np.ndarray, size: np.ndarray,
                    tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Face pairs ``(fa, fb)`` of the block pairs ``(a, b)``: opposite normals and coplanar."""
    fmax = table.of_block.shape[1]
    chunk = max(1, _FACE_PAIR_BUDGET // (fmax * fmax))
    out_a, out_b = [], []
    for s in range(0, a.size, chunk):
        ba, bb = a[s: s + chunk], b[s: s + chunk]
        fa = table.of_block[ba][:, :, None]
        fb = table.of_block[bb][:, None, :]
        ok = (fa >= 0) & (fb >= 0)
        ia, ib = np.where(ok, fa, 0), np.where(ok, fb, 0)
        na, nb = table.normal[ia], table.normal[ib]
        ok &= np.einsum("pijk,pijk->pij", na, nb) < -(1 - tol)
        scale = np.minimum(size[ba], size[bb])[:, None, None]
        gap = np.einsum("pijk,pijk->pij", na, table.centre[ib] - table.centre[ia])
        ok &= np.abs(gap) <= tol * scale
        p, i, j = np.nonzero(ok)
        out_a.append(ia[p, i, j])
        out_b.append(ib[p, i, j])
    return np.concatenate(out_a), np.concatenate(out_b)


def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane of each unit normal (m, 3)."""
    helper = np.where(np.abs(normal[:, [0]]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    e1 = np.cross(normal, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(normal, e1)


def _polygons_2d(table: _FaceTable, faces: np.ndarray, origin, e1, e2):
    import shapely

    counts = table.count[faces]
    j = np.arange(table.coords.shape[1])[None, :]
    valid = j < counts[:, None]
    rel = table.coords[faces] - origin[:, None, :]
    uv = np.stack([np.einsum("fkd,fd->fk", rel, e1), np.einsum("fkd,fd->fk", rel, e2)], axis=-1)
    rings = shapely.linearrings(uv[valid], indices=np.repeat(np.arange(faces.size), counts))
    return shapely.make_valid(shapely.polygons(rings))


def detect_contacts(vertices, faces, tol: float = 1e-6, table: FaceTable | None = None) -> Contacts:
    """Contact polygons of blocks given by their vertices and faces (see the module docstring).

    The minus block of a contact is the lower block index; its normal is that block's outward face
    normal.  A contact polygon of area at most ``tol`` times the smaller block's size squared (faces
    that only touch along an edge or at a point) is no contact.
    """
    import shapely
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import connected_components

    table = FaceTable(vertices, faces) if table is None else table
    centre, unit, size = _frame(table)
    local = (table.points - centre) / unit
    faces_local = _FaceTable(table, centre, unit)
    a, b = candidate_pairs(_padded_vertices(table, local), tol)
    table = faces_local
    fa, fb = _matching_faces(table, a, b, size, tol) if a.size else (np.zeros(0, int), np.zeros(0, int))
    if fa.size == 0:
        return _empty()
    # groups: coplanar faces of one block pair linked through their matches (nodes are (pair, face))
    n_faces = table.block.size
    pair_key = table.block[fa] * len(vertices) + table.block[fb]
    nodes, node = np.unique(np.concatenate([pair_key * n_faces + fa, pair_key * n_faces + fb]), return_inverse=True)
    graph = coo_array((np.ones(fa.size), (node[: fa.size], node[fa.size:])), shape=(nodes.size, nodes.size))
    _, label = connected_components(graph, directed=False)
    group, first = np.unique(label[node[: fa.size]], return_index=True)
    g_of_match = np.searchsorted(group, label[node[: fa.size]])
    g_face = fa[first]  # the representative face (of the lower block) of each group
    g_normal = table.normal[g_face]
    g_origin = table.centre[g_face]
    e1, e2 = _plane_basis(g_normal)
    m = g_of_match
    pa = _polygons_2d(table, fa, g_origin[m], e1[m], e2[m])
    pb = _polygons_2d(table, fb, g_origin[m], e1[m], e2[m])
    pieces = shapely.intersection(pa, pb)
    order = np.argsort(g_of_match, kind="stable")
    bounds = np.searchsorted(g_of_match[order], np.arange(group.size + 1))
    scale = np.minimum(size[table.block[fa[first]]], size[table.block[fb[first]]])
    # one polygon per group: a single piece as it is, several merged (shapely, group by group)
    counts = np.diff(bounds)
    poly = pieces[order[bounds[:-1]]].copy()
    for g in np.flatnonzero(counts > 1):
        poly[g] = shapely.union_all(pieces[order[bounds[g]: bounds[g + 1]]])
    area = shapely.area(poly)
    keep = np.flatnonzero(area > tol * scale**2)
    poly = shapely.simplify(poly[keep], 1e-9 * scale[keep])
    parts, part_of = shapely.get_parts(poly, return_index=True)
    polygons = shapely.get_type_id(parts) == 3  # a contact of two faces is polygons; lines and points are no area
    rings = shapely.get_exterior_ring(parts[polygons])
    uv, ring_of = shapely.get_coordinates(rings, return_index=True)
    last = np.r_[ring_of[1:] != ring_of[:-1], True]  # each ring repeats its first point at its end
    uv, ring_of = uv[~last], ring_of[~last]
    g_of_point = keep[part_of[polygons][ring_of]]
    n_points = np.bincount(g_of_point, minlength=group.size)
    good = np.flatnonzero(n_points >= 3)
    sel = np.isin(g_of_point, good)
    uv, g_of_point = uv[sel], g_of_point[sel]
    p3 = g_origin[g_of_point] + uv[:, :1] * e1[g_of_point] + uv[:, 1:] * e2[g_of_point]
    minus, plus = table.block[fa[first[good]]], table.block[fb[first[good]]]
    rank = np.lexsort((plus, minus))
    groups = good[rank]
    new_id = np.empty(group.size, int)
    new_id[groups] = np.arange(groups.size)
    point_order = np.argsort(new_id[g_of_point], kind="stable")
    counts = n_points[groups]
    return Contacts(minus=minus[rank], plus=plus[rank], normal=g_normal[groups],
                    point_start=np.concatenate([[0], np.cumsum(counts)]),
                    points=p3[point_order] * unit + centre, area=area[groups] * unit**2)


def _empty() -> Contacts:
    z = np.zeros(0, int)
    return Contacts(z, z.copy(), np.zeros((0, 3)), np.zeros(1, int), np.zeros((0, 3)), np.zeros(0))


# --------------------------------------------------------------------------- overlaps


def _per_block(rows: np.ndarray, block: np.ndarray, n: int) -> np.ndarray:
    """Rows ``(m, 3)`` grouped by ``block`` (sorted) into ``(n, k, 3)``, each group padded by repeating its first."""
    order = np.argsort(block, kind="stable")
    rows, block = rows[order], block[order]
    per = np.bincount(block, minlength=n)
    start = np.concatenate([[0], np.cumsum(per)[:-1]])
    j = np.arange(int(per.max()))[None, :]
    return rows[start[:, None] + np.where(j < per[:, None], j, 0)]


def _edge_directions(table: FaceTable, points: np.ndarray) -> np.ndarray:
    """Each block's distinct edge directions (sign-canonical unit vectors), padded: ``(n, k, 3)``."""
    a, b = table.directed_edges()
    e = points[b] - points[a]
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    e = np.where((e[:, [0]] < 0) | ((e[:, [0]] == 0) & (e[:, [1]] < 0)), -e, e)
    key = np.column_stack([table.vertex_block[a], np.round(e, 9)])
    key = np.unique(key, axis=0)
    return _per_block(key[:, 1:], key[:, 0].astype(int), table.n_blocks)


def check_overlaps(vertices, faces, convex: np.ndarray, tol: float, names, table: FaceTable | None = None) -> None:
    """Raise a GeometryError naming two blocks that overlap by more than ``10 tol`` times the smaller's size.

    Two convex blocks by the separating axis test (face normals of both and the cross products of their
    edge directions: the penetration depth); a pair with a non-convex block by the winding number of each
    face's centre, moved inside its block by ``100 tol`` of its size, in the other block (a vertex-free
    overlap of two non-convex blocks can escape this test)."""
    table = FaceTable(vertices, faces) if table is None else table
    centre, unit, size = _frame(table)
    points = (table.points - centre) / unit
    a, b = candidate_pairs(_padded_vertices(table, points), tol)
    if a.size == 0:
        return
    both = convex[a] & convex[b]
    _overlaps_convex(table, points, a[both], b[both], size, tol, names, unit)
    local = [points[table.vertex_start[i]: table.vertex_start[i + 1]] for i in range(table.n_blocks)]
    _overlaps_nonconvex(local, faces, a[~both], b[~both], size, tol, names)


def _overlaps_convex(table: FaceTable, points, a, b, size, tol, names, unit) -> None:
    if a.size == 0:
        return
    verts = _padded_vertices(table, points)
    normals = _per_block(table.normals(points), table.face_block, table.n_blocks)
    edges = _edge_directions(table, points)
    chunk = max(1, 2_000_000 // (edges.shape[1] ** 2 * verts.shape[1] + 1))
    for s in range(0, a.size, chunk):
        sa, sb = a[s: s + chunk], b[s: s + chunk]
        cross = np.cross(edges[sa][:, :, None, :], edges[sb][:, None, :, :]).reshape(sa.size, -1, 3)
        length = np.linalg.norm(cross, axis=-1, keepdims=True)
        cross = np.where(length > 1e-9, cross / np.maximum(length, 1e-300), normals[sa][:, :1, :])
        axes = np.concatenate([normals[sa], normals[sb], cross], axis=1)
        pa = np.einsum("pad,pkd->pak", axes, verts[sa])
        pb = np.einsum("pad,pkd->pak", axes, verts[sb])
        depth = np.minimum(pa.max(-1) - pb.min(-1), pb.max(-1) - pa.min(-1)).min(axis=1)
        slack = 10 * tol * np.minimum(size[sa], size[sb])
        bad = np.flatnonzero(depth > slack)
        if bad.size:
            k = bad[0]
            raise GeometryError(f"blocks {names[sa[k]]} and {names[sb[k]]} overlap (penetration "
                                f"{depth[k] * unit:.3g})")


def winding_number(points: np.ndarray, vertices: np.ndarray, faces) -> np.ndarray:
    """Generalised winding number of ``points`` (m, 3) in a closed outward polyhedron: 1 inside, 0 outside."""
    a, b, c = _fan(vertices, faces)
    ra, rb, rc = (x[None, :, :] - points[:, None, :] for x in (a, b, c))
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (ra, rb, rc))
    det = np.einsum("mtk,mtk->mt", ra, np.cross(rb, rc))
    den = (la * lb * lc + np.einsum("mtk,mtk->mt", ra, rb) * lc + np.einsum("mtk,mtk->mt", ra, rc) * lb
           + np.einsum("mtk,mtk->mt", rb, rc) * la)
    return (2 * np.arctan2(det, den)).sum(axis=1) / (4 * np.pi)


def _overlaps_nonconvex(local, faces, a, b, size, tol, names) -> None:
    for i, j in zip(a.tolist(), b.tolist()):
        for p, q in ((i, j), (j, i)):
            normals = face_normals(local[p], faces[p])
            centres = np.array([local[p][f].mean(axis=0) for f in faces[p]])
            inside = centres - 100 * tol * size[p] * normals
            w = winding_number(inside, local[q], faces[q])
            if np.any(w > 0.5):
                raise GeometryError(f"blocks {names[i]} and {names[j]} overlap (a part of block {names[p]} lies "
                                    f"inside block {names[q]})")
