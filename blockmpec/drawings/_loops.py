"""Stones drawn as several entities: lines, arcs and open polylines joined where they close loops.

A drawing may draw a stone with several entities: the LINEs and ARCs of an exploded polyline, four
LINEs drawn one after the other, ``<line>`` elements of an SVG exported from CAD.  Each stone is
taken to be drawn with its own segments (two stones that share a joint each draw it once).

The segments' ends closer than the joining tolerance are merged, the segments are noded (shapely's
unary union: overlapping pieces merged, crossings split) and the bounded faces of the arrangement
found (shapely's ``polygonize``).  Each *piece* of the arrangement is covered by ``m`` segments
(``m = 2`` along a joint drawn once for each of its two stones) and borders one or two faces.  A face
is a stone or a space (a void enclosed by stones): a face beside the outside is a stone, and across a
piece drawn once from a stone lies a space, across one drawn twice (or more: a line drawn over
again, one drawn past its corner) a stone.  A piece beside more stones than it is drawn (a joint drawn
once for two stones, a line cutting across a stone) is refused with one line naming its segments.
Faces thinner than the joining tolerance (slivers between two outlines that nearly coincide) are
spaces.  An end that meets no other end is moved onto a segment closer than the tolerance (a line
drawn short of another).

Segments on no stone's outline are left over: lines are skipped (and counted by the reader), an open
polyline is an error (usually a stone whose closing was forgotten).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockmpec.drawings._common import Stone
from blockmpec.errors import StructureFileError


@dataclass
class Segment:
    """An open piece of outline in the file's coordinates (its ends are where it may join others)."""

    points: np.ndarray  # (k, 2), k >= 2
    label: str  # the entity, e.g. "LINE #1F" or '<line id="a">'
    where: str  # what the entity's name adds after the label, e.g. " on layer 'stones'" ("" for none)
    kind: str  # what the reader's summary counts, e.g. "LINE"
    fixed: bool
    line: bool  # True: a line (skipped when on no stone); False: an open polyline (an error then)

    @property
    def name(self) -> str:
        return self.label + self.where


def _joined_ends(segments: list[Segment], tolerance: float) -> list[np.ndarray]:
    """The segments' points with ends closer than ``tolerance`` moved to their common mean, and an end that
    meets no other end moved onto a segment closer than ``tolerance`` (a line drawn short of another)."""
    import shapely
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    ends = np.array([[s.points[0], s.points[-1]] for s in segments], float).reshape(-1, 2)
    pairs = cKDTree(ends).query_pairs(tolerance, output_type="ndarray")
    n = ends.shape[0]
    graph = coo_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else \
        coo_array((n, n))
    _, label = connected_components(graph, directed=False)
    sums = np.zeros((label.max() + 1, 2))
    np.add.at(sums, label, ends)
    merged = sums[label] / np.bincount(label)[label, None]
    out = []
    for k, s in enumerate(segments):
        p = np.array(s.points, float)
        p[0], p[-1] = merged[2 * k], merged[2 * k + 1]
        out.append(p)
    lone = np.flatnonzero(np.bincount(label)[label] == 1)
    if lone.size:
        lines = np.array([shapely.LineString(p) for p in out], dtype=object)
        tree = shapely.STRtree(lines)
        for end in lone.tolist():
            k, point = end // 2, shapely.Point(ends[end])
            near = [j for j in tree.query(point, predicate="dwithin", distance=tolerance).tolist() if j != k]
            if near:
                j = min(near, key=lambda j: shapely.distance(lines[j], point))
                on = shapely.line_interpolate_point(lines[j], shapely.line_locate_point(lines[j], point))
                out[k][0 if end % 2 == 0 else -1] = shapely.get_coordinates(on)[0]
    return out


def _arrangement(points: list[np.ndarray], tolerance: float):
    """Pieces of the noded segments, bounded faces (slivers removed), which faces each piece borders
    and which segments cover it."""
    import shapely

    lines = np.array([shapely.LineString(p) for p in points], dtype=object)
    pieces = shapely.get_parts(shapely.unary_union(lines))
    faces = shapely.get_parts(shapely.polygonize_full(pieces)[0])
    faces = faces[2 * shapely.area(faces) >= tolerance * shapely.length(faces)]  # slivers: spaces
    middle = shapely.line_interpolate_point(pieces, 0.5, normalized=True)
    extent = float(np.ptp(np.vstack(points), axis=0).max()) or 1.0
    near = 1e-9 * extent
    piece_faces: list[list[int]] = [[] for _ in pieces]
    for i, j in shapely.STRtree(shapely.boundary(faces)).query(middle, predicate="dwithin", distance=near).T:
        piece_faces[i].append(int(j))
    covering: list[list[int]] = [[] for _ in pieces]
    for i, j in shapely.STRtree(lines).query(middle, predicate="dwithin", distance=near).T:
        covering[i].append(int(j))
    return pieces, faces, piece_faces, covering


def _stone_faces(pieces, n_faces: int, piece_faces: list[list[int]], covering: list[list[int]],
                 segments: list[Segment], source: str) -> np.ndarray:
    """Whether each face is a stone: beside the outside a stone, across a piece covered once from a stone a
    space, twice or more a stone (a breadth-first walk from the outside inwards); a piece beside more
    stones than it is drawn is a StructureFileError."""
    from collections import deque

    stone = np.full(n_faces, -1)
    pieces_of: list[list[int]] = [[] for _ in range(n_faces)]
    for i, faces in enumerate(piece_faces):
        for f in faces:
            pieces_of[f].append(i)
        if len(faces) == 1:
            stone[faces[0]] = 1
    queue = deque(np.flatnonzero(stone == 1).tolist())
    while queue:
        f = queue.popleft()
        for i in pieces_of[f]:
            other = [g for g in piece_faces[i] if g != f]
            if len(other) == 1 and stone[other[0]] < 0:
                stone[other[0]] = min(max(len(covering[i]) - stone[f], 0), 1)
                queue.append(other[0])
    for i, faces in enumerate(piece_faces):
        if faces and (sum(int(stone[f]) for f in faces) > len(covering[i]) or min(stone[f] for f in faces) < 0):
            names = ", ".join(segments[k].name for k in covering[i])
            a, b = pieces[i].coords[0], pieces[i].coords[-1]
            drawn = {1: "once", 2: "twice"}.get(len(covering[i]), f"{len(covering[i])} times")
            beside = "beside one face" if len(faces) == 1 else "between two faces"
            raise StructureFileError(
                f"{source}: {names}: cannot tell the stones from the spaces between them along "
                f"[{a[0]:.6g}, {a[1]:.6g}] - [{b[0]:.6g}, {b[1]:.6g}] (drawn {drawn} there, {beside}); "
                "draw each stone as a closed polyline, or with its own lines")
    return stone == 1


def _loop_name(own: list[Segment]) -> str:
    labels = [s.label for s in own]
    shown = ", ".join(labels[:4]) + (f" and {len(labels) - 4} more" if len(labels) > 4 else "")
    wheres = {s.where for s in own}
    return f"loop of {shown}{wheres.pop() if len(wheres) == 1 else ''}"


def join_loops(segments: list[Segment], snap: float, source: str) -> tuple[list[Stone], np.ndarray]:
    """The stones that ``segments`` close (in the file's coordinates), and which segments lie on a stone's outline.

    Parameters
    ----------
    segments : list of Segment
        In the file's coordinates.
    snap : float
        Ends closer than ``snap`` times the median segment size (the diagonal of its bounding box) are
        joined, and faces thinner than that are spaces (at least ``1e-9`` times the drawing's size).
    source : str
        The file, for the errors.

    Raises
    ------
    StructureFileError
        No consistent choice of stones (naming the segments where it fails), a loop around a space or
        another stone, a loop of segments both on and off the supports.
    """
    import shapely

    used = np.zeros(len(segments), bool)
    if not segments:
        return [], used
    sizes = np.array([np.hypot(*np.ptp(s.points, axis=0)) for s in segments])
    extent = float(np.ptp(np.vstack([s.points for s in segments]), axis=0).max())
    tolerance = max(snap * float(np.median(sizes)), 1e-9 * extent)
    points = _joined_ends(segments, tolerance)
    keep = [k for k, p in enumerate(points) if np.hypot(*np.ptp(p, axis=0)) > tolerance]
    if not keep:
        return [], used
    pieces, faces, piece_faces, covering = _arrangement([points[k] for k in keep], tolerance)
    kept = [segments[k] for k in keep]
    stone = _stone_faces(pieces, len(faces), piece_faces, covering, kept, source)
    faces_of = [None] * len(kept)  # the stone faces each segment borders all along (its loose ends aside)
    near: list[set] = [set() for _ in range(len(faces))]  # the segments along each face
    for i, fs in enumerate(piece_faces):
        on = {f for f in fs if stone[f]}
        for k in covering[i] if fs else ():
            faces_of[k] = on if faces_of[k] is None else faces_of[k] & on
            for f in fs:
                near[f].add(k)
    stones = []
    for f in np.flatnonzero(stone):
        border = [k for k in sorted(near[f]) if faces_of[k] and f in faces_of[k]] or sorted(near[f])
        own = [kept[k] for k in border if faces_of[k] == {f}] or [kept[k] for k in border]
        name = _loop_name(own)
        if len(faces[f].interiors):
            raise StructureFileError(f"{source}: {name} surrounds a space or another stone; a stone must be a "
                                     "simple polygon")
        if len({s.fixed for s in own}) > 1:
            raise StructureFileError(f"{source}: {name} mixes supports and stones; draw a stone's lines on one layer")
        # without the vertices where other lines end on its straight sides (T-junctions of the arrangement)
        outline = shapely.simplify(faces[f].exterior, 1e-12 * extent)
        stones.append(Stone(np.asarray(outline.coords)[:-1], own[0].fixed, name))
    for i, fs in enumerate(piece_faces):
        if any(stone[f] for f in fs):
            used[[keep[k] for k in covering[i]]] = True
    return stones, used
