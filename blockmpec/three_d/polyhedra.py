"""Polyhedra: exact volume and centroid, face normals, and builders of simple blocks (boxes, prisms, hulls).

A polyhedron is given by its vertices ``(k, 3)`` and faces (lists of vertex indices, counter-clockwise seen from
outside).
"""

from __future__ import annotations

import numpy as np


def polyhedron_mass(vertices: np.ndarray, faces) -> tuple[float, np.ndarray]:
    """Volume and centroid of a closed polyhedron with outward (counter-clockwise) faces.

    Each face is fanned from its first vertex into triangles ``(a, b, c)``; with the vertices taken
    relative to the polyhedron's first vertex ``o`` and in units of its size ``s``, the signed
    volume is ``sum a.(b x c) / 6`` and the centroid ``o + s sum V_t (a + b + c) / 4 / V``: exact
    for any closed polyhedron (a fan of a planar simple polygon is a chain equal to it).
    """
    v = np.asarray(vertices, float)
    o = v[0]
    s = float(np.max(v.max(axis=0) - v.min(axis=0)))
    s = s if s > 0 else 1.0
    p = (v - o) / s
    a, b, c = _fan(p, faces)
    vol_t = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    vol = float(vol_t.sum())
    with np.errstate(invalid="ignore", divide="ignore"):
        cen = (vol_t[:, None] * (a + b + c)).sum(axis=0) / (4.0 * vol)
    return vol * s**3, o + cen * s


def _fan(p: np.ndarray, faces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fan triangles ``(a, b, c)`` of every face, each shape (t, 3)."""
    idx = [(f[0], f[j], f[j + 1]) for f in faces for j in range(1, len(f) - 1)]
    t = np.asarray(idx, int).reshape(-1, 3)
    return p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]


def face_normals(vertices: np.ndarray, faces) -> np.ndarray:
    """Unit outward normals of the faces (Newell's method), shape (f, 3)."""
    v = np.asarray(vertices, float)
    out = np.empty((len(faces), 3))
    for i, f in enumerate(faces):
        q = v[np.asarray(f)]
        q = q - q.mean(axis=0)
        n = np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0)
        out[i] = n / max(np.linalg.norm(n), 1e-300)
    return out


def box(lo, hi) -> tuple[np.ndarray, list[list[int]]]:
    """An axis-aligned box from corner ``lo`` to ``hi``: vertices and outward faces."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], float)
    f = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [3, 0, 4, 7]]
    return v, f


def prism(bottom: np.ndarray, top: np.ndarray) -> tuple[np.ndarray, list[list[int]]]:
    """A block between two polygons with corresponding vertices ``bottom`` and ``top`` (k, 3);
    ``bottom`` counter-clockwise seen from the ``top`` side (so its face turns away from ``top``).

    The side faces are quadrilaterals ``bottom[j], bottom[j+1], top[j+1], top[j]``; each must be
    planar (a frustum, an extrusion)."""
    b, t = np.asarray(bottom, float), np.asarray(top, float)
    k = b.shape[0]
    v = np.vstack([b, t])
    faces = [list(range(k - 1, -1, -1)), list(range(k, 2 * k))]
    faces += [[j, (j + 1) % k, k + (j + 1) % k, k + j] for j in range(k)]
    return v, faces


def convex_block(points: np.ndarray) -> tuple[np.ndarray, list[list[int]]]:
    """The convex hull of ``points`` as a block (scipy's Qhull; coplanar triangles merged into faces)."""
    from scipy.spatial import ConvexHull

    pts = np.asarray(points, float)
    hull = ConvexHull(pts)
    used = np.unique(hull.simplices)
    remap = -np.ones(pts.shape[0], int)
    remap[used] = np.arange(used.size)
    v = pts[used]
    eq = hull.equations
    faces = []
    seen = np.zeros(len(eq), bool)
    for i in range(len(eq)):
        if seen[i]:
            continue
        same = np.flatnonzero(np.all(np.abs(eq - eq[i]) < 1e-10, axis=1))
        seen[same] = True
        corner = np.unique(hull.simplices[same])
        n = eq[i, :3]
        q = pts[corner]
        c = q.mean(axis=0)
        e1 = q[0] - c
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        ang = np.arctan2((q - c) @ e2, (q - c) @ e1)
        faces.append(remap[corner[np.argsort(ang)]].tolist())
    return v, faces


class FaceTable:
    """Every face of every block as flat, padded arrays, for vectorised checks and sums over a whole structure.

    Attributes
    ----------
    points : ndarray, shape (v, 3)
        All vertices, block after block; ``vertex_start[i]:vertex_start[i + 1]`` are block ``i``'s.
    vertex_block : ndarray of int, shape (v,)
    face_block, count : ndarray of int, shape (f,)
        Block and number of vertices of each face.
    index : ndarray of int, shape (f, k)
        Each face's vertices (rows of ``points``), padded by repeating its last vertex.
    """

    def __init__(self, vertices, faces):
        n = len(vertices)
        nv = np.array([len(v) for v in vertices])
        self.vertex_start = np.concatenate([[0], np.cumsum(nv)])
        self.points = np.vstack([np.asarray(v, float) for v in vertices])
        self.vertex_block = np.repeat(np.arange(n), nv)
        self.face_block = np.repeat(np.arange(n), [len(f) for f in faces])
        flat = [np.asarray(face, int) for fs in faces for face in fs]
        self.count = np.array([f.size for f in flat])
        idx = np.concatenate(flat) + np.repeat(self.vertex_start[self.face_block], self.count)
        starts = np.concatenate([[0], np.cumsum(self.count)[:-1]])
        j = np.arange(int(self.count.max()))[None, :]
        self.index = idx[starts[:, None] + np.minimum(j, self.count[:, None] - 1)]
        self.n_blocks = n

    @property
    def valid(self) -> np.ndarray:
        """``(f, k)``: the real (not padded) vertex positions of each face."""
        return np.arange(self.index.shape[1])[None, :] < self.count[:, None]

    def block_frames(self, points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Each block's first vertex ``(n, 3)`` and size ``(n,)`` (largest side of its bounding box)."""
        p = self.points if points is None else points
        lo = np.minimum.reduceat(p, self.vertex_start[:-1], axis=0)
        hi = np.maximum.reduceat(p, self.vertex_start[:-1], axis=0)
        size = (hi - lo).max(axis=1)
        return p[self.vertex_start[:-1]], np.where(size > 0, size, 1.0)

    def local(self, points: np.ndarray | None = None) -> np.ndarray:
        """Every vertex relative to its block's first vertex, in units of the block's size."""
        p = self.points if points is None else points
        origin, size = self.block_frames(p)
        return (p - origin[self.vertex_block]) / size[self.vertex_block, None]

    def newell(self, points: np.ndarray) -> np.ndarray:
        """Newell's area vector of each face (twice its vector area), shape (f, 3)."""
        q = points[self.index]
        q = q - q[:, :1, :]
        return np.cross(q, np.roll(q, -1, axis=1)).sum(axis=1)

    def centres(self, points: np.ndarray) -> np.ndarray:
        """Mean of each face's vertices, shape (f, 3)."""
        return (points[self.index] * self.valid[..., None]).sum(axis=1) / self.count[:, None]

    def normals(self, points: np.ndarray | None = None) -> np.ndarray:
        """Unit outward normals of the faces, shape (f, 3)."""
        a = self.newell(self.points if points is None else points)
        return a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300)

    def directed_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Every face's edges ``(a, b)`` as rows of ``points``, each shape (e,)."""
        nxt = np.where(np.arange(self.index.shape[1])[None, :] + 1 < self.count[:, None],
                       np.roll(self.index, -1, axis=1), self.index[:, :1])
        valid = self.valid
        return self.index[valid], nxt[valid]

    def mass(self, points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Volume ``(n,)`` and centroid ``(n, 3)`` of every block (the fan sums of :func:`polyhedron_mass`)."""
        p = self.points if points is None else points
        origin, size = self.block_frames(p)
        q = self.local(p)[self.index]
        a = q[:, :1, :]
        b, c = q[:, 1:-1, :], q[:, 2:, :]
        if b.shape[1] == 0:
            raise ValueError("faces need at least three vertices")
        vol_t = np.einsum("ftk,ftk->ft", np.broadcast_to(a, b.shape), np.cross(b, c)) / 6.0
        vol_t = np.where(np.arange(b.shape[1])[None, :] + 2 < self.count[:, None], vol_t, 0.0)
        weighted = (vol_t[..., None] * (a + b + c)).sum(axis=1) / 4.0
        vol = np.bincount(self.face_block, vol_t.sum(axis=1), self.n_blocks)
        cen = np.column_stack([np.bincount(self.face_block, weighted[:, k], self.n_blocks) for k in range(3)])
        with np.errstate(invalid="ignore", divide="ignore"):
            cen = cen / vol[:, None]
        return vol * size**3, origin + cen * size[:, None]

    def canonical(self, points: np.ndarray) -> FaceTable:
        """This table over ``points`` (one row per vertex) with every block's vertices sorted by position (height,
        ``x``, ``y``), each face started at its first vertex in that order and the faces of a block sorted: the fan
        sums of :meth:`mass` then do not depend on the order in which the input lists vertices and faces (the same
        bits for the same points)."""
        order = np.lexsort((points[:, 1], points[:, 0], points[:, 2], self.vertex_block))
        new = np.empty(order.size, int)
        new[order] = np.arange(order.size)
        idx = new[self.index]
        k = idx.shape[1]
        valid = self.valid
        first = np.argmin(np.where(valid, idx, np.iinfo(idx.dtype).max), axis=1)
        j = np.arange(k)[None, :]
        pos = np.where(valid, (first[:, None] + j) % self.count[:, None], 0)
        idx = np.take_along_axis(idx, pos, axis=1)
        idx = np.where(valid, idx, np.take_along_axis(idx, (self.count - 1)[:, None], axis=1))
        face_order = np.lexsort(tuple(idx[:, c] for c in range(k - 1, -1, -1)) + (self.face_block,))
        out = object.__new__(FaceTable)
        out.vertex_start, out.vertex_block, out.n_blocks = self.vertex_start, self.vertex_block, self.n_blocks
        out.points = points[order]
        out.face_block, out.count, out.index = self.face_block[face_order], self.count[face_order], idx[face_order]
        return out
