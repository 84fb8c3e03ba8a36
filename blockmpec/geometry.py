"""Rigid-block structures: blocks as simple polygons, interfaces, material and loads.

Conventions (stated once, used everywhere)
------------------------------------------
* A block is a simple polygon (convex or not, without self-intersections or holes)
  with its vertices in counter-clockwise order.  Its area and centroid are the
  shoelace sums, exact for any simple polygon.  Blocks marked ``fixed`` are supports
  (base, springings): they carry no unknowns.
* An interface ``k`` joins a *minus* block and a *plus* block along the segment
  ``start[k] -> end[k]`` of length ``L``.  Its unit tangent is
  ``tau = (end - start) / L`` and its unit normal ``nu`` is ``tau`` rotated by +90°;
  ``nu`` points from the minus block into the plus block.  Equivalently the shear
  direction ``tau`` is ``nu`` rotated by -90°.
* Interface forces ``(t, n, m)`` are the shear, normal and moment (about the
  segment midpoint) that the plus block exerts on the minus block:
  force ``t * tau + n * nu``.  Compression is ``n <= 0``.
* Material: friction coefficient ``mu = tan(phi)`` and dilatancy coefficient
  ``tan(psi)`` per structure, with optional per-interface overrides (NaN = use the
  structure's value).  ``0 <= tan(psi) <= tan(phi)`` is required.
* Loads act at block centroids.  Dead load: self-weight ``W = density * area``,
  downward.  Live load: horizontal body force ``live_direction * live_factor * W``
  (pseudo-static seismic action), plus optional point loads per block, each dead
  or live.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.sparse import coo_array

from blockmpec.errors import GeometryError, PrecisionWarning, StructureError
from blockmpec.units import Frame, block_extent, power_of_two

#: Default relative tolerance for geometric tests (scaled by block size).
DEFAULT_GEOMETRY_TOL = 1e-6

#: the friction coefficient ``tan(phi)`` of the built-in cases and of the drawing readers unless given (their
#: parameter ``mu``)
DEFAULT_FRICTION = 0.65


@dataclass(frozen=True)
class PointLoad:
    """A concentrated force applied to one block.

    Attributes
    ----------
    block : int
        Index of the loaded block.
    point : tuple[float, float]
        Point of application.
    force : tuple[float, float]
        Force vector ``(fx, fy)``.
    kind : {"dead", "live"}
        A dead load is added to ``f_d``; a live load to ``f_l`` (scaled by lambda).
    """

    block: int
    point: tuple[float, float]
    force: tuple[float, float]
    kind: Literal["dead", "live"] = "dead"


@dataclass(frozen=True, eq=False)
class Interfaces:
    """Contact segments between blocks, as arrays of length ``c``.

    Attributes
    ----------
    minus, plus : ndarray of int, shape (c,)
        Block indices; the normal points from ``minus`` into ``plus``.
    start, end : ndarray, shape (c, 2)
        Segment end points; ``nu = rot90(end - start) / L``.
    friction, dilatancy : ndarray, shape (c,)
        Per-interface ``tan(phi)`` and ``tan(psi)`` overrides; NaN means "use the
        structure's value".
    """

    minus: np.ndarray
    plus: np.ndarray
    start: np.ndarray
    end: np.ndarray
    friction: np.ndarray
    dilatancy: np.ndarray

    def __len__(self) -> int:
        return int(self.minus.shape[0])

    @classmethod
    def empty(cls) -> Interfaces:
        """An empty interface set."""
        z = np.zeros(0)
        return cls(np.zeros(0, int), np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2)), z, z)

    @property
    def length(self) -> np.ndarray:
        """Segment lengths ``L``, shape (c,)."""
        d = self.end - self.start
        return np.hypot(d[:, 0], d[:, 1])

    @property
    def midpoint(self) -> np.ndarray:
        """Segment midpoints, shape (c, 2)."""
        return 0.5 * (self.start + self.end)

    @property
    def tangent(self) -> np.ndarray:
        """Unit tangents ``tau``, shape (c, 2)."""
        return (self.end - self.start) / self.length[:, None]

    @property
    def normal(self) -> np.ndarray:
        """Unit normals ``nu`` (from minus into plus), shape (c, 2)."""
        tau = self.tangent
        return np.column_stack([-tau[:, 1], tau[:, 0]])


@dataclass(frozen=True, eq=False)
class Structure:
    """A validated 2D rigid-block structure.

    Build it with :func:`make_structure` (which validates and detects interfaces)
    or load it with :func:`blockmpec.structure_file.load_structure`.

    Attributes
    ----------
    vertices : ndarray, shape (n_blocks, k_max, 2)
        Block vertices, counter-clockwise; block ``i`` uses the first
        ``n_vertices[i]`` rows, the rest repeat its last vertex.
    n_vertices : ndarray of int, shape (n_blocks,)
    fixed : ndarray of bool, shape (n_blocks,)
    density : ndarray, shape (n_blocks,)
    interfaces : Interfaces
    friction : float
        Default ``mu = tan(phi)``.
    dilatancy : float
        Default ``tan(psi)``.
    live_direction : {+1, -1}
        Sign of the horizontal live load.
    live_factor : float
        Live body force as a fraction of the weight.
    point_loads : tuple of PointLoad
    name : str
    """

    vertices: np.ndarray
    n_vertices: np.ndarray
    fixed: np.ndarray
    density: np.ndarray
    interfaces: Interfaces
    friction: float
    dilatancy: float = 0.0
    live_direction: int = 1
    live_factor: float = 1.0
    point_loads: tuple[PointLoad, ...] = ()
    name: str = "structure"
    metadata: dict = field(default_factory=dict)

    @property
    def n_blocks(self) -> int:
        """Number of blocks, fixed ones included."""
        return int(self.n_vertices.shape[0])

    @property
    def n_free(self) -> int:
        """Number of free (non-fixed) blocks."""
        return int((~self.fixed).sum())

    def polygon(self, i: int) -> np.ndarray:
        """Vertices of block ``i``, shape (k, 2)."""
        return self.vertices[i, : self.n_vertices[i]]

    @property
    def area(self) -> np.ndarray:
        """Block areas, shape (n_blocks,)."""
        return polygon_areas(self.vertices)

    @property
    def centroid(self) -> np.ndarray:
        """Block centroids, shape (n_blocks, 2)."""
        return polygon_centroids(self.vertices)

    @property
    def weight(self) -> np.ndarray:
        """Block weights ``density * area``, shape (n_blocks,)."""
        return self.density * self.area

    def interface_friction(self) -> np.ndarray:
        """Effective ``tan(phi)`` per interface, shape (c,)."""
        f = self.interfaces.friction
        return np.where(np.isnan(f), self.friction, f)

    def interface_dilatancy(self) -> np.ndarray:
        """Effective ``tan(psi)`` per interface, shape (c,)."""
        d = self.interfaces.dilatancy
        return np.where(np.isnan(d), self.dilatancy, d)

    def with_material(self, friction: float | None = None, dilatancy: float | None = None) -> Structure:
        """A copy with other default material coefficients (overrides kept), validated."""
        from dataclasses import replace

        s = replace(
            self,
            friction=self.friction if friction is None else float(friction),
            dilatancy=self.dilatancy if dilatancy is None else float(dilatancy),
        )
        _check_material(s)
        return s


# --------------------------------------------------------------------------- polygons


def polygon_shape(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scale-free shoelace data of padded polygons (n, k, 2).

    Each polygon is taken relative to its first vertex and in units of ``s_i``, the power
    of two nearest its size (bounding-box diagonal): no product of two lengths is formed
    in the structure's units, so areas and centroids neither underflow (a 1e-108 block has
    an area of 1e-216, its shoelace products below 1e-300) nor overflow (lengths of 1e160),
    and relative coordinates avoid cancellation (a 1e-5 block at (0.5, 1) has products
    ``x y ~ 0.5`` cancelling down to an area ~1e-10).  Powers of two make the scaling exact.

    Returns
    -------
    scale : ndarray, shape (n,)
        ``s_i``.
    area : ndarray, shape (n,)
        Signed area in units of ``s_i**2`` (positive when counter-clockwise).
    centroid : ndarray, shape (n, 2)
        Centroid relative to the first vertex, in units of ``s_i`` (NaN for a zero area).
    """
    scale = power_of_two(block_extent(vertices))
    scale = np.atleast_1d(np.asarray(scale, float))
    p = (vertices - vertices[:, :1, :]) / scale[:, None, None]
    q = np.roll(p, -1, axis=1)
    cross = p[..., 0] * q[..., 1] - q[..., 0] * p[..., 1]
    a = 0.5 * cross.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = ((p[..., 0] + q[..., 0]) * cross).sum(axis=1) / (6 * a)
        cy = ((p[..., 1] + q[..., 1]) * cross).sum(axis=1) / (6 * a)
    return scale, a, np.column_stack([cx, cy])


def polygon_areas(vertices: np.ndarray) -> np.ndarray:
    """Signed areas (positive when counter-clockwise) of padded polygons (n, k, 2).

    In the structure's units (may over- or underflow at extreme sizes; the operators use
    :func:`polygon_shape`)."""
    scale, a, _ = polygon_shape(vertices)
    with np.errstate(over="ignore", under="ignore"):
        return a * scale * scale


def polygon_centroids(vertices: np.ndarray) -> np.ndarray:
    """Centroids of padded polygons (n, k, 2) -> (n, 2)."""
    scale, _, c = polygon_shape(vertices)
    return vertices[:, 0, :] + c * scale[:, None]


def pad_polygons(polygons: list) -> tuple[np.ndarray, np.ndarray]:
    """Pad a list of (k_i, 2) vertex arrays to (n, k_max, 2), repeating the last vertex.

    Raises
    ------
    GeometryError
        If a polygon is not an array of shape (k, 2) with k >= 3 and finite entries.
    """
    arrays = []
    for i, poly in enumerate(polygons):
        try:
            a = np.asarray(poly, dtype=float)
        except (TypeError, ValueError) as exc:
            raise GeometryError(f"block {i}: vertices must be a list of [x, y] pairs of numbers ({exc})") from None
        if a.ndim != 2 or a.shape[1] != 2 or a.shape[0] < 3:
            raise GeometryError(
                f"block {i}: vertices must have shape (k, 2) with k >= 3; got shape {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise GeometryError(f"block {i}: vertices contain NaN or infinite coordinates")
        arrays.append(a)
    if not arrays:
        raise StructureError("a structure needs at least one block; got none")
    n_vertices = np.array([a.shape[0] for a in arrays])
    k_max = int(n_vertices.max())
    out = np.empty((len(arrays), k_max, 2))
    for i, a in enumerate(arrays):
        out[i, : a.shape[0]] = a
        out[i, a.shape[0] :] = a[-1]
    return out, n_vertices


def _edges(vertices: np.ndarray, n_vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All real edges: (block index, start point, end point), arrays of length n_edges."""
    n, k_max, _ = vertices.shape
    i = np.arange(k_max)[None, :]
    valid = i < n_vertices[:, None]
    nxt = np.where(i + 1 < n_vertices[:, None], i + 1, 0)
    block = np.broadcast_to(np.arange(n)[:, None], (n, k_max))[valid]
    p = vertices[valid.nonzero()[0], i.repeat(n, 0)[valid]]
    q = vertices[valid.nonzero()[0], nxt[valid]]
    return block, p, q


def block_sizes(vertices: np.ndarray, n_vertices: np.ndarray) -> np.ndarray:
    """Characteristic size of each block: its bounding-box diagonal."""
    return block_extent(vertices)


# --------------------------------------------------------------------------- snapping


def snap_polygons(vertices: np.ndarray, n_vertices: np.ndarray, snap: float) -> tuple[list[np.ndarray], dict]:
    """Make nearly matching edges of different blocks match exactly.

    With ``d = snap * `` the median block size (bounding-box diagonal), vertices of different
    blocks closer than ``d`` are merged and a vertex closer than ``d`` to another block's edge is
    inserted into that edge (shapely's ``coverage_clean``, GEOS's coverage cleaner, with snapping
    distance ``d`` and no gap filling), so that edges within ``d`` of each other become the same
    segments and :func:`detect_interfaces` finds them whatever its tolerance.  Vertices that the
    cleaning only adds on a straight edge (where another block's corner touches it) are removed
    again, so a block keeps its own vertices except those that moved.

    Parameters
    ----------
    vertices, n_vertices : ndarray
        Padded polygons (n, k, 2), counter-clockwise and simple.
    snap : float
        The snapping distance relative to the median block size.

    Returns
    -------
    polygons : list of ndarray
        The snapped polygons, counter-clockwise, each starting at its first vertex where that
        did not move.
    record : dict
        ``{"snap": snap, "distance": d, "largest": the largest move, "vertices": [[block,
        x_before, y_before, x_after, y_after], ...]}``: every vertex of a snapped polygon that is
        not on its block's original outline, with where it was: the block's own vertex that moved
        there (one within ``d``), else the nearest point of the outline (a vertex of a neighbour
        inserted into an edge); and every vertex of the original polygon that is not on the new
        outline, with the new vertex it went to (one within ``d``), else its nearest point.

    Raises
    ------
    GeometryError
        When two blocks overlap by more than ``d`` (their penetration, the thickness of the
        overlap, named), or snapping splits or empties a block (``d`` too large for it).
    """
    import shapely

    n = vertices.shape[0]
    frame = Frame.of(vertices, exact=True)  # exact powers of two: unmoved vertices come back bit for bit
    local = frame(vertices)
    size = block_sizes(local, n_vertices)
    distance = snap * float(np.median(size))
    a, b = candidate_pairs(local, DEFAULT_GEOMETRY_TOL)
    thickness = overlap_thickness(local, n_vertices, a, b)
    bad = np.flatnonzero(thickness > distance)
    if bad.size:
        k = int(bad[np.lexsort((b[bad], a[bad]))[0]])
        raise GeometryError(
            f"blocks {int(a[k])} and {int(b[k])} overlap (penetration {thickness[k] * frame.length_scale:.3g}, "
            f"more than the snapping distance {distance * frame.length_scale:.3g})"
        )
    originals = [local[i, : n_vertices[i]] for i in range(n)]
    polygons = shapely_polygons(local, n_vertices)
    cleaned = shapely.coverage_clean(polygons, snapping_distance=distance)
    out, moved = [], []
    for i in range(n):
        g = cleaned[i]
        if g.geom_type != "Polygon" or g.is_empty or len(g.interiors):
            raise GeometryError(
                f"block {i}: snapping at distance {distance * frame.length_scale:.3g} splits it or leaves nothing "
                "of it; give a smaller snapping distance"
            )
        q = np.asarray(g.exterior.coords)[:-1]
        if not shapely.is_ccw(g.exterior):
            q = q[::-1]
        q = _drop_added_collinear(q, originals[i])
        first = np.flatnonzero((q == originals[i][0]).all(axis=1))
        if first.size:
            q = np.roll(q, -int(first[0]), axis=0)
        off = shapely.distance(shapely.points(q), polygons[i].exterior)
        for j in np.flatnonzero(off > 1e-12 * size[i]):
            gap = np.hypot(*(originals[i] - q[j]).T)
            if gap.min() <= distance:  # a vertex of the block that moved
                before = originals[i][int(np.argmin(gap))]
            else:  # a vertex of another block inserted into an edge of this one
                before = shapely.get_coordinates(shapely.shortest_line(polygons[i].exterior, shapely.Point(q[j])))[0]
            moved.append([i, *frame.back(before).tolist(), *frame.back(q[j]).tolist(),
                          float(np.hypot(*(q[j] - before)) * frame.length_scale)])
        # the block's own vertices that left its outline (moved along an edge of theirs, say)
        outline = shapely.Polygon(q).exterior
        lost = shapely.distance(shapely.points(originals[i]), outline)
        for j in np.flatnonzero(lost > 1e-12 * size[i]):
            gap = np.hypot(*(q - originals[i][j]).T)
            after = q[int(np.argmin(gap))] if gap.min() <= distance else shapely.get_coordinates(
                shapely.shortest_line(outline, shapely.Point(originals[i][j])))[0]
            entry = [i, *frame.back(originals[i][j]).tolist(), *frame.back(after).tolist(),
                     float(np.hypot(*(after - originals[i][j])) * frame.length_scale)]
            if entry[:5] not in [m[:5] for m in moved]:
                moved.append(entry)
        out.append(frame.back(q))
    record = {
        "snap": snap,
        "distance": distance * frame.length_scale,
        "largest": max((m[5] for m in moved), default=0.0),
        "vertices": [m[:5] for m in moved],
    }
    return out, record


def _drop_added_collinear(q: np.ndarray, original: np.ndarray) -> np.ndarray:
    """``q`` without the vertices that are not in ``original`` and lie on a straight edge (the nodes
    that coverage cleaning adds where another block's corner touches an edge)."""
    prev, nxt = np.roll(q, 1, axis=0), np.roll(q, -1, axis=0)
    e1, e2 = q - prev, nxt - q
    cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    dot = (e1 * e2).sum(axis=1)
    straight = (np.abs(cross) <= 1e-12 * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)) & (dot > 0)
    own = (q[:, None, :] == original[None, :, :]).all(axis=2).any(axis=1)
    keep = ~straight | own
    return q[keep] if keep.sum() >= 3 else q


# --------------------------------------------------------------------------- validation


#: Largest ratio of a free block's density to the median density of the free blocks.
DENSITY_RANGE = 1e100

#: Largest ratio of two block sizes in one structure (beyond it, areas span more than floating point).
SIZE_RANGE = 1e100


def _check_size_range(vertices: np.ndarray) -> None:
    """Raise when a block is more than ``SIZE_RANGE`` times smaller or larger than the median block."""
    size = block_extent(vertices)
    median = float(np.median(size))
    with np.errstate(divide="ignore", over="ignore"):
        ratio = size / median
    bad = np.flatnonzero(~((ratio > 1 / SIZE_RANGE) & (ratio < SIZE_RANGE)))
    if bad.size:
        i = int(bad[np.argmax(np.abs(np.log10(np.maximum(ratio[bad], 1e-320))))])
        raise GeometryError(
            f"block {i}: its size {size[i]:.3g} is {ratio[i]:.3g} times the median block size {median:.3g}; "
            f"block sizes in one structure must lie within a factor {SIZE_RANGE:.0e} of each other"
        )


def _check_polygons(vertices: np.ndarray, n_vertices: np.ndarray, tol: float) -> np.ndarray:
    """Shape checks of each block, each in its own units (relative to its first vertex, over its size).

    Returns
    -------
    ndarray of bool, shape (n,)
        ``True`` for a convex block (every turn to the left within ``tol``, total turn one
        revolution).  The others are checked to be simple polygons (no self-intersection) with
        shapely; the convex ones need no such check.
    """
    scale, area, _ = polygon_shape(vertices)
    original = vertices
    vertices = (vertices - vertices[:, :1, :]) / scale[:, None, None]
    size = block_sizes(vertices, n_vertices)
    bad = np.flatnonzero(~(np.abs(area) > tol * size**2))
    if bad.size:
        i = int(bad[0])
        with np.errstate(over="ignore", under="ignore"):
            physical = area[i] * scale[i] * scale[i]
        raise GeometryError(f"block {i}: polygon is degenerate (area {physical:.3g}); vertices {original[i, :n_vertices[i]].tolist()}")
    bad = np.flatnonzero(area < 0)
    if bad.size:
        i = int(bad[0])
        raise GeometryError(
            f"block {i}: vertices are in clockwise order; give them counter-clockwise "
            f"(reverse the list {original[i, :n_vertices[i]].tolist()})"
        )
    block, p, q = _edges(vertices, n_vertices)
    edge_len = np.hypot(*(q - p).T)
    short = np.flatnonzero(edge_len <= tol * size[block])
    if short.size:
        i = int(block[short[0]])
        raise GeometryError(f"block {i}: two consecutive vertices coincide (zero-length edge)")
    # convexity: the turn at every vertex is to the left (cross product >= 0)
    d = (q - p) / edge_len[:, None]
    starts = np.concatenate([[0], np.cumsum(n_vertices)[:-1]])
    nxt = np.arange(d.shape[0]) + 1
    last = starts + n_vertices - 1
    nxt[last] = starts
    turn = d[:, 0] * d[nxt, 1] - d[:, 1] * d[nxt, 0]
    convex = np.ones(vertices.shape[0], bool)
    convex[block[turn < -tol]] = False
    # a polygon turning left everywhere is convex only if it turns once: a star turns twice
    angle = np.arctan2(turn, d[:, 0] * d[nxt, 0] + d[:, 1] * d[nxt, 1])
    winding = np.add.reduceat(angle, starts) / (2 * np.pi)
    convex &= np.abs(winding - 1) < 1e-6
    if not convex.all():
        _check_simple(vertices, n_vertices, np.flatnonzero(~convex), original, scale)
    return convex


def shapely_polygons(vertices: np.ndarray, n_vertices: np.ndarray, blocks: np.ndarray | None = None) -> np.ndarray:
    """shapely Polygons of padded polygons (n, k, 2) (of ``blocks`` only, if given), as an object array."""
    import shapely

    blocks = np.arange(vertices.shape[0]) if blocks is None else np.asarray(blocks, int)
    if blocks.size == 0:
        return np.empty(0, object)
    counts = n_vertices[blocks]
    j = np.arange(vertices.shape[1])[None, :]
    valid = j < counts[:, None]
    coords = vertices[blocks][valid]
    rings = shapely.linearrings(coords, indices=np.repeat(np.arange(blocks.size), counts))
    return shapely.polygons(rings)


def _check_simple(vertices: np.ndarray, n_vertices: np.ndarray, blocks: np.ndarray, original: np.ndarray,
                  scale: np.ndarray) -> None:
    """Raise a GeometryError for the first of ``blocks`` that is not a simple polygon (shapely's validity).

    ``vertices`` are each block's own units (relative to its first vertex, over ``scale``); the
    message gives the point where its boundary crosses itself in the structure's coordinates."""
    import re

    import shapely

    polygons = shapely_polygons(vertices, n_vertices, blocks)
    valid = shapely.is_valid(polygons)
    if valid.all():
        return
    k = int(np.flatnonzero(~valid)[0])
    i = int(blocks[k])
    reason = shapely.is_valid_reason(polygons[k])
    found = re.search(r"\[\s*(\S+)\s+(\S+)\s*\]", reason)
    where = ""
    if found:
        point = original[i, 0] + scale[i] * np.array([float(found.group(1)), float(found.group(2))])
        where = f" at {[float(f'{v:.6g}') for v in point]}"
    raise GeometryError(f"block {i}: polygon is self-intersecting (its boundary crosses or touches itself{where}); "
                        "a block must be a simple polygon")


def _check_material(s: Structure) -> None:
    for name, value in (("friction", s.friction), ("dilatancy", s.dilatancy)):
        if not np.isfinite(value) or value < 0:
            raise StructureError(f"{name}: must be a finite number >= 0; got {value}")
    if s.dilatancy > s.friction:
        raise StructureError(
            f"dilatancy: tan(psi) = {s.dilatancy} exceeds the friction coefficient tan(phi) = {s.friction}; "
            "the dilatancy angle must not exceed the friction angle"
        )
    if len(s.interfaces):
        mu = s.interface_friction()
        tp = s.interface_dilatancy()
        bad = np.flatnonzero(~np.isfinite(mu) | (mu < 0))
        if bad.size:
            raise StructureError(f"interface {bad[0]}: friction must be a finite number >= 0; got {mu[bad[0]]}")
        bad = np.flatnonzero(~np.isfinite(tp) | (tp < 0))
        if bad.size:
            raise StructureError(f"interface {bad[0]}: dilatancy must be a finite number >= 0; got {tp[bad[0]]}")
        bad = np.flatnonzero(tp > mu)
        if bad.size:
            k = int(bad[0])
            raise StructureError(
                f"interface {k} (blocks {s.interfaces.minus[k]}-{s.interfaces.plus[k]}): dilatancy tan(psi) = {tp[k]} "
                f"exceeds friction tan(phi) = {mu[k]}"
            )


def candidate_pairs(vertices: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(a, b)``, ``a < b``, of blocks whose bounding boxes overlap or touch.

    Boxes are grown by ``tol`` times the smaller block's size.  Blocks are grouped
    in size classes (powers of two) so that a few large blocks (a long base) do not
    inflate the search radius of the many small ones; each pair of classes is
    searched with a k-d tree of box centres.
    """
    n = vertices.shape[0]
    if n < 2:
        return np.zeros(0, int), np.zeros(0, int)
    lo, hi = vertices.min(axis=1), vertices.max(axis=1)
    centre = 0.5 * (lo + hi)
    radius = 0.5 * np.linalg.norm(hi - lo, axis=1) * (1 + 2 * tol)
    cls = np.floor(np.log2(radius)).astype(int)
    classes = np.unique(cls)
    groups = [np.flatnonzero(cls == k) for k in classes]
    from scipy.spatial import cKDTree  # imported here: scipy.spatial costs a third of `blockmpec --help`

    trees = [cKDTree(centre[g]) for g in groups]
    found_a, found_b = [], []
    for x, (ga, ta) in enumerate(zip(groups, trees)):
        for gb, tb in zip(groups[x:], trees[x:]):
            r = radius[ga].max() + radius[gb].max()
            if gb is ga:
                p = ta.query_pairs(r, output_type="ndarray")
                found_a.append(ga[p[:, 0]])
                found_b.append(ga[p[:, 1]])
            else:
                m = ta.sparse_distance_matrix(tb, r, output_type="ndarray")
                found_a.append(ga[m["i"]])
                found_b.append(gb[m["j"]])
    a, b = np.concatenate(found_a), np.concatenate(found_b)
    a, b = np.minimum(a, b), np.maximum(a, b)
    size = 2 * radius
    pad = tol * np.minimum(size[a], size[b])[:, None]
    keep = np.all((lo[a] <= hi[b] + pad) & (lo[b] <= hi[a] + pad), axis=1)
    return a[keep], b[keep]


def _padded_edges(vertices: np.ndarray, n_vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge start points and edge vectors per block, shape (n, k_max, 2); padded edges are zero."""
    k_max = vertices.shape[1]
    i = np.arange(k_max)[None, :]
    nxt = np.where(i + 1 < n_vertices[:, None], i + 1, 0)
    q = np.take_along_axis(vertices, nxt[..., None], axis=1)
    e = np.where((i < n_vertices[:, None])[..., None], q - vertices, 0.0)
    return vertices, e


#: Budget of the pairwise edge arrays (pairs x k_max x k_max entries) of one chunk of the vectorised
#: overlap test and interface detection: chunks hold fewer pairs when blocks have many vertices.
_PAIR_EDGE_BUDGET = 3_200_000


def _chunk(pairs: int, k_max: int, entries_per_pair: int) -> int:
    """Pairs per chunk: ``pairs`` (the old fixed chunk) up to 8 vertices, fewer above (memory bound)."""
    return max(1, min(pairs, _PAIR_EDGE_BUDGET // max(1, entries_per_pair * k_max * k_max)))


def _check_overlaps(vertices: np.ndarray, n_vertices: np.ndarray, tol: float, pairs=None, unit: float = 1.0,
                    convex: np.ndarray | None = None) -> None:
    """Raise if two blocks overlap by more than ``tol`` times their size.

    Pairs of convex blocks by the separating axis test (the penetration depth); a pair with a
    non-convex block (``convex[i]`` False) by shapely's intersection, whose thickness
    ``2 area / perimeter`` (a sliver's width) stands for the depth.
    ``vertices`` in any frame; ``unit`` is its length in the structure's units (for the message)."""
    a, b = candidate_pairs(vertices, tol) if pairs is None else pairs
    if a.size == 0:
        return
    if convex is not None and not convex.all():
        both = convex[a] & convex[b]
        _check_overlaps_nonconvex(vertices, n_vertices, tol, a[~both], b[~both], unit)
        a, b = a[both], b[both]
        if a.size == 0:
            return
    size = block_sizes(vertices, n_vertices)
    slack = tol * np.minimum(size[a], size[b])
    _, e = _padded_edges(vertices, n_vertices)
    normals = np.stack([e[..., 1], -e[..., 0]], axis=-1)
    lengths = np.linalg.norm(normals, axis=-1, keepdims=True)
    normals = np.where(lengths > 0, normals / np.where(lengths > 0, lengths, 1), normals[:, :1] / lengths[:, :1])
    chunk = _chunk(20000, vertices.shape[1], 4)
    for start in range(0, a.size, chunk):
        sa, sb, sl = a[start : start + chunk], b[start : start + chunk], slack[start : start + chunk]
        axes = np.concatenate([normals[sa], normals[sb]], axis=1)  # (p, 2k, 2)
        proj_a = np.einsum("pkd,pjd->pkj", axes, vertices[sa])
        proj_b = np.einsum("pkd,pjd->pkj", axes, vertices[sb])
        gap = np.maximum(proj_b.min(-1) - proj_a.max(-1), proj_a.min(-1) - proj_b.max(-1))
        overlapping = np.flatnonzero(gap.max(axis=1) < -sl)
        if overlapping.size:
            i, j = int(sa[overlapping[0]]), int(sb[overlapping[0]])
            raise GeometryError(f"blocks {i} and {j} overlap (penetration {-gap[overlapping[0]].max() * unit:.3g})")


def overlap_thickness(vertices: np.ndarray, n_vertices: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Thickness ``2 area / perimeter`` of the overlap of blocks ``a[k]`` and ``b[k]`` (0 where they only
    touch), by shapely's intersection: the width of a sliver, half the side of a square overlap."""
    import shapely

    if a.size == 0:
        return np.zeros(0)
    used = np.union1d(a, b)
    polygons = np.empty(vertices.shape[0], object)
    polygons[used] = shapely_polygons(vertices, n_vertices, used)
    overlap = shapely.intersection(polygons[a], polygons[b])
    area = shapely.area(overlap)
    perimeter = shapely.length(shapely.boundary(overlap))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(area > 0, 2 * area / np.where(perimeter > 0, perimeter, 1), 0.0)


def _check_overlaps_nonconvex(vertices: np.ndarray, n_vertices: np.ndarray, tol: float, a: np.ndarray,
                              b: np.ndarray, unit: float) -> None:
    """The overlap test of :func:`_check_overlaps` for pairs with a non-convex block (shapely)."""
    if a.size == 0:
        return
    size = block_sizes(vertices, n_vertices)
    thickness = overlap_thickness(vertices, n_vertices, a, b)
    bad = np.flatnonzero(thickness > tol * np.minimum(size[a], size[b]))
    if bad.size:
        k = int(bad[np.lexsort((b[bad], a[bad]))[0]])
        raise GeometryError(f"blocks {int(a[k])} and {int(b[k])} overlap (penetration {thickness[k] * unit:.3g})")


def detect_interfaces(vertices: np.ndarray, n_vertices: np.ndarray, tol: float = DEFAULT_GEOMETRY_TOL) -> Interfaces:
    """Find contacts where edges of two blocks are collinear, opposite and overlap.

    Two edges match when their outward normals are opposite to within ``tol``,
    both ends of one lie within ``tol * size`` of the other's line, and they
    overlap over more than ``tol * size`` (``size`` = the smaller block's
    bounding-box diagonal, so that a tiny block on a huge one is still found).  The interface segment is the overlap; its minus block
    is the lower block index.  Vectorised over the candidate block pairs of
    :func:`candidate_pairs` and all their edge combinations.
    """
    a, b = candidate_pairs(vertices, tol)
    if a.size == 0:
        return Interfaces.empty()
    p_all, e_all = _padded_edges(vertices, n_vertices)
    size = block_sizes(vertices, n_vertices)
    found = []
    chunk = _chunk(50000, vertices.shape[1], 1)
    for start in range(0, a.size, chunk):
        ba, bb = a[start : start + chunk], b[start : start + chunk]
        pa, ea = p_all[ba][:, :, None, :], e_all[ba][:, :, None, :]   # (P, k, 1, 2)
        pb, eb = p_all[bb][:, None, :, :], e_all[bb][:, None, :, :]   # (P, 1, k, 2)
        la = np.linalg.norm(ea, axis=-1)
        lb = np.linalg.norm(eb, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            da = ea / la[..., None]
            db = eb / lb[..., None]
        oa = np.stack([da[..., 1], -da[..., 0]], axis=-1)
        ob = np.stack([db[..., 1], -db[..., 0]], axis=-1)
        scale = np.minimum(size[ba], size[bb])[:, None, None]
        ok = (la > 0) & (lb > 0)
        ok &= (oa * ob).sum(-1) < -(1 - tol)
        qb = pb + eb
        off_p = (oa * (pb - pa)).sum(-1)
        off_q = (oa * (qb - pa)).sum(-1)
        ok &= (np.abs(off_p) <= tol * scale) & (np.abs(off_q) <= tol * scale)
        s1 = (da * (pb - pa)).sum(-1)
        s2 = (da * (qb - pa)).sum(-1)
        lo = np.maximum(0.0, np.minimum(s1, s2))
        hi = np.minimum(la, np.maximum(s1, s2))
        ok &= hi - lo > tol * scale
        pair, ka, _ = np.nonzero(ok)
        d_ok = np.broadcast_to(da, ok.shape + (2,))[ok]
        found.append((ba[pair], bb[pair], p_all[ba[pair], ka], d_ok, lo[ok], hi[ok]))
    minus = np.concatenate([f[0] for f in found])
    plus = np.concatenate([f[1] for f in found])
    p0 = np.concatenate([f[2] for f in found])
    d = np.concatenate([f[3] for f in found])
    lo = np.concatenate([f[4] for f in found])
    hi = np.concatenate([f[5] for f in found])
    order = np.lexsort((plus, minus))
    minus, plus, p0, d, lo, hi = minus[order], plus[order], p0[order], d[order], lo[order], hi[order]
    # normal from minus into plus = outward normal of the minus edge = rot90(-d): start at hi, end at lo
    start_pt = p0 + hi[:, None] * d
    end_pt = p0 + lo[:, None] * d
    nan = np.full(minus.size, np.nan)
    return Interfaces(minus.astype(int), plus.astype(int), start_pt, end_pt, nan, nan.copy())


def _distance_to_boundary(points: np.ndarray, vertices: np.ndarray, n_vertices: np.ndarray) -> np.ndarray:
    """Distance from ``points[k]`` to the boundary of polygon ``k`` (padded arrays)."""
    p, e = _padded_edges(vertices, n_vertices)
    rel = points[:, None, :] - p
    ee = (e * e).sum(-1)
    t = np.clip(np.where(ee > 0, (rel * e).sum(-1) / np.where(ee > 0, ee, 1), 0.0), 0.0, 1.0)
    d = np.linalg.norm(rel - t[..., None] * e, axis=-1)
    return d.min(axis=1)


def _edge_direction_along(points: np.ndarray, vertices: np.ndarray, n_vertices: np.ndarray,
                          tangent: np.ndarray) -> np.ndarray:
    """``d . tangent[k]`` for ``d`` the unit direction of the edge of polygon ``k`` (padded arrays) nearest
    to ``points[k]``: negative where that edge runs against ``tangent``."""
    p, e = _padded_edges(vertices, n_vertices)
    rel = points[:, None, :] - p
    ee = (e * e).sum(-1)
    t = np.clip(np.where(ee > 0, (rel * e).sum(-1) / np.where(ee > 0, ee, 1), 0.0), 0.0, 1.0)
    d = np.where(ee > 0, np.linalg.norm(rel - t[..., None] * e, axis=-1), np.inf)
    nearest = np.argmin(d, axis=1)
    edge = e[np.arange(points.shape[0]), nearest]
    return (edge * tangent).sum(-1) / np.linalg.norm(edge, axis=-1)


def _check_interfaces(s: Structure, tol: float, frame: Frame | None = None, convex: np.ndarray | None = None) -> None:
    """Interface checks on ``s`` given in the coordinates of ``frame`` (messages in the structure's).

    The normal must point from the minus block into the plus block: for two convex blocks, towards
    the plus block's centroid; where a block is not convex (``convex`` False), the interface must lie
    on an edge of the minus block that runs against its tangent (the block on the normal's negative
    side) and on one of the plus block that runs along it."""
    back = (lambda p: p) if frame is None else frame.back
    unit = 1.0 if frame is None else frame.length_scale
    itf = s.interfaces
    c = len(itf)
    n = s.n_blocks
    for name in ("minus", "plus"):
        arr = getattr(itf, name)
        bad = np.flatnonzero((arr < 0) | (arr >= n))
        if bad.size:
            raise StructureError(f"interface {bad[0]}: {name} block {arr[bad[0]]} does not exist (there are {n} blocks)")
    bad = np.flatnonzero(itf.minus == itf.plus)
    if bad.size:
        raise StructureError(f"interface {bad[0]}: minus and plus block are the same block {itf.minus[bad[0]]}")
    if c:
        if not (np.all(np.isfinite(itf.start)) and np.all(np.isfinite(itf.end))):
            k = int(np.flatnonzero(~np.isfinite(np.c_[itf.start, itf.end]).all(axis=1))[0])
            raise GeometryError(f"interface {k}: end points contain NaN or infinite coordinates")
        size = block_sizes(s.vertices, s.n_vertices)
        scale = np.minimum(size[itf.minus], size[itf.plus])
        bad = np.flatnonzero(itf.length <= tol * scale)
        if bad.size:
            raise GeometryError(f"interface {bad[0]}: segment has zero length")
        for name, blocks in (("minus", itf.minus), ("plus", itf.plus)):
            for point_name, pts in (("start", itf.start), ("end", itf.end)):
                dist = _distance_to_boundary(pts, s.vertices[blocks], s.n_vertices[blocks])
                bad = np.flatnonzero(dist > 10 * tol * scale)
                if bad.size:
                    k = int(bad[0])
                    raise GeometryError(
                        f"interface {k}: {point_name} point {back(pts[k]).tolist()} is not on the boundary of its "
                        f"{name} block {blocks[k]} (distance {dist[k] * unit:.3g})"
                    )
        centroid = s.centroid
        side = np.einsum("kd,kd->k", centroid[itf.plus] - centroid[itf.minus], itf.normal)
        if convex is not None and not convex.all():
            local = np.flatnonzero(~(convex[itf.minus] & convex[itf.plus]))
            mid, tau = itf.midpoint[local], itf.tangent[local]
            minus_along = _edge_direction_along(mid, s.vertices[itf.minus[local]], s.n_vertices[itf.minus[local]], tau)
            plus_along = _edge_direction_along(mid, s.vertices[itf.plus[local]], s.n_vertices[itf.plus[local]], tau)
            side[local] = np.where((minus_along < 0) & (plus_along > 0), 1.0, -1.0)
        bad = np.flatnonzero(side <= 0)
        if bad.size:
            k = int(bad[0])
            raise GeometryError(
                f"interface {k}: its normal (end - start rotated by +90 degrees) points from block {itf.plus[k]} "
                f"into block {itf.minus[k]}, but it must point from the minus block {itf.minus[k]} into the plus "
                f"block {itf.plus[k]}; swap 'start' and 'end' (or 'minus' and 'plus')"
            )


def _check_connectivity(s: Structure) -> None:
    check_supported(s.fixed, s.interfaces.minus, s.interfaces.plus, list(range(s.n_blocks)), "interfaces")


def check_supported(fixed: np.ndarray, minus: np.ndarray, plus: np.ndarray, names: list, contacts: str) -> None:
    """Raise a StructureError unless some block is fixed and some free, every free block touches another and every
    block is connected to a fixed one through the contacts ``(minus, plus)`` (2D interfaces, 3D contact polygons);
    blocks are named by ``names``, the contacts by the word ``contacts``."""
    n = fixed.shape[0]
    if not fixed.any():
        raise StructureError("no block is fixed: mark at least one block (a base or springing) as fixed")
    if fixed.all():
        raise StructureError("every block is fixed: there is nothing that can collapse")
    touched = np.zeros(n, bool)
    touched[minus] = True
    touched[plus] = True
    lonely = np.flatnonzero(~touched & ~fixed)
    if lonely.size:
        raise StructureError(
            f"block {names[lonely[0]]} touches no other block (free blocks without {contacts}: "
            f"{[names[i] for i in lonely[:10]]}{_more(lonely.size, 10)}); move it into contact or remove it"
        )
    graph = coo_array((np.ones(len(minus)), (minus, plus)), shape=(n, n))
    from scipy.sparse.csgraph import connected_components  # imported here, as cKDTree above

    _, label = connected_components(graph, directed=False)
    supported = np.zeros(label.max() + 1, bool)
    supported[label[fixed]] = True
    floating = np.flatnonzero(~supported[label])
    if floating.size:
        raise StructureError(
            f"blocks {[names[i] for i in floating[:10]]}{_more(floating.size, 10)} are not connected to any fixed "
            f"block through {contacts}"
        )


def _more(total: int, shown: int) -> str:
    """What a message listing the first ``shown`` of ``total`` items adds: `` and 5 more (15 in all)``."""
    return f" and {total - shown} more ({total} in all)" if total > shown else ""


def _normalised(s: Structure) -> tuple[Structure, Frame]:
    """``s`` with vertices and interface points in its :class:`~blockmpec.units.Frame`, and the frame."""
    from dataclasses import replace

    frame = Frame.of(s.vertices, exact=True)
    itf = s.interfaces
    with np.errstate(over="ignore", invalid="ignore"):
        itf = Interfaces(itf.minus, itf.plus, frame(itf.start).reshape(-1, 2), frame(itf.end).reshape(-1, 2),
                         itf.friction, itf.dilatancy)
    return replace(s, vertices=frame(s.vertices), interfaces=itf), frame


def _check_point_loads(s: Structure, frame: Frame, tol: float, convex: np.ndarray | None = None) -> None:
    """Point loads: existing block, known kind, finite, and applied inside the block or on its boundary
    (within ``10 tol`` times the block's size, as interface end points; for a non-convex block, the
    distance to the polygon by shapely)."""
    size = block_sizes(s.vertices, s.n_vertices)
    for k, pl in enumerate(s.point_loads):
        if isinstance(pl.block, bool) or not isinstance(pl.block, (int, np.integer)) or not 0 <= pl.block < s.n_blocks:
            raise StructureError(f"point load {k}: block {pl.block} does not exist (there are {s.n_blocks} blocks)")
        if pl.kind not in ("dead", "live"):
            raise StructureError(f"point load {k}: kind must be 'dead' or 'live'; got {pl.kind!r}")
        try:
            point = np.asarray(pl.point, float).reshape(2)
            force = np.asarray(pl.force, float).reshape(2)
        except (TypeError, ValueError):
            raise StructureError(f"point load {k} on block {pl.block}: point and force must be pairs of numbers") from None
        if not (np.all(np.isfinite(point)) and np.all(np.isfinite(force))):
            raise StructureError(f"point load {k} on block {pl.block}: point and force must be finite")
        i = pl.block
        poly = s.vertices[i, : s.n_vertices[i]]
        edge = np.roll(poly, -1, axis=0) - poly
        edge_len = np.hypot(edge[:, 0], edge[:, 1])
        # outward offset of the point from each edge's line (CCW polygon: outward normal = edge rotated by -90)
        offset = (edge[:, 1] * (frame(point)[0] - poly[:, 0]) - edge[:, 0] * (frame(point)[1] - poly[:, 1])) / edge_len
        outside = offset.max()
        if convex is not None and not convex[i]:
            import shapely

            outside = shapely.distance(shapely.Polygon(poly), shapely.Point(frame(point)))
        if outside > 10 * tol * size[i]:
            raise StructureError(
                f"point load {k}: its point {point.tolist()} lies outside block {i} "
                f"(distance {outside * frame.length_scale:.3g} beyond its boundary)"
            )


#: Relative resolution of a block's coordinates above which a PrecisionWarning is issued.
COORDINATE_RESOLUTION_WARNING = 1e-9


def _warn_coarse_coordinates(s: Structure) -> None:
    """Warn when a block's coordinates are resolved coarser than 1e-9 of its size (far from the origin)."""
    size = block_sizes(s.vertices, s.n_vertices)
    reach = np.abs(s.vertices).max(axis=(1, 2))
    resolution = np.spacing(reach) / size
    bad = np.flatnonzero(resolution > COORDINATE_RESOLUTION_WARNING)
    if bad.size:
        import warnings

        i = int(bad[np.argmax(resolution[bad])])
        warnings.warn(
            f"block {i}: its coordinates (up to {reach[i]:.3g}) are resolved only to {np.spacing(reach[i]):.3g}, "
            f"{resolution[i]:.2g} of its size: digits of the geometry may already be lost in the input; "
            "give coordinates near the origin",
            PrecisionWarning, stacklevel=3,
        )


def validate(s: Structure, tol: float = DEFAULT_GEOMETRY_TOL, check_overlap: bool = True) -> Structure:
    """Check a structure; return it unchanged or raise a GeometryError/StructureError.

    Geometry is checked in the structure's :class:`~blockmpec.units.Frame` (lengths over a power
    of two near the median block size, about the centre of the structure), so that the checks
    mean the same at any magnitude and offset."""
    Frame.of(s.vertices)  # raises when the coordinates overflow
    _check_size_range(s.vertices)
    convex = _check_polygons(s.vertices, s.n_vertices, tol)
    bad = np.flatnonzero(~np.isfinite(s.density) | (s.density <= 0))
    if bad.size:
        raise StructureError(f"block {bad[0]}: density must be a finite number > 0; got {s.density[bad[0]]}")
    free_density = s.density[~s.fixed] if (~s.fixed).any() else s.density
    ratio = s.density / float(np.median(free_density))
    bad = np.flatnonzero(~((ratio > 1 / DENSITY_RANGE) & (ratio < DENSITY_RANGE)) & ~s.fixed)
    if bad.size:
        i = int(bad[0])
        raise StructureError(
            f"block {i}: density {s.density[i]:.3g} is {ratio[i]:.3g} times the median density; densities in one "
            f"structure must lie within a factor {DENSITY_RANGE:.0e} of each other"
        )
    unit, frame = _normalised(s)
    if check_overlap:
        _check_overlaps(unit.vertices, unit.n_vertices, 10 * tol, unit=frame.length_scale, convex=convex)
    _check_interfaces(unit, tol, frame, convex)
    _check_material(s)
    _check_connectivity(s)
    if s.live_direction not in (1, -1):
        raise StructureError(f"live_direction: must be +1 or -1; got {s.live_direction}")
    if not np.isfinite(s.live_factor) or s.live_factor < 0:
        raise StructureError(
            f"live_factor: must be a finite number >= 0; got {s.live_factor} "
            "(the sign of the live load is live_direction, +1 or -1)"
        )
    _check_point_loads(unit, frame, tol, convex)
    _warn_coarse_coordinates(s)
    live_point = any(pl.kind == "live" and not s.fixed[pl.block] and np.any(pl.force) for pl in s.point_loads)
    if s.live_factor == 0 and not live_point:
        raise StructureError(
            "zero live load: live_factor is 0 and no live point load acts on a free block, "
            "so the collapse multiplier is undefined"
        )
    return s


def make_structure(
    polygons: list,
    fixed: list | np.ndarray,
    *,
    friction: float,
    dilatancy: float = 0.0,
    density: float | list | np.ndarray = 1.0,
    interfaces: Interfaces | None = None,
    live_direction: int = 1,
    live_factor: float = 1.0,
    point_loads: tuple[PointLoad, ...] | list = (),
    name: str = "structure",
    metadata: dict | None = None,
    tol: float = DEFAULT_GEOMETRY_TOL,
    check_overlap: bool = True,
    snap: float = 0.0,
) -> Structure:
    """Build and validate a structure from polygons.

    Parameters
    ----------
    polygons : list of array_like, each shape (k, 2)
        Block vertices, counter-clockwise: simple polygons, convex or not.
    fixed : array_like of bool, shape (n_blocks,)
        Support blocks.
    friction, dilatancy : float
        Default ``tan(phi)`` and ``tan(psi)``.
    density : float or array_like
        Weight per unit area, per block or for all.
    interfaces : Interfaces, optional
        Explicit interfaces; detected automatically (:func:`detect_interfaces`) when omitted.
    tol : float
        Relative geometric tolerance.
    snap : float
        Relative snapping distance (0, the default: no snapping).  When positive, edges and
        vertices of different blocks closer than ``snap`` times the median block size are made
        to coincide (:func:`snap_polygons`) before the interfaces are detected, and
        ``metadata["snapping"]`` records every vertex that moved.

    Raises
    ------
    GeometryError, StructureError
        With the offending block, interface or field named.
    """
    vertices, n_vertices = pad_polygons(list(polygons))
    Frame.of(vertices)  # raises when the coordinates overflow
    _check_size_range(vertices)
    n = vertices.shape[0]
    fixed_arr = np.asarray(fixed, dtype=bool).reshape(-1)
    if fixed_arr.shape[0] != n:
        raise StructureError(f"fixed: expected {n} flags (one per block); got {fixed_arr.shape[0]}")
    dens = np.broadcast_to(np.asarray(density, dtype=float), (n,)).copy()
    _check_polygons(vertices, n_vertices, tol)
    metadata = dict(metadata or {})
    if not (isinstance(snap, (int, float, np.floating)) and np.isfinite(snap) and snap >= 0):
        raise GeometryError(f"snap: must be a finite number >= 0 (a fraction of the median block size); got {snap!r}")
    if snap > 0 and interfaces is not None:
        raise GeometryError("snap: snapping moves vertices, so it works with detected interfaces only; "
                            "give interfaces=None or snap=0")
    if snap > 0:
        snapped, record = snap_polygons(vertices, n_vertices, float(snap))
        vertices, n_vertices = pad_polygons(snapped)
        _check_polygons(vertices, n_vertices, tol)
        metadata["snapping"] = record
    if interfaces is None:
        frame = Frame.of(vertices, exact=True)
        found = detect_interfaces(frame(vertices), n_vertices, tol)
        interfaces = Interfaces(found.minus, found.plus, frame.back(found.start), frame.back(found.end),
                                found.friction, found.dilatancy)
    s = Structure(
        vertices=vertices,
        n_vertices=n_vertices,
        fixed=fixed_arr,
        density=dens,
        interfaces=interfaces,
        friction=float(friction),
        dilatancy=float(dilatancy),
        live_direction=int(live_direction),
        live_factor=float(live_factor),
        point_loads=tuple(point_loads),
        name=name,
        metadata=metadata,
    )
    return validate(s, tol, check_overlap)
