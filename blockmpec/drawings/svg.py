"""Stones from an SVG drawing (svgelements): every closed shape is a stone.

Read are ``<path>`` (each closed sub-path a stone), ``<polygon>``, ``<rect>``, closed ``<polyline>``
and ``<circle>``/``<ellipse>`` elements, also inside groups and as ``<use>`` clones, each through its
whole chain of transformations (its own ``transform``, its groups', its ``<use>``'s and the root's
``viewBox``: svgelements' transformed segments).  Open shapes and ``<line>`` elements are joined
where they close loops (:mod:`blockmpec.drawings._loops`).  Curved segments are replaced by
``curve_segments`` chords each.  A stone is a support when its ``class`` (or that of a group around
it) contains ``fixed_class``, or its id or a group's id or Inkscape layer name is ``fixed_class``
(all compared without case).  Texts, images, lines on no stone's outline and shapes hidden by
``display:none`` are left out and counted in the summary line.

Frame: SVG's ``y`` axis points *down*; the structure's points *up*.  A point ``(x, y)`` of the
drawing (in the user units of the root ``<svg>``, i.e. of its ``viewBox``) is ``(s x, -s y)`` in the
structure, ``s`` the metres per user unit (``scale``, else ``units``, else from the root's
``width``/``height`` and ``viewBox`` when they have a physical unit such as ``mm``, else 1).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from blockmpec.drawings._common import (
    DEFAULT_SNAP,
    LENGTH_UNITS,
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

_INKSCAPE_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
#: Metres per CSS absolute unit of a root ``width``/``height`` (which give the drawing a physical size).
_PHYSICAL = {"mm": 0.001, "cm": 0.01, "q": 0.00025, "in": 0.0254, "pt": 0.0254 / 72, "pc": 0.0254 / 6}
#: Elements that draw something (counted when hidden by ``display:none``).
_DRAWN = {"path", "rect", "polygon", "polyline", "circle", "ellipse", "line", "text", "image", "use"}
#: Containers whose content is not drawn where it stands.
_NOT_DRAWN = {"defs", "clipPath", "mask", "pattern", "symbol", "marker", "metadata"}


def _attributes(element) -> dict:
    return element.values.get("attributes", {}) if hasattr(element, "values") else {}


def _marks_fixed(element, fixed_class: str) -> bool:
    attrs = _attributes(element)
    key = fixed_class.lower()
    classes = str(attrs.get("class", "")).lower().split()
    label = str(attrs.get(_INKSCAPE_LABEL, attrs.get("inkscape:label", ""))).lower()
    return key in classes or str(attrs.get("id", "")).lower() == key or label == key


def _entity_name(element, number: int, subpath: int | None) -> str:
    attrs = _attributes(element)
    tag = attrs.get("tag", type(element).__name__.lower())
    name = f'<{tag} id="{attrs["id"]}">' if attrs.get("id") else f"<{tag}> number {number} (no id)"
    return name if subpath is None else f"{name} sub-path {subpath}"


def _viewbox(svg):
    """The root's viewBox transformation (svgelements' Matrix: user units -> svgelements' pixels)."""
    from svgelements import Matrix

    transform = getattr(svg, "viewbox_transform", None)
    return Matrix(transform) if transform else Matrix()


def _physical_scale(svg, p: Path) -> float | None:
    """Metres per user unit from the root's ``width``/``height`` when one has a physical unit (else None).

    With a ``viewBox``, the user units are scaled into the width and height as ``preserveAspectRatio``
    says (default: uniformly, to fit); without one, a user unit is a CSS pixel (1/96 inch)."""
    attrs = _attributes(svg)
    size = {}
    for key in ("width", "height"):
        found = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([a-zA-Z]*)\s*", str(attrs.get(key, "")))
        if found and found.group(2).lower() in _PHYSICAL:
            size[key] = float(found.group(1)) * _PHYSICAL[found.group(2).lower()]
    if not size:
        return None
    box = svg.viewbox
    if box is None or not box.width or not box.height:
        return _PHYSICAL["in"] / 96
    sx, sy = (size[k] / d if k in size else None for k, d in (("width", box.width), ("height", box.height)))
    aspect = str(attrs.get("preserveAspectRatio", "")).split()
    if aspect[:1] == ["none"] and sx and sy and not np.isclose(sx, sy, rtol=1e-9):
        raise StructureFileError(f"{p}: the root's viewBox is stretched unequally (preserveAspectRatio=\"none\": "
                                 f"{sy / sx:.6g} times as much in y as in x); give the drawing's unit with "
                                 "-p units=... (it is then read in its user units)")
    if sx and sy:
        return max(sx, sy) if "slice" in aspect else min(sx, sy)
    return sx or sy


def _hidden_count(root) -> int:
    """Drawn elements inside ``display:none`` (svgelements leaves them out)."""
    def hidden(e) -> bool:
        style = e.get("style", "")
        return e.get("display", "").strip() == "none" or re.search(r"display\s*:\s*none", style) is not None

    def visit(e, inside: bool) -> int:
        tag = e.tag.rsplit("}", 1)[-1]
        if tag in _NOT_DRAWN:
            return 0
        inside = inside or hidden(e)
        return int(inside and tag in _DRAWN) + sum(visit(c, inside) for c in e)

    return visit(root, False)


def _subpaths(shape, curve_segments: int) -> list[tuple[np.ndarray, bool, int]]:
    """``(points, closed, pieces)`` of each sub-path of a shape, transformed (svgelements' pixels),
    curves as chords; ``pieces`` counts its segments."""
    from svgelements import Close, Line, Move

    out: list[tuple[list, bool, int]] = []
    current: list = []
    closed, pieces = False, 0
    for seg in shape.segments(transformed=True):
        if isinstance(seg, Move):
            if current:
                out.append((current, closed, pieces))
            current, closed, pieces = [(seg.end.x, seg.end.y)], False, 0
        elif isinstance(seg, Close):
            closed = True
        elif isinstance(seg, Line):
            current.append((seg.end.x, seg.end.y))
            pieces += 1
        else:  # curves and arcs: chords
            if not current:
                current = [(seg.start.x, seg.start.y)]
            t = np.linspace(0.0, 1.0, curve_segments + 1)[1:]
            current += [tuple(p) for p in np.asarray(seg.npoint(t), float)]
            pieces += 1
    if current:
        out.append((current, closed, pieces))
    return [(np.array(points, float).reshape(-1, 2), c, n) for points, c, n in out]


def _shapes(svg, fixed_class: str, reading: Reading):
    """``(shape, fixed, via)`` of every drawn shape (groups and ``<use>`` clones followed); texts and
    images counted as skipped."""
    from svgelements import Group, Shape, Use

    uses = [0]

    def visit(container, fixed: bool, via: str):
        for element in container:
            if isinstance(element, Use):
                uses[0] += 1
                attrs = _attributes(element)
                use = f'<use id="{attrs["id"]}">' if attrs.get("id") else f"<use> number {uses[0]}"
                yield from visit(element, fixed or _marks_fixed(element, fixed_class), f" (cloned by {use}){via}")
            elif isinstance(element, Group):
                yield from visit(element, fixed or _marks_fixed(element, fixed_class), via)
            elif isinstance(element, Shape):
                yield element, fixed or _marks_fixed(element, fixed_class), via
            else:
                tag = _attributes(element).get("tag", "")
                if tag in ("text", "image"):  # a <text>'s <tspan>s are part of it
                    reading.skipped[f"<{tag}>"] += 1

    yield from visit(svg, _marks_fixed(svg, fixed_class), "")


def _read_shapes(svg, inverse: np.ndarray, fixed_class: str, curve_segments: int, p: Path,
                 reading: Reading) -> tuple[list[Stone], list[Segment]]:
    """Stones (closed sub-paths) and segments (open ones, lines) in user units (``y`` down)."""
    from svgelements import SimpleLine

    stones, segments = [], []
    for number, (element, fixed, via) in enumerate(_shapes(svg, fixed_class, reading), 1):
        subpaths = _subpaths(element, curve_segments)
        tag = _attributes(element).get("tag", type(element).__name__.lower())
        for k, (points, closed, pieces) in enumerate(subpaths):
            if points.shape[0] < 2:
                continue  # a lone move-to draws nothing
            name = _entity_name(element, number, k + 1 if len(subpaths) > 1 else None)
            user = points @ inverse[:, :2].T + inverse[:, 2]
            size = float(np.hypot(*np.ptp(user, axis=0)))
            if closed or (points.shape[0] > 2 and closing_gap(user) <= 1e-9 * size):
                outline = clean_outline(user)
                if outline.shape[0] < 3:
                    raise StructureFileError(f"{p}: {name}{via} has {outline.shape[0]} distinct points; "
                                             "a stone needs at least 3")
                stones.append(Stone(outline, fixed, name + via))
            else:
                line = isinstance(element, SimpleLine) or pieces == 1
                segments.append(Segment(user, name, via, f"<{tag}>", fixed, line))
    return stones, segments


def _refuse_inner_viewboxes(root, p: Path) -> None:
    """A nested ``<svg>``, or a ``<symbol>`` that a ``<use>`` draws, with a viewBox of its own is a
    StructureFileError: svgelements places their content without that viewBox's scaling (1.9)."""
    used = {str(v).lstrip("#") for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "use"
            for k, v in e.attrib.items() if k.rsplit("}", 1)[-1] == "href"}
    for e in root.iter():
        tag = e.tag.rsplit("}", 1)[-1]
        if e is not root and e.get("viewBox") and (tag == "svg" or tag == "symbol" and e.get("id") in used):
            name = f'<{tag} id="{e.get("id")}">' if e.get("id") else f"a nested <{tag}>"
            raise StructureFileError(f"{p}: {name} has a viewBox of its own, whose scaling blockmpec cannot apply; "
                                     "ungroup it into plain groups (Inkscape: Object > Ungroup) or remove its viewBox")


def _parse(p: Path):
    """The svgelements document and the number of drawn elements that ``display:none`` hides."""
    import io

    from svgelements import SVG

    try:
        text = p.read_bytes()
    except OSError as exc:
        raise StructureFileError(f"{p}: cannot read ({exc.strerror or exc})") from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise StructureFileError(f"{p}: not valid XML ({exc})") from None
    if not root.tag.endswith("svg"):
        raise StructureFileError(f"{p}: not an SVG file (its root element is <{root.tag}>)")
    _refuse_inner_viewboxes(root, p)
    try:
        svg = SVG.parse(io.BytesIO(text), reify=True)
    except Exception as exc:  # svgelements raises several types for broken files
        raise StructureFileError(f"{p}: not a readable SVG file ({type(exc).__name__}: "
                                 f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    return svg, _hidden_count(root)


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
    """A structure from the closed shapes (and the closed loops of lines) of an SVG drawing (``y`` turned up).

    Parameters
    ----------
    path : path of an ``.svg`` file
    fixed_class : str
        Class (or id, or Inkscape layer name) that marks supports; compared without case.
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
        Not an SVG file, no closed shape, an open path that closes no loop, lines whose loops are
        ambiguous.
    GeometryError, StructureError
        Naming the element (its id, or its number in document order).
    """
    check_common(mu, dilatancy, density, live_direction, snap)
    if not isinstance(fixed_class, str) or not fixed_class:
        raise OptionError(f"fixed_class: expected a class name; got {fixed_class!r}")
    if isinstance(curve_segments, bool) or not isinstance(curve_segments, int) or curve_segments < 1:
        raise OptionError(f"curve_segments: must be an integer >= 1; got {curve_segments!r}")
    p = Path(path)
    svg, hidden = _parse(p)
    reading = Reading()
    if hidden:
        reading.skipped["hidden (display:none)"] += hidden
    explicit = units is not None or scale is not None
    forward = _viewbox(svg)
    m = ~forward
    inverse = np.array([[m.a, m.c, m.e], [m.b, m.d, m.f]], float)  # svgelements' pixels -> user units
    per_unit = None if explicit else _physical_scale(svg, p)
    factor = scale_option(units, scale, per_unit or 1.0, str(p))
    if per_unit is None and not explicit:
        reading.unit_missing = ("no length unit (a width or height in mm, cm, in, pt or pc) on the root <svg>, so "
                                "one user unit is read as a metre",
                                "that looks like millimetres: give -p units=mm (or the drawing's unit)")
    stones, segments = _read_shapes(svg, inverse, fixed_class, curve_segments, p, reading)
    loops, used = join_loops(segments, snap, str(p))
    for s, u in zip(segments, used):
        if u:
            reading.joined[s.kind] += 1
        elif not s.line:
            raise StructureFileError(f"{p}: {s.name} is open (its ends are {closing_gap(s.points):.3g} user units "
                                     "apart); close it with Z (or remove it)")
        else:
            reading.skipped[s.kind] += 1
    stones += loops
    if not stones:
        found = ", ".join(f"{v} {k}" for k, v in sorted(reading.skipped.items())) or "no shapes"
        raise StructureFileError(f"{p}: no closed path, polygon or rect (found {found}); "
                                 "draw each stone as a closed shape")
    for s in stones:
        s.vertices = s.vertices * [factor, -factor] + 0.0  # y up; + 0.0: no -0.0
    frame = {"format": "svg", "scale": factor, "flip_y": True}
    return build_structure(stones, p, mu=mu, dilatancy=dilatancy, density=density, live_direction=live_direction,
                           snap=snap, frame=frame, reading=reading,
                           support_hint=f"no shape with class {fixed_class!r} (the supports; another class with "
                                        "-p fixed_class=NAME)")


__all__ = ["read_svg", "LENGTH_UNITS"]
