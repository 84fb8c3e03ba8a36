"""Stones from a DXF drawing (ezdxf): every closed outline is a stone, those on the ``fixed`` layer supports.

Read, in the model space and inside block references (``INSERT`` and ``MINSERT``, nested to any
depth):

* closed ``LWPOLYLINE``, ``POLYLINE`` (2D and 3D) and ``SPLINE`` entities: each a stone;
* ``LINE``, ``ARC``, elliptical arcs (``ELLIPSE``), open ``SPLINE`` and open polylines: joined where
  they close loops (:mod:`blockmpec.drawings._loops`), each loop a stone.

Every entity is taken to world coordinates by ezdxf: its own object coordinate system (the extrusion
``(0, 0, -1)`` that AutoCAD's MIRROR writes included) by :func:`ezdxf.path.make_path`, and the
transformation of each block reference around it (mirrored, rotated, non-uniformly scaled, nested)
by :meth:`Insert.matrix44 <ezdxf.entities.Insert.matrix44>`, applied to the entity's path, so
that arcs stay exact curves under any scaling.  Block content on layer ``0`` takes the layer of its
``INSERT`` (the CAD convention).  Curves (splines evaluated as their B-splines) are replaced by chords
with a sagitta of at most ``arc_tolerance`` times the entity's size.  ``z`` is dropped; an entity that does not lie in a plane
parallel to ``x``-``y`` is an error.

Everything else (texts, dimensions, hatches, circles, points, lines on no stone's outline ...) is
left out and counted in the summary line (``metadata["drawing"]["summary"]``).  Coordinates are
taken in the drawing's units times ``scale`` (metres per drawing unit: from ``scale``, else
``units``, else the drawing's ``$INSUNITS``, else metres).
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from blockmpec.drawings._common import (
    DEFAULT_SNAP,
    Reading,
    Stone,
    build_structure,
    check_common,
    clean_outline,
    closing_gap,
    scale_option,
)
from blockmpec.drawings._loops import Segment, join_loops
from blockmpec.errors import OptionError, StructureFileError
from blockmpec.geometry import DEFAULT_FRICTION, Structure

#: Entities whose closed ones are stones and whose open ones are joined with the lines.
OUTLINES = ("LWPOLYLINE", "POLYLINE", "SPLINE")
#: Entities joined where they close loops (a full ELLIPSE is left out, as a CIRCLE is).
LINES = ("LINE", "ARC", "ELLIPSE")
#: ezdxf's paths hold arcs as cubic Bezier curves, off the circle by about 2.7e-4 (theta / 90 deg)^6 of its
#: radius for an arc of theta; with 48 "segments" a polyline's arc (bulge) becomes 16 curves, 11.25 deg each
#: for a half circle (off by 1e-9 of the radius), and an ARC or ELLIPSE 48.
BEZIER_SEGMENTS = 48
#: Deepest nesting of block references followed.
MAX_DEPTH = 32


@dataclass
class _Item:
    """A graphic entity with the transformation and the layer it has in the drawing."""

    entity: Any
    matrix: Any  # ezdxf Matrix44 of the block references around it, None in the model space
    layer: str  # its layer, or that of its INSERT if it is on layer "0" inside a block
    label: str  # e.g. "LINE #2F in block 'STONE' of INSERT #3A"

    @property
    def name(self) -> str:
        return f"{self.label} on layer {self.layer!r}"


def _header_int(raw: bytes, variable: str) -> int | None:
    """An integer header variable as the file gives it (ezdxf fills a missing header with defaults)."""
    found = re.search(rb"\$" + variable.encode() + rb"\s*\n\s*70\s*\n\s*(-?\d+)", raw)
    return int(found.group(1)) if found else None


def _open(p: Path):
    """The ezdxf document, whether its entities have handles in the file, and its ``$INSUNITS`` (0: none)."""
    import ezdxf

    if not p.is_file():
        raise StructureFileError(f"{p}: cannot read ({'a folder' if p.is_dir() else 'no such file'})")
    try:
        raw = p.read_bytes()
        doc = ezdxf.readfile(p)
    except OSError as exc:  # ezdxf's "is not a DXF file" is an IOError
        raise StructureFileError(f"{p}: not a readable DXF file ({exc.strerror or exc})") from None
    except ezdxf.DXFStructureError as exc:
        raise StructureFileError(f"{p}: not a valid DXF file ({exc})") from None
    except Exception as exc:  # ezdxf raises several types for broken files
        raise StructureFileError(f"{p}: not a readable DXF file ({type(exc).__name__}: {exc})") from None
    r12 = b"AC1009" in raw[:4096] or b"$ACADVER" not in raw[:4096]
    handles = not r12 or _header_int(raw, "HANDLING") == 1  # R12 files may come without handles
    return doc, handles, _header_int(raw, "INSUNITS") or 0


def _entities(doc, handles: bool, skipped: Counter, source: Path) -> Iterator[_Item]:
    """Every graphic entity of the model space, block references followed (counting their attributes
    and external references as skipped)."""

    def visit(entities, matrix, parent_layer, where, blocks):
        for number, e in enumerate(entities, 1):
            kind = e.dxftype()
            layer = e.dxf.get("layer", "0")
            if parent_layer is not None and layer == "0":
                layer = parent_layer
            label = (f"{kind} #{e.dxf.handle}" if handles and e.dxf.get("handle") else f"{kind} number {number}") + where
            if kind == "INSERT":
                yield from inserted(e, matrix, layer, label, blocks)
            elif kind != "ATTDEF" or matrix is None:  # a block's attribute templates: drawn as its ATTRIBs
                yield _Item(e, matrix, layer, label)

    def inserted(insert, matrix, layer, label, blocks):
        block, name = insert.block(), insert.dxf.name
        if block is None:
            raise StructureFileError(f"{source}: {label} on layer {layer!r} inserts block {name!r}, which the file "
                                     "does not define")
        if name in blocks:
            raise StructureFileError(f"{source}: block {name!r} inserts itself ({' > '.join((*blocks, name))}); a "
                                     "block that contains itself cannot be drawn")
        if len(blocks) >= MAX_DEPTH:
            raise StructureFileError(f"{source}: {label}: block references nested more than {MAX_DEPTH} deep")
        skipped.update({"ATTRIB": len(insert.attribs)} if insert.attribs else {})
        if block.block is not None and block.block.is_xref:
            skipped["INSERT of an external reference"] += 1
            return
        copies = list(insert.multi_insert()) if insert.mcount > 1 else [insert]
        for copy in copies:
            m = copy.matrix44() if matrix is None else copy.matrix44() @ matrix
            yield from visit(block, m, layer, f" in block {name!r} of {label}", (*blocks, name))

    yield from visit(doc.modelspace(), None, None, "", ())


def _points(item: _Item, arc_tolerance: float, source: Path) -> tuple[np.ndarray, bool]:
    """The entity's outline in world coordinates (x, y; curves as chords) and whether it is closed."""
    import ezdxf.path

    e = item.entity
    try:  # a spline is evaluated as the B-spline it is (ezdxf's path holds it as approximate Bezier curves)
        curve = e.construction_tool() if e.dxftype() == "SPLINE" else ezdxf.path.make_path(e, segments=BEZIER_SEGMENTS)
    except Exception as exc:  # ezdxf refuses entities it cannot represent
        raise StructureFileError(f"{source}: {item.name} cannot be read as an outline "
                                 f"({type(exc).__name__}: {exc})") from None
    if item.matrix is not None:
        curve = curve.transform(item.matrix)
    vertices = curve.control_points if e.dxftype() == "SPLINE" else curve.control_vertices()
    control = np.array([tuple(v) for v in vertices], float).reshape(-1, 3)
    size = float(np.hypot(*np.ptp(control[:, :2], axis=0))) if control.size else 0.0
    points = np.array([tuple(v) for v in curve.flattening(arc_tolerance * (size or 1.0))], float).reshape(-1, 3)
    if points.shape[0] and np.ptp(points[:, 2]) > 1e-9 * max(size, float(np.abs(points).max())):
        raise StructureFileError(f"{source}: {item.name} does not lie in a plane parallel to x-y (its z runs from "
                                 f"{points[:, 2].min():.6g} to {points[:, 2].max():.6g}); blockmpec reads the "
                                 "x-y plane")
    xy = points[:, :2]
    closed = bool(getattr(e, "closed", False) or getattr(e, "is_closed", False))
    if xy.shape[0] >= 3 and closing_gap(xy) <= 1e-9 * size:
        closed = True  # a polyline whose last point repeats its first
    return xy, closed


def _read_entities(doc, handles: bool, wanted, fixed_layer: str, arc_tolerance: float, p: Path,
                   reading: Reading) -> tuple[list[Stone], list[Segment]]:
    """Stones (closed outlines) and segments (lines, arcs, open outlines) of the layers read; the rest counted."""
    stones, segments = [], []
    for item in _entities(doc, handles, reading.skipped, p):
        e, kind = item.entity, item.entity.dxftype()
        if kind not in OUTLINES + LINES:
            reading.skipped[kind] += 1
            continue
        if wanted is not None and item.layer.lower() not in wanted:
            reading.skipped[f"{kind} on layers not read"] += 1
            continue
        if kind == "POLYLINE" and (e.is_poly_face_mesh or e.is_polygon_mesh):
            raise StructureFileError(f"{p}: {item.name} is a mesh, not an outline; draw each stone as a closed "
                                     "polyline")
        points, closed = _points(item, arc_tolerance, p)
        fixed = item.layer.lower() == fixed_layer.lower()
        if closed and kind in OUTLINES:
            if points.shape[0] < 4:  # with the closing point
                raise StructureFileError(f"{p}: {item.name} has {max(points.shape[0] - 1, 1)} vertices; a stone "
                                         "needs at least 3")
            stones.append(Stone(clean_outline(points), fixed, item.name))
        elif closed or points.shape[0] < 2:
            reading.skipped[kind] += 1  # a CIRCLE-like full ellipse or a point-like entity
        else:
            vertices = len(e) if kind == "LWPOLYLINE" else len(e.vertices) if kind == "POLYLINE" else 0
            line = kind not in ("LWPOLYLINE", "POLYLINE") or vertices == 2  # one straight or curved piece
            segments.append(Segment(points, item.label, f" on layer {item.layer!r}", kind, fixed, line))
    return stones, segments


def read_dxf(
    path: str | Path,
    *,
    fixed_layer: str = "fixed",
    layers: list | None = None,
    units: str | None = None,
    scale: float | None = None,
    mu: float = DEFAULT_FRICTION,
    dilatancy: float = 0.0,
    density: float = 1.0,
    live_direction: int = 1,
    snap: float = DEFAULT_SNAP,
    arc_tolerance: float = 1e-3,
) -> Structure:
    """A structure from the closed outlines (and the closed loops of lines) of a DXF drawing.

    Parameters
    ----------
    path : path of a ``.dxf`` file
    fixed_layer : str
        Layer of the supports (compared without case, as CAD programs do).
    layers : list of str, optional
        Layers that hold stones (default: every layer; compared without case); the fixed layer is
        always read.
    units : {"m", "dm", "cm", "mm", "km", "in", "ft"}, optional
        The drawing's length unit, when ``$INSUNITS`` is missing or wrong.
    scale : float, optional
        Metres per drawing unit (overrides ``units``).
    mu, dilatancy : float
        ``tan(phi)`` and ``tan(psi)``.
    density : float
        Weight per unit area (the loads are proportional to it).
    live_direction : {1, -1}
        Direction of the horizontal live load (+x or -x).
    snap : float
        Relative snapping distance (:func:`blockmpec.geometry.snap_polygons`); 0 for none.  Ends of
        lines closer than ``snap`` times their median size are joined.
    arc_tolerance : float
        Largest sagitta of the chords replacing arcs, relative to the entity's size.

    Raises
    ------
    StructureFileError
        The file cannot be read as DXF, holds no stone, an open polyline on a stone layer closes no
        loop, lines whose loops are ambiguous, an entity outside the x-y plane.
    GeometryError, StructureError
        Naming the entity (handle, or number in a file without handles, and layer):
        self-intersection, overlap, a stone touching nothing, no stone on the fixed layer.
    """
    from ezdxf import units as dxf_units

    check_common(mu, dilatancy, density, live_direction, snap)
    if not isinstance(fixed_layer, str) or not fixed_layer:
        raise OptionError(f"fixed_layer: expected a layer name; got {fixed_layer!r}")
    if layers is not None and (not isinstance(layers, (list, tuple)) or not all(isinstance(x, str) for x in layers)):
        raise OptionError(f"layers: expected a list of layer names; got {layers!r}")
    if isinstance(arc_tolerance, bool) or not isinstance(arc_tolerance, (int, float)) or not 0 < arc_tolerance < 1:
        raise OptionError(f"arc_tolerance: must be a number in (0, 1); got {arc_tolerance!r}")
    p = Path(path)
    doc, handles, insunits = _open(p)
    default = None
    if insunits:
        try:
            default = dxf_units.conversion_factor(insunits, dxf_units.M)
        except Exception:  # a unit code ezdxf does not know: as if there were none
            default = None
    factor = scale_option(units, scale, default or 1.0, str(p))
    reading = Reading()
    if default is None and units is None and scale is None:
        reading.unit_missing = ("no length unit ($INSUNITS) in the drawing, so read in metres",
                                "that looks like millimetres: give -p units=mm (or the drawing's unit)")
    wanted = None if layers is None else {x.lower() for x in layers} | {fixed_layer.lower()}
    stones, segments = _read_entities(doc, handles, wanted, fixed_layer, arc_tolerance, p, reading)
    loops, used = join_loops(segments, snap, str(p))
    for s, u in zip(segments, used):
        if u:
            reading.joined[s.kind] += 1
        elif not s.line:
            gap = closing_gap(s.points)
            raise StructureFileError(f"{p}: {s.name} is an open polyline (its ends are {gap:.3g} drawing units "
                                     "apart); close it (or move it to a layer that is not read)")
        else:
            reading.skipped[s.kind] += 1
    stones += loops
    if not stones:
        found = ", ".join(f"{v} {k}" for k, v in sorted(reading.skipped.items())) or "nothing"
        raise StructureFileError(f"{p}: no closed polyline{'' if layers is None else ' on the layers read'} "
                                 f"(found {found}); draw each stone as a closed polyline")
    for s in stones:
        s.vertices = s.vertices * factor
    frame = {"format": "dxf", "scale": factor, "flip_y": False, "insunits": insunits}
    return build_structure(stones, p, mu=mu, dilatancy=dilatancy, density=density, live_direction=live_direction,
                           snap=snap, frame=frame, reading=reading,
                           support_hint=f"no closed polyline on layer {fixed_layer!r} (the supports; "
                                        "another layer with -p fixed_layer=NAME)")
