"""Stones from a DXF drawing (ezdxf): every closed polyline is a stone, those on the ``fixed`` layer supports.

Read are ``LWPOLYLINE`` and 2D/3D ``POLYLINE`` entities of the model space (also inside block
references, ``INSERT``, exploded with their transformation); arcs of a polyline (bulges) are
replaced by chords with a sagitta of at most ``arc_tolerance`` times the stone's size.  Other
entities (lines, texts, hatches, dimensions ...) are ignored.  Coordinates are taken in the
drawing's units times ``scale`` (metres per drawing unit: from ``scale``, else ``units``, else the
drawing's ``$INSUNITS``, else metres); ``z`` is dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blockmpec.drawings._common import (
    DEFAULT_SNAP,
    Stone,
    build_structure,
    check_common,
    clean_outline,
    closing_gap,
    scale_option,
)
from blockmpec.errors import OptionError, StructureFileError
from blockmpec.geometry import DEFAULT_FRICTION, Structure

#: Entities that can be stones.
POLYLINES = ("LWPOLYLINE", "POLYLINE")


def _entity_name(e, insert=None) -> str:
    handle = e.dxf.handle if e.dxf.hasattr("handle") and e.dxf.handle else None
    where = f"{e.dxftype()} #{handle}" if handle else f"{e.dxftype()} in INSERT #{insert.dxf.handle}"
    return f"{where} on layer {e.dxf.layer!r}"


def _outline(e, arc_tolerance: float) -> np.ndarray:
    """Vertices of a polyline entity (x, y), arcs replaced by chords."""
    import ezdxf.path

    if e.dxftype() == "LWPOLYLINE":
        points = np.array([(x, y) for x, y in e.get_points("xy")], float).reshape(-1, 2)
    else:
        points = np.array([(v.dxf.location.x, v.dxf.location.y) for v in e.vertices], float).reshape(-1, 2)
    if e.has_arc and points.shape[0] >= 2:
        size = float(np.hypot(*np.ptp(points, axis=0))) or 1.0
        path = ezdxf.path.make_path(e)
        points = np.array([(v.x, v.y) for v in path.flattening(distance=arc_tolerance * size)], float)
    return points


def _polyline_entities(msp):
    """``(entity, insert)`` of every polyline of the model space, block references exploded."""
    counts: dict[str, int] = {}
    out = []

    def visit(entities, insert, depth):
        for e in entities:
            kind = e.dxftype()
            counts[kind] = counts.get(kind, 0) + 1
            if kind in POLYLINES:
                out.append((e, insert))
            elif kind == "INSERT" and depth < 8:
                visit(list(e.virtual_entities()), insert or e, depth + 1)

    visit(msp, None, 0)
    return out, counts


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
    """A structure from the closed polylines of a DXF drawing.

    Parameters
    ----------
    path : path of a ``.dxf`` file
    fixed_layer : str
        Layer of the supports (compared without case, as CAD programs do).
    layers : list of str, optional
        Layers that hold stones (default: every layer); the fixed layer is always read.
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
        Relative snapping distance (:func:`blockmpec.geometry.snap_polygons`); 0 for none.
    arc_tolerance : float
        Largest sagitta of the chords replacing arcs, relative to the stone's size.

    Raises
    ------
    StructureFileError
        The file cannot be read as DXF, holds no polyline, or a polyline on a stone layer is open.
    GeometryError, StructureError
        Naming the entity (handle and layer): self-intersection, overlap, a stone touching nothing,
        no stone on the fixed layer.
    """
    import ezdxf
    from ezdxf import units as dxf_units

    check_common(mu, dilatancy, density, live_direction, snap)
    if not isinstance(fixed_layer, str) or not fixed_layer:
        raise OptionError(f"fixed_layer: expected a layer name; got {fixed_layer!r}")
    if layers is not None and (not isinstance(layers, (list, tuple)) or not all(isinstance(x, str) for x in layers)):
        raise OptionError(f"layers: expected a list of layer names; got {layers!r}")
    if isinstance(arc_tolerance, bool) or not isinstance(arc_tolerance, (int, float)) or not 0 < arc_tolerance < 1:
        raise OptionError(f"arc_tolerance: must be a number in (0, 1); got {arc_tolerance!r}")
    p = Path(path)
    if not p.is_file():
        raise StructureFileError(f"{p}: cannot read ({'a folder' if p.is_dir() else 'no such file'})")
    try:
        doc = ezdxf.readfile(p)
    except OSError as exc:  # ezdxf's "is not a DXF file" is an IOError
        raise StructureFileError(f"{p}: not a readable DXF file ({exc.strerror or exc})") from None
    except ezdxf.DXFStructureError as exc:
        raise StructureFileError(f"{p}: not a valid DXF file ({exc})") from None
    except Exception as exc:  # ezdxf raises several types for broken files
        raise StructureFileError(f"{p}: not a readable DXF file ({type(exc).__name__}: {exc})") from None
    insunits = int(doc.header.get("$INSUNITS", 0) or 0)
    default = 1.0
    if insunits:
        try:
            default = dxf_units.conversion_factor(insunits, dxf_units.M)
        except Exception:  # an unknown unit code: metres
            default = 1.0
    factor = scale_option(units, scale, default, str(p))
    wanted = None if layers is None else {x.lower() for x in layers} | {fixed_layer.lower()}
    entities, counts = _polyline_entities(doc.modelspace())
    stones = []
    for e, insert in entities:
        layer = e.dxf.layer
        if wanted is not None and layer.lower() not in wanted:
            continue
        name = _entity_name(e, insert)
        if e.dxftype() == "POLYLINE" and (e.is_poly_face_mesh or e.is_polygon_mesh):
            raise StructureFileError(f"{p}: {name} is a mesh, not an outline; draw each stone as a closed polyline")
        points = _outline(e, arc_tolerance)
        if points.shape[0] < 3:
            raise StructureFileError(f"{p}: {name} has {points.shape[0]} vertices; a stone needs at least 3")
        size = float(np.hypot(*np.ptp(points, axis=0)))
        if not e.is_closed and closing_gap(points) > 1e-9 * size:
            raise StructureFileError(
                f"{p}: {name} is an open polyline (its ends are {closing_gap(points):.3g} drawing units apart); "
                "close it (or move it to a layer that is not read)"
            )
        outline = clean_outline(points) * factor
        stones.append(Stone(outline, layer.lower() == fixed_layer.lower(), name))
    if not stones:
        found = ", ".join(f"{v} {k}" for k, v in sorted(counts.items())) or "nothing"
        raise StructureFileError(f"{p}: no closed polyline{'' if layers is None else ' on the layers read'} "
                                 f"(found {found}); draw each stone as a closed polyline")
    frame = {"format": "dxf", "scale": factor, "flip_y": False, "insunits": insunits}
    return build_structure(stones, p, mu=mu, dilatancy=dilatancy, density=density, live_direction=live_direction,
                           snap=snap, frame=frame,
                           support_hint=f"no closed polyline on layer {fixed_layer!r} (the supports; "
                                        "another layer with -p fixed_layer=NAME)")
