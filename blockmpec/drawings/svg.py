"""Stones from an SVG drawing (svgelements): every closed path or polygon is a stone.

Read are ``<path>`` (each closed sub-path a stone), ``<polygon>``, ``<rect>``, closed ``<polyline>``
and ``<circle>``/``<ellipse>`` elements, with their transformations (``transform`` attributes of
the element and its groups, ``<use>``).  Curved segments are replaced by ``curve_segments``
chords each.  A stone is a support when its ``class`` (or that of a group around it) contains
``fixed_class``, or its id or a group's id or Inkscape layer name is ``fixed_class``.

Frame: SVG's ``y`` axis points *down*; the structure's points *up*.  A point ``(x, y)`` of the
drawing (in the user units of the root ``<svg>``, i.e. of its ``viewBox``) is ``(s x, -s y)`` in the
structure, ``s`` the metres per user unit (``scale``, else ``units``, else from the root's
``width`` and ``viewBox`` when the width has a physical unit such as ``mm``, else 1).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from blockmpec.drawings._common import (
    DEFAULT_SNAP,
    LENGTH_UNITS,
    Stone,
    build_structure,
    check_common,
    clean_outline,
    closing_gap,
    scale_option,
)
from blockmpec.errors import OptionError, StructureFileError
from blockmpec.geometry import DEFAULT_FRICTION, Structure

_INKSCAPE_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
_PHYSICAL = {"mm": 0.001, "cm": 0.01, "m": 1.0, "in": 0.0254, "pt": 0.0254 / 72, "pc": 0.0254 / 6}


def _attributes(element) -> dict:
    return element.values.get("attributes", {}) if hasattr(element, "values") else {}


def _marks_fixed(element, fixed_class: str) -> bool:
    attrs = _attributes(element)
    classes = str(attrs.get("class", "")).split()
    label = attrs.get(_INKSCAPE_LABEL, attrs.get("inkscape:label"))
    return fixed_class in classes or attrs.get("id") == fixed_class or label == fixed_class


def _entity_name(element, number: int, subpath: int | None) -> str:
    attrs = _attributes(element)
    tag = attrs.get("tag", type(element).__name__.lower())
    name = f'<{tag} id="{attrs["id"]}">' if attrs.get("id") else f"<{tag}> number {number} (no id)"
    return name if subpath is None else f"{name} sub-path {subpath}"


def _user_units_per_px(svg) -> tuple[np.ndarray, float | None]:
    """The inverse of the root's viewBox transformation (a 2x3 matrix) and the metres per user unit
    that the root's ``width`` gives, when it has a physical unit."""
    from svgelements import Matrix

    transform = getattr(svg, "viewbox_transform", None)
    m = ~Matrix(transform) if transform else Matrix()
    inverse = np.array([[m.a, m.c, m.e], [m.b, m.d, m.f]], float)
    width = str(_attributes(svg).get("width", ""))
    found = re.fullmatch(r"\s*([0-9.eE+-]+)\s*(mm|cm|m|in|pt|pc)\s*", width)
    per_unit = None
    if found and svg.viewbox is not None and svg.viewbox.width:
        per_unit = float(found.group(1)) * _PHYSICAL[found.group(2)] / float(svg.viewbox.width)
    return inverse, per_unit


def _subpaths(shape, curve_segments: int) -> list[tuple[np.ndarray, bool]]:
    """``(points, closed)`` of each sub-path of a shape (in the parser's px), curves as chords."""
    from svgelements import Close, Line, Move, Path

    out: list[tuple[list, bool]] = []
    current: list = []
    closed = False
    for seg in Path(shape):
        if isinstance(seg, Move):
            if current:
                out.append((current, closed))
            current, closed = [(seg.end.x, seg.end.y)], False
        elif isinstance(seg, Close):
            closed = True
        elif isinstance(seg, Line):
            current.append((seg.end.x, seg.end.y))
        else:  # curves and arcs: chords
            t = np.linspace(0.0, 1.0, curve_segments + 1)[1:]
            current += [tuple(p) for p in np.asarray(seg.npoint(t), float)]
    if current:
        out.append((current, closed))
    return [(np.array(points, float).reshape(-1, 2), c) for points, c in out]


def read_svg(
    path: str | Path,
    *,
    fixed_class: str = "fixed",
    units: str | None = None,
    scale: float | None = None,
    mu: float = DEFAULT_FRICTION,
    dilatancy: float = 0.0,
    density: float = 1.0,
    live_direction: int = 1,
    snap: float = DEFAULT_SNAP,
    curve_segments: int = 8,
) -> Structure:
    """A structure from the closed paths and polygons of an SVG drawing (``y`` turned to point up).

    Parameters
    ----------
    path : path of an ``.svg`` file
    fixed_class : str
        Class (or id, or Inkscape layer name) that marks supports.
    units : {"m", "dm", "cm", "mm", "km", "in", "ft"}, optional
        The length of one user unit of the drawing.
    scale : float, optional
        Metres per user unit (overrides ``units``).
    mu, dilatancy, density, live_direction, snap
        As for :func:`blockmpec.drawings.dxf.read_dxf`.
    curve_segments : int
        Chords per curved segment.

    Raises
    ------
    StructureFileError
        Not an SVG file, no closed shape, or an open shape.
    GeometryError, StructureError
        Naming the element (its id, or its number in document order).
    """
    from svgelements import SVG, Group, Shape

    check_common(mu, dilatancy, density, live_direction, snap)
    if not isinstance(fixed_class, str) or not fixed_class:
        raise OptionError(f"fixed_class: expected a class name; got {fixed_class!r}")
    if isinstance(curve_segments, bool) or not isinstance(curve_segments, int) or curve_segments < 1:
        raise OptionError(f"curve_segments: must be an integer >= 1; got {curve_segments!r}")
    p = Path(path)
    try:
        text = p.read_bytes()
    except OSError as exc:
        raise StructureFileError(f"{p}: cannot read ({exc.strerror or exc})") from None
    import io
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise StructureFileError(f"{p}: not valid XML ({exc})") from None
    if not root.tag.endswith("svg"):
        raise StructureFileError(f"{p}: not an SVG file (its root element is <{root.tag}>)")
    try:
        svg = SVG.parse(io.BytesIO(text))
    except Exception as exc:  # svgelements raises several types for broken files
        raise StructureFileError(f"{p}: not a readable SVG file ({type(exc).__name__}: {exc})") from None
    inverse, per_unit = _user_units_per_px(svg)
    factor = scale_option(units, scale, per_unit or 1.0, str(p))
    stones: list[Stone] = []
    counts = {"shapes": 0}

    def visit(group, fixed: bool) -> None:
        for element in group:
            if isinstance(element, Group):
                visit(element, fixed or _marks_fixed(element, fixed_class))
            elif isinstance(element, Shape):
                counts["shapes"] += 1
                is_fixed = fixed or _marks_fixed(element, fixed_class)
                subpaths = _subpaths(element, curve_segments)
                for k, (points, closed) in enumerate(subpaths):
                    name = _entity_name(element, counts["shapes"], k + 1 if len(subpaths) > 1 else None)
                    if points.shape[0] < 3 and not closed:
                        if points.shape[0] == 1:
                            continue  # a lone move-to draws nothing
                        raise StructureFileError(f"{p}: {name} is an open line, not an outline; close it "
                                                 "(or remove it)")
                    user = points @ inverse[:, :2].T + inverse[:, 2]
                    size = float(np.hypot(*np.ptp(user, axis=0)))
                    if not closed and closing_gap(user) > 1e-9 * size:
                        raise StructureFileError(
                            f"{p}: {name} is open (its ends are {closing_gap(user):.3g} user units apart); "
                            "close it with Z (or remove it)")
                    outline = clean_outline(user)
                    if outline.shape[0] < 3:
                        raise StructureFileError(f"{p}: {name} has {outline.shape[0]} distinct points; "
                                                 "a stone needs at least 3")
                    stones.append(Stone(outline * [factor, -factor] + 0.0, is_fixed, name))  # + 0.0: no -0.0

    visit(svg, _marks_fixed(svg, fixed_class))
    if not stones:
        raise StructureFileError(f"{p}: no closed path, polygon or rect (found {counts['shapes']} shapes); "
                                 "draw each stone as a closed shape")
    frame = {"format": "svg", "scale": factor, "flip_y": True}
    return build_structure(stones, p, mu=mu, dilatancy=dilatancy, density=density, live_direction=live_direction,
                           snap=snap, frame=frame,
                           support_hint=f"no shape with class {fixed_class!r} (the supports; another class with "
                                        "-p fixed_class=NAME)")


__all__ = ["read_svg", "LENGTH_UNITS"]
