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
from blockmpec.three_d.polyhedra import _fan, face_normals


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


def _frame(vertices) -> tuple[np.ndarray, float]:
    allv = np.vstack(vertices)
    centre = 0.5 * (allv.min(axis=0) + allv.max(axis=0))
    size = np.array([np.linalg.norm(v.max(axis=0) - v.min(axis=0)) for v in vertices])
    return centre, float(np.median(size))


def _padded_vertices(vertices) -> np.ndarray:
    k = max(v.shape[0] for v in vertices)
    out = np.empty((len(vertices), k, 3))
    for i, v in enumerate(vertices):
        out[i, : v.shape[0]] = v
        out[i, v.shape[0]:] = v[-1]
    return out


class _FaceTable:
    """Every face of every block as flat arrays (in the local frame)."""

    def __init__(self, vertices, faces):
        self.block = np.concatenate([np.full(len(f), i) for i, f in enumerate(faces)])
        counts = np.array([len(face) for f in faces for face in f])
        self.count = counts
        k = int(counts.max())
        self.coords = np.empty((counts.size, k, 3))
        normals, row = [], 0
        for v, fs in zip(vertices, faces):
            normals.append(face_normals(v, fs))
            for face in fs:
                q = v[face]
                self.coords[row, : len(face)] = q
                self.coords[row, len(face):] = q[-1]
                row += 1
        self.normal = np.vstack(normals)
        self.centre = np.array([self.coords[i, : counts[i]].mean(axis=0) for i in range(counts.size)])
        n_blocks = len(faces)
        per = np.bincount(self.block, minlength=n_blocks)
        self.of_block = -np.ones((n_blocks, int(per.max())), int)
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


def detect_contacts(vertices, faces, tol: float = 1e-6) -> Contacts:
    """Contact polygons of blocks given by their vertices and faces (see the module docstring).

    The minus block of a contact is the lower block index; its normal is that block's outward face
    normal.  A contact polygon of area at most ``tol`` times the smaller block's size squared (faces
    that only touch along an edge or at a point) is no contact.
    """
    import shapely
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import connected_components

    centre, unit = _frame(vertices)
    local = [(v - centre) / unit for v in vertices]
    table = _FaceTable(local, faces)
    size = np.array([np.linalg.norm(v.max(axis=0) - v.min(axis=0)) for v in local])
    a, b = candidate_pairs(_padded_vertices(local), tol)
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
    minus, plus, normals, starts, points, areas = [], [], [], [0], [], []
    for g in range(group.size):
        sel = order[bounds[g]: bounds[g + 1]]
        poly = pieces[sel[0]] if sel.size == 1 else shapely.union_all(pieces[sel])
        area = shapely.area(poly)
        if not area > tol * scale[g] ** 2:
            continue
        poly = shapely.simplify(poly, 1e-9 * scale[g])
        uv = _outline_points(poly)
        if uv.shape[0] < 3:
            continue
        p3 = g_origin[g] + uv[:, :1] * e1[g] + uv[:, 1:] * e2[g]
        minus.append(table.block[fa[first[g]]])
        plus.append(table.block[fb[first[g]]])
        normals.append(g_normal[g])
        points.append(p3 * unit + centre)
        starts.append(starts[-1] + p3.shape[0])
        areas.append(area * unit**2)
    if not minus:
        return _empty()
    minus, plus = np.array(minus), np.array(plus)
    order = np.lexsort((plus, minus))
    pts = [points[i] for i in order]
    counts = np.array([p.shape[0] for p in pts])
    return Contacts(minus=minus[order], plus=plus[order], normal=np.array(normals)[order],
                    point_start=np.concatenate([[0], np.cumsum(counts)]), points=np.vstack(pts),
                    area=np.array(areas)[order])


def _outline_points(poly) -> np.ndarray:
    """The vertices of a contact polygon's outline (every part of a multi-polygon), shape (q, 2)."""
    import shapely

    parts = shapely.get_parts(poly)
    out = []
    for part in parts:
        if part.geom_type != "Polygon" or part.is_empty:
            continue
        out.append(np.asarray(part.exterior.coords)[:-1])
    return np.vstack(out) if out else np.zeros((0, 2))


def _empty() -> Contacts:
    z = np.zeros(0, int)
    return Contacts(z, z.copy(), np.zeros((0, 3)), np.zeros(1, int), np.zeros((0, 3)), np.zeros(0))


# --------------------------------------------------------------------------- overlaps


def _edge_directions(v: np.ndarray, faces) -> np.ndarray:
    e = np.concatenate([v[np.roll(f, -1)] - v[f] for f in faces])
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    e = np.where((e[:, [0]] < 0) | ((e[:, [0]] == 0) & (e[:, [1]] < 0)), -e, e)
    return np.unique(np.round(e, 9), axis=0)


def _padded(rows: list[np.ndarray]) -> np.ndarray:
    k = max(r.shape[0] for r in rows)
    out = np.empty((len(rows), k, 3))
    for i, r in enumerate(rows):
        out[i, : r.shape[0]] = r
        out[i, r.shape[0]:] = r[0]
    return out


def check_overlaps(vertices, faces, convex: np.ndarray, tol: float, names) -> None:
    """Raise a GeometryError naming two blocks that overlap by more than ``10 tol`` times the smaller's size.

    Two convex blocks by the separating axis test (face normals of both and the cross products of their
    edge directions: the penetration depth); a pair with a non-convex block by the winding number of each
    face's centre, moved inside its block by ``100 tol`` of its size, in the other block (a vertex-free
    overlap of two non-convex blocks can escape this test)."""
    centre, unit = _frame(vertices)
    local = [(v - centre) / unit for v in vertices]
    a, b = candidate_pairs(_padded_vertices(local), tol)
    if a.size == 0:
        return
    size = np.array([np.linalg.norm(v.max(axis=0) - v.min(axis=0)) for v in local])
    both = convex[a] & convex[b]
    _overlaps_convex(local, faces, a[both], b[both], size, tol, names, unit)
    _overlaps_nonconvex(local, faces, a[~both], b[~both], size, tol, names)


def _overlaps_convex(local, faces, a, b, size, tol, names, unit) -> None:
    if a.size == 0:
        return
    verts = _padded(local)
    normals = _padded([face_normals(v, f) for v, f in zip(local, faces)])
    edges = _padded([_edge_directions(v, f) for v, f in zip(local, faces)])
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
