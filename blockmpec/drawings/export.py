"""A result drawn back into a drawing: the mechanism and the interface forces as DXF layers or SVG groups.

:func:`export_drawing` writes, in the coordinates of the drawing the structure came from (its
``metadata["drawing"]``: scale, ``y`` direction; the structure's own coordinates otherwise):

``blockmpec-mechanism``
    the outline of every stone that moves, displaced rigidly by the collapse mechanism, amplified
    so that the largest displacement is ``mechanism_amplitude`` times the median stone size;
``blockmpec-forces``
    at every interface that carries a force, a segment along the resultant ``t tau + n nu``
    through its point of application (``m / n`` from the midpoint along the interface), its
    length proportional to the force (the largest ``force_length`` times the median stone size),
    and a small circle at the point of application;
``blockmpec-notes``
    one line of text: the method, status, multiplier and the two scales;
``blockmpec-stones``
    the stones' outlines, unless the output is a copy of the source drawing (``source``), which
    holds them already.

With ``source`` (the drawing the structure was read from, same format) the output is that
drawing with these layers or groups added, ready to overlay; for a structure read from an
image an SVG output shows the image underneath.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from blockmpec.errors import OptionError

LAYERS = ("blockmpec-stones", "blockmpec-mechanism", "blockmpec-forces", "blockmpec-notes")
_DXF_COLOURS = {"blockmpec-stones": 8, "blockmpec-mechanism": 1, "blockmpec-forces": 5, "blockmpec-notes": 7}
_SVG_COLOURS = {"blockmpec-stones": "#888888", "blockmpec-mechanism": "#d9402b", "blockmpec-forces": "#1f5fbf",
                "blockmpec-notes": "#000000"}


def solution_in_structure_frame(structure, result) -> dict[str, Any]:
    """Mechanism and interface forces of ``result`` in the structure's axes, units and ids.

    The one place that maps a solver's canonical, nondimensional solution to the user's frame
    (see :func:`blockmpec.operators.assemble`): velocities ``(u_x, u_y, theta)`` at the centroid
    of each free block, ``mirror`` applied to ``u_x`` and ``theta`` and lengths times
    ``length_scale``; interface forces ``(t, n, m)`` (of the plus block on the minus block, the
    structure's orientation) with ``t`` times ``mirror``, ``m`` times ``mirror`` and -1 where the
    canonical order swapped minus and plus, in the structure's force and length units.

    Parameters
    ----------
    structure : Structure
        The structure ``result`` solved.
    result : Result
        A result of :func:`blockmpec.solve` on it (with or without a solution).

    Returns
    -------
    dict
        ``velocity`` (n_blocks, 3) and ``forces`` (n_interfaces, 3), NaN where there is none
        (fixed blocks, interfaces between two fixed blocks, a result without that part).
    """
    from blockmpec.operators import assemble

    ops = assemble(structure)
    sol = result.solution
    velocity = np.full((structure.n_blocks, 3), np.nan)
    forces = np.full((len(structure.interfaces), 3), np.nan)
    if sol is not None and sol.u is not None and np.size(sol.u) == 3 * ops.n_free_blocks:
        u = ops.velocities_to_structure(np.asarray(sol.u, float)).reshape(-1, 3)
        u[:, :2] *= ops.length_scale
        velocity[ops.free_blocks] = u
    if sol is not None and sol.x is not None and np.size(sol.x) == 3 * ops.n_interfaces:
        x = ops.forces_to_physical(np.asarray(sol.x, float)).reshape(-1, 3)
        x[:, 0] *= ops.mirror
        x[:, 2] *= ops.mirror * np.where(ops.interface_flipped, -1.0, 1.0)
        forces[ops.interface_ids] = x
    return {"velocity": velocity, "forces": forces}


class _Frame:
    """Structure coordinates -> the drawing's: units of ``metadata["drawing"]`` (metres without one), and
    ``y`` up in a DXF file, down in an SVG file (about the image's height for an image)."""

    def __init__(self, structure, output: str):
        d = structure.metadata.get("drawing", {}) if isinstance(structure.metadata, dict) else {}
        self.format = d.get("format")
        self.scale = float(d.get("scale", 1.0))
        self.flip = output == ".svg"
        self.y_offset = float(d.get("y_offset", 0.0)) if self.flip and d.get("flip_y") else 0.0
        self.insunits = int(d.get("insunits", 0) or 0)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        q = np.asarray(points, float) / self.scale
        if self.flip:
            q = q.copy()
            q[..., 1] = self.y_offset - q[..., 1]
        return q

    def length(self, value: float) -> float:
        return value / self.scale


def _drawn(structure, result, mechanism_amplitude: float, force_length: float) -> dict[str, Any]:
    """What to draw, in structure coordinates: displaced outlines, force segments, points, scales."""
    sol = solution_in_structure_frame(structure, result)
    free = np.flatnonzero(~structure.fixed)
    size = float(np.median(np.hypot(*np.ptp(structure.vertices[free], axis=1).T)))
    centroid = structure.centroid
    v = sol["velocity"]
    displaced = []
    factor = 0.0
    moving = [i for i in free if np.all(np.isfinite(v[i]))]
    if moving:
        reach = np.array([np.hypot(*v[i, :2]) + abs(v[i, 2]) * np.hypot(*(structure.polygon(i) - centroid[i]).T).max()
                          for i in moving])
        if reach.max() > 0:
            factor = mechanism_amplitude * size / reach.max()
            for i, r in zip(moving, reach):
                if r <= 1e-6 * reach.max():
                    continue
                a = factor * v[i, 2]
                rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
                displaced.append((int(i), centroid[i] + factor * v[i, :2] + (structure.polygon(i) - centroid[i]) @ rot.T))
    f = sol["forces"]
    itf = structure.interfaces
    segments = []
    force_factor = 0.0
    has = np.flatnonzero(np.all(np.isfinite(f), axis=1))
    if has.size:
        vec = f[has, :1] * itf.tangent[has] + f[has, 1:2] * itf.normal[has]
        magnitude = np.hypot(vec[:, 0], vec[:, 1])
        if magnitude.max() > 0:
            force_factor = force_length * size / magnitude.max()
            for k, fv, mag in zip(has, vec, magnitude):
                if mag <= 1e-9 * magnitude.max():
                    continue
                t, n, m = f[k]
                offset = float(np.clip(m / n, -itf.length[k] / 2, itf.length[k] / 2)) if n != 0 else 0.0
                point = itf.midpoint[k] + offset * itf.tangent[k]
                half = 0.5 * force_factor * fv
                segments.append((int(k), point - half, point + half, point, (float(t), float(n), float(m))))
    extent = float(np.ptp(structure.vertices.reshape(-1, 2), axis=0).max())
    return {"displaced": displaced, "segments": segments, "size": size, "mechanism_factor": factor,
            "force_factor": force_factor, "text_height": 0.015 * extent}


def _note(result, drawn, frame: _Frame) -> str:
    lam = "-" if result.multiplier is None else f"{result.multiplier:.6g}"
    per_unit = frame.length(drawn["force_factor"]) if drawn["force_factor"] else 0.0
    return (f"blockmpec {result.method}: status {result.status.value}, lambda = {lam}; forces: "
            f"{per_unit:.4g} drawing units per unit of force; mechanism x {drawn['mechanism_factor']:.4g}")


def check_export_path(path: str | Path) -> Path:
    """``path`` as a Path, if it can be an export drawing (``.dxf`` or ``.svg`` in an existing folder)."""
    out = Path(path)
    if out.suffix.lower() not in (".dxf", ".svg"):
        raise OptionError(f"export drawing {out}: the file must end in .dxf or .svg")
    if out.is_dir() or not out.parent.is_dir():
        raise OptionError(f"export drawing {out}: {'is a folder' if out.is_dir() else 'its folder does not exist'}")
    return out


def export_drawing(structure, result, path: str | Path, *, source: str | Path | None = None,
                   mechanism_amplitude: float = 0.5, force_length: float = 0.5) -> Path:
    """Draw ``result``'s mechanism and interface forces into a DXF or SVG file (see the module docstring).

    Parameters
    ----------
    structure : Structure
        The structure solved (read from a drawing or not).
    result : Result
        From :func:`blockmpec.solve`.
    path : path ending in ``.dxf`` or ``.svg``
    source : path, optional
        The drawing the structure was read from: the output is a copy of it with the layers added
        (same format), or, for an image and an SVG output, the image under the groups.
    mechanism_amplitude, force_length : float
        Largest displacement and largest force segment, in median stone sizes.

    Returns
    -------
    Path
        The file written.
    """
    out = check_export_path(path)
    kind = out.suffix.lower()
    for name, value in (("mechanism_amplitude", mechanism_amplitude), ("force_length", force_length)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise OptionError(f"{name}: must be a finite number > 0; got {value!r}")
    frame = _Frame(structure, kind)
    drawn = _drawn(structure, result, float(mechanism_amplitude), float(force_length))
    if not drawn["displaced"] and not drawn["segments"]:
        raise OptionError(f"export drawing {out}: the result ({result.method}, status {result.status.value}) has "
                          "neither a mechanism nor interface forces to draw")
    src = None if source is None else Path(source)
    if kind == ".dxf":
        _write_dxf(structure, result, drawn, frame, out, src if src is not None and src.suffix.lower() == ".dxf"
                   else None)
    else:
        _write_svg(structure, result, drawn, frame, out, src)
    return out


def _write_dxf(structure, result, drawn, frame: _Frame, out: Path, source: Path | None) -> None:
    import ezdxf

    if source is not None:
        doc = ezdxf.readfile(source)
    else:
        doc = ezdxf.new("R2010", units=frame.insunits or 6)
    msp = doc.modelspace()
    for name in LAYERS:
        for e in list(msp.query(f'*[layer=="{name}"]')):
            msp.delete_entity(e)
        if name not in doc.layers:
            doc.layers.add(name, color=_DXF_COLOURS[name])
    if source is None:
        for i in range(structure.n_blocks):
            msp.add_lwpolyline(frame(structure.polygon(i)).tolist(), close=True,
                               dxfattribs={"layer": "blockmpec-stones"})
    for _, poly in drawn["displaced"]:
        msp.add_lwpolyline(frame(poly).tolist(), close=True, dxfattribs={"layer": "blockmpec-mechanism"})
    radius = frame.length(0.02 * drawn["size"])
    for _, a, b, point, _ in drawn["segments"]:
        msp.add_line(tuple(frame(a)), tuple(frame(b)), dxfattribs={"layer": "blockmpec-forces"})
        msp.add_circle(tuple(frame(point)), radius, dxfattribs={"layer": "blockmpec-forces"})
    lo = frame(structure.vertices.reshape(-1, 2)).min(axis=0)
    height = frame.length(drawn["text_height"])
    msp.add_text(_note(result, drawn, frame), height=height,
                 dxfattribs={"layer": "blockmpec-notes", "insert": (float(lo[0]), float(lo[1]) - 2 * height)})
    doc.saveas(out)


def _fmt(v: float) -> str:
    return f"{v:.10g}"


def _points(poly: np.ndarray) -> str:
    return " ".join(f"{_fmt(x)},{_fmt(y)}" for x, y in poly)


def _write_svg(structure, result, drawn, frame: _Frame, out: Path, source: Path | None) -> None:
    import xml.etree.ElementTree as ET

    svg_ns = "http://www.w3.org/2000/svg"
    ET.register_namespace("", svg_ns)
    ET.register_namespace("inkscape", "http://www.inkscape.org/namespaces/inkscape")
    ET.register_namespace("sodipodi", "http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd")
    ET.register_namespace("xlink", "http://www.w3.org/1999/xlink")
    q = f"{{{svg_ns}}}"
    stroke = frame.length(0.01 * drawn["size"])
    copy_source = source is not None and source.suffix.lower() == ".svg" and frame.format == "svg"
    if copy_source:
        tree = ET.parse(source)
        root = tree.getroot()
        for g in list(root):
            if g.get("id") in LAYERS:
                root.remove(g)
    else:
        everything = [frame(structure.vertices.reshape(-1, 2))] + [frame(p) for _, p in drawn["displaced"]]
        pts = np.vstack(everything)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = frame.length(drawn["size"])
        lo, hi = lo - pad, hi + pad
        hi[1] += 3 * frame.length(drawn["text_height"])  # the note below the structure
        root = ET.Element(f"{q}svg", {"version": "1.1", "viewBox": f"{_fmt(lo[0])} {_fmt(lo[1])} "
                                      f"{_fmt(hi[0] - lo[0])} {_fmt(hi[1] - lo[1])}"})
        tree = ET.ElementTree(root)
        if source is not None and frame.format == "image" and source.exists():
            d = structure.metadata["drawing"]
            href = os.path.relpath(source.resolve(), out.resolve().parent)
            ET.SubElement(root, f"{q}image", {"href": href, "x": "0", "y": "0", "width": str(d["width_px"]),
                                               "height": str(d["height_px"]), "style": "image-rendering:pixelated"})
        g = ET.SubElement(root, f"{q}g", {"id": "blockmpec-stones", "fill": "none",
                                          "stroke": _SVG_COLOURS["blockmpec-stones"], "stroke-width": _fmt(stroke)})
        for i in range(structure.n_blocks):
            ET.SubElement(g, f"{q}polygon", {"points": _points(frame(structure.polygon(i)))})
    g = ET.SubElement(root, f"{q}g", {"id": "blockmpec-mechanism", "fill": "none",
                                      "stroke": _SVG_COLOURS["blockmpec-mechanism"], "stroke-width": _fmt(stroke)})
    for i, poly in drawn["displaced"]:
        e = ET.SubElement(g, f"{q}polygon", {"points": _points(frame(poly))})
        ET.SubElement(e, f"{q}title").text = f"block {i} displaced"
    g = ET.SubElement(root, f"{q}g", {"id": "blockmpec-forces", "stroke": _SVG_COLOURS["blockmpec-forces"],
                                      "fill": _SVG_COLOURS["blockmpec-forces"], "stroke-width": _fmt(stroke)})
    radius = frame.length(0.02 * drawn["size"])
    for k, a, b, point, (t, n, m) in drawn["segments"]:
        (x1, y1), (x2, y2), (cx, cy) = frame(a), frame(b), frame(point)
        e = ET.SubElement(g, f"{q}line", {"x1": _fmt(x1), "y1": _fmt(y1), "x2": _fmt(x2), "y2": _fmt(y2)})
        ET.SubElement(e, f"{q}title").text = f"interface {k}: t = {t:.6g}, n = {n:.6g}, m = {m:.6g}"
        ET.SubElement(g, f"{q}circle", {"cx": _fmt(cx), "cy": _fmt(cy), "r": _fmt(radius)})
    lo = frame(structure.vertices.reshape(-1, 2))
    height = frame.length(drawn["text_height"])
    y_text = lo[:, 1].max() + 2 * height  # below the structure (y down)
    g = ET.SubElement(root, f"{q}g", {"id": "blockmpec-notes", "fill": _SVG_COLOURS["blockmpec-notes"]})
    text = ET.SubElement(g, f"{q}text", {"x": _fmt(lo[:, 0].min()), "y": _fmt(y_text), "font-size": _fmt(height),
                                         "font-family": "sans-serif"})
    text.text = _note(result, drawn, frame)
    tree.write(out, encoding="utf-8", xml_declaration=True)
