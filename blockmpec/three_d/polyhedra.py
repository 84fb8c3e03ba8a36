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
