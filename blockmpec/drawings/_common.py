"""What the readers share: stones with the names of their entities, options, and the structure build.

A reader turns a file into :class:`Stone` s (vertices in the structure's frame: metres, ``y`` up)
and hands them to :func:`build_structure`, which orients them, checks that there is a support,
builds the structure with :func:`blockmpec.make_structure` (snapping included) and turns the
block numbers of any error into the names of the entities (a DXF handle and layer, an SVG id,
an image label), so that a bad drawing gets one line naming what to fix in the drawing.
"""

from __future__ import annotations

import inspect
import math
import re
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from blockmpec.errors import BlockmpecError, OptionError, StructureError
from blockmpec.geometry import Structure, make_structure

#: Default relative snapping distance of drawings: edges of different stones closer than this
#: fraction of the median stone size are made to coincide (see blockmpec.geometry.snap_polygons).
DEFAULT_SNAP = 1e-3

#: Metres per unit of the ``units`` option.
LENGTH_UNITS = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001, "km": 1000.0, "in": 0.0254, "ft": 0.3048}


#: A drawing without a length unit "looks like millimetres" when its median stone size (square root
#: of the median stone area), read as metres, is at least this: masonry stones are 0.05 - 2 m across,
#: so 20 "m" is a stone of 20 mm or more drawn in millimetres (or of 20 cm or more in centimetres).
MM_LIKE_SIZE = 20.0


class DrawingWarning(UserWarning):
    """A drawing read in a way its author may not mean: no length unit, and stones that look like millimetres."""


@dataclass
class Reading:
    """What a reader read and left out, for the summary line of :func:`build_structure`.

    ``skipped`` counts what was left out by kind (``"TEXT"``, ``"LINE"``, ``"<text>"``,
    ``"LWPOLYLINE on layers not read"``); ``joined`` the segments joined into stones, by kind;
    ``unit_missing``, when the drawing gives no length unit and none was given, is ``(how it was
    read, what to do)`` for the warning of :func:`unit_warning` (None: the unit is known).
    """

    skipped: Counter = field(default_factory=Counter)
    joined: Counter = field(default_factory=Counter)
    unit_missing: tuple[str, str] | None = None


def _counts(counter: Counter) -> str:
    return ", ".join(f"{n} {kind}" for kind, n in sorted(counter.items(), key=lambda kv: (-kv[1], kv[0])))


def summary_line(stones: list, reading: Reading) -> str:
    """``read 42 stones and 1 support (3 joined from 12 LINE); skipped 3 TEXT, 2 LINE``."""
    free = sum(not s.fixed for s in stones)
    fixed = len(stones) - free
    line = f"read {free} stone{'s' * (free != 1)} and {fixed} support{'s' * (fixed != 1)}"
    loops = sum(s.name.startswith("loop of ") for s in stones)
    if loops:
        line += f" ({loops} joined from {_counts(reading.joined)})"
    return line + (f"; skipped {_counts(reading.skipped)}" if reading.skipped else "; skipped nothing")


def unit_warning(stones: list, reading: Reading, source: str) -> str | None:
    """The warning for a drawing without a length unit whose stones look like millimetres (see
    :data:`MM_LIKE_SIZE`), or None."""
    if reading.unit_missing is None or not stones:
        return None
    size = math.sqrt(float(np.median([polygon_area(s.vertices) for s in stones])))
    if size < MM_LIKE_SIZE:
        return None
    how, advice = reading.unit_missing
    return f"{source}: {how}, its stones are {size:.3g} m across (median); {advice}"


def polygon_area(p: np.ndarray) -> float:
    """The area of a simple polygon (shoelace, either orientation)."""
    q = np.asarray(p, float) - p[0]
    r = np.roll(q, -1, axis=0)
    return abs(float((q[:, 0] * r[:, 1] - r[:, 0] * q[:, 1]).sum())) / 2


@dataclass
class Stone:
    """One closed outline of a drawing: its vertices (structure frame), whether it is a support, its name."""

    vertices: np.ndarray
    fixed: bool
    name: str


def scale_option(units: str | None, scale: float | None, default: float, source: str) -> float:
    """Metres per drawing unit: ``scale`` if given, else ``units``, else ``default`` (from the file)."""
    if scale is not None:
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not (math.isfinite(scale) and scale > 0):
            raise OptionError(f"scale: must be a finite number > 0 (metres per drawing unit); got {scale!r}")
        return float(scale)
    if units is not None:
        if units not in LENGTH_UNITS:
            raise OptionError(f"units: must be one of {', '.join(LENGTH_UNITS)}; got {units!r}")
        return LENGTH_UNITS[units]
    return default


def check_common(mu: Any, dilatancy: Any, density: Any, live_direction: Any, snap: Any) -> None:
    """Types and ranges of the options every reader takes (one line naming the option)."""
    for name, value in (("mu", mu), ("dilatancy", dilatancy), ("density", density), ("snap", snap)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise OptionError(f"{name}: expected a finite number; got {value!r}")
    if density <= 0:
        raise OptionError(f"density: must be > 0 (weight per unit area); got {density!r}")
    if snap < 0:
        raise OptionError(f"snap: must be >= 0 (a fraction of the median stone size; 0 = no snapping); got {snap!r}")
    if live_direction not in (1, -1) or isinstance(live_direction, bool):
        raise OptionError(f"live_direction: must be 1 (towards +x) or -1 (towards -x); got {live_direction!r}")


def clean_outline(points: np.ndarray) -> np.ndarray:
    """An outline without its closing point and without repeated consecutive points."""
    p = np.asarray(points, float).reshape(-1, 2)
    if p.shape[0] > 1 and np.array_equal(p[0], p[-1]):
        p = p[:-1]
    keep = np.any(p != np.roll(p, 1, axis=0), axis=1)
    return p[keep] if keep.any() else p[:1]


def closing_gap(points: np.ndarray) -> float:
    """Distance between the first and the last point of an outline."""
    p = np.asarray(points, float).reshape(-1, 2)
    return float(np.hypot(*(p[-1] - p[0])))


def counter_clockwise(p: np.ndarray) -> np.ndarray:
    """``p`` in counter-clockwise order (shoelace sign, relative to its first vertex)."""
    q = p - p[0]
    r = np.roll(q, -1, axis=0)
    return p if (q[:, 0] * r[:, 1] - r[:, 0] * q[:, 1]).sum() >= 0 else p[::-1].copy()


def _with_names(message: str, names: list[str]) -> str:
    """``message`` of the geometry checks with block numbers replaced by the entities' names."""
    def name(i: str) -> str:
        k = int(i)
        return names[k] if 0 <= k < len(names) else f"block {k}"

    message = re.sub(r"\bblocks (\d+) and (\d+)\b", lambda m: f"{name(m.group(1))} and {name(m.group(2))}", message)
    message = re.sub(r"\bblocks \[([\d, ]+)\]",
                     lambda m: "stones " + ", ".join(name(i) for i in m.group(1).split(",") if i.strip()), message)
    message = re.sub(r"\[([\d, ]+)\]((?: and \d+ more \(\d+ in all\))?\))",
                     lambda m: "[" + ", ".join(name(i) for i in m.group(1).split(",") if i.strip()) + "]" + m.group(2),
                     message)
    message = re.sub(r"\b(?:block|its minus block|its plus block) (\d+)\b", lambda m: name(m.group(1)), message)
    return message


def to_file(point: np.ndarray, frame: dict) -> np.ndarray:
    """A point of the structure in the file's coordinates (``frame`` as in ``metadata["drawing"]``)."""
    q = np.asarray(point, float) / float(frame.get("scale", 1.0))
    if frame.get("flip_y"):
        q = np.array([q[0], float(frame.get("y_offset", 0.0)) - q[1]])
    return q + 0.0


def _outside_level() -> int:
    """The ``stacklevel`` of a warning raised here that names the first caller outside blockmpec.drawings."""
    import sys

    level, frame = 2, sys._getframe(2)
    while frame is not None and frame.f_globals.get("__name__", "").startswith("blockmpec.drawings"):
        level, frame = level + 1, frame.f_back
    return level


def _check_outlines(stones: list[Stone], source: str, frame: dict) -> None:
    """Each outline a simple polygon (shapely's validity), else a GeometryError naming the entity and
    the point, in the file's coordinates, where its outline crosses itself."""
    import shapely

    from blockmpec.errors import GeometryError

    for stone in stones:
        if stone.vertices.shape[0] < 3:
            raise GeometryError(f"{source}: {stone.name} has {stone.vertices.shape[0]} distinct vertices; "
                                "a stone needs at least 3")
    polygons = [shapely.Polygon(s.vertices) for s in stones]
    valid = shapely.is_valid(polygons)
    for k in np.flatnonzero(~valid):
        reason = shapely.is_valid_reason(polygons[k])
        found = re.search(r"\[\s*(\S+)\s+(\S+)\s*\]", reason)
        where = ""
        if found:
            x, y = to_file(np.array([float(found.group(1)), float(found.group(2))]), frame)
            where = f" at [{x:.6g}, {y:.6g}]"
        what = "crosses or touches itself" if "elf-intersection" in reason else f"is not a simple polygon ({reason})"
        raise GeometryError(f"{source}: {stones[k].name}: its outline {what}{where}; a stone must be a simple "
                            "polygon")


def build_structure(stones: list[Stone], source: str | Path, *, mu: float, dilatancy: float, density: float,
                    live_direction: int, snap: float, frame: dict, support_hint: str, reading: Reading,
                    name: str | None = None, min_contact: float = 0.0) -> Structure:
    """The structure of ``stones`` (errors name the entities; ``frame`` goes into ``metadata["drawing"]``).

    Parameters
    ----------
    stones : list of Stone
        In the structure's frame (metres, ``y`` up), any orientation.
    source : path
        The file (named in every error).
    frame : dict
        How the structure's coordinates map back to the file's (``scale``: metres per file unit,
        ``flip_y``: whether the file's ``y`` points down, ``format``, ...); the export uses it.
    support_hint : str
        What marks a support in this kind of file (for the "no support" error).
    reading : Reading
        What the reader left out: ``metadata["drawing"]`` gets the summary line (``summary``), its
        counts (``read``) and the warnings (``warnings``, each also a :class:`DrawingWarning`).
    min_contact : float
        Interfaces shorter than this (structure units) are dropped (contacts below an image's
        resolution); their number goes into ``metadata["drawing"]["dropped_contacts"]``.
    """
    source = str(source)
    if not stones:
        raise StructureError(f"{source}: no stone found")
    if not any(s.fixed for s in stones):
        raise StructureError(f"{source}: no support: {support_hint}")
    if all(s.fixed for s in stones):
        raise StructureError(f"{source}: every stone is a support ({support_hint}); nothing can collapse")
    names = [s.name for s in stones]
    _check_outlines(stones, source, frame)
    polygons = [counter_clockwise(s.vertices) for s in stones]
    notes = [w for w in [unit_warning(stones, reading, source)] if w]
    for note in notes:
        warnings.warn(note, DrawingWarning, stacklevel=_outside_level())
    read = {"stones": sum(not s.fixed for s in stones), "supports": sum(s.fixed for s in stones),
            "joined": dict(reading.joined), "skipped": dict(reading.skipped)}
    metadata = {"drawing": {**frame, "source": Path(source).name, "entities": names,
                            "summary": summary_line(stones, reading), "read": read, "warnings": notes}}
    try:
        structure = make_structure(
            polygons, [s.fixed for s in stones], friction=mu, dilatancy=dilatancy, density=density,
            live_direction=live_direction, name=name or Path(source).stem, metadata=metadata, snap=snap,
        )
        if min_contact > 0:
            structure = _without_short_contacts(structure, min_contact)
        return structure
    except BlockmpecError as exc:
        raise type(exc)(f"{source}: {_with_names(str(exc), names)}") from None


def _without_short_contacts(structure: Structure, min_contact: float) -> Structure:
    """``structure`` without its interfaces shorter than ``min_contact``, validated again."""
    from dataclasses import replace

    from blockmpec.geometry import Interfaces, validate

    itf = structure.interfaces
    keep = np.flatnonzero(itf.length >= min_contact)
    dropped = len(itf) - keep.size
    structure.metadata["drawing"]["dropped_contacts"] = int(dropped)
    if dropped == 0:
        return structure
    kept = Interfaces(itf.minus[keep], itf.plus[keep], itf.start[keep], itf.end[keep], itf.friction[keep],
                      itf.dilatancy[keep])
    return validate(replace(structure, interfaces=kept))


def check_options(reader: Callable, options: dict[str, Any], source: str | Path) -> None:
    """Unknown options of ``reader`` are an OptionError listing the valid ones."""
    import difflib

    known = [k for k in inspect.signature(reader).parameters if k != "path"]
    for key in options:
        if key not in known:
            close = difflib.get_close_matches(key, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise OptionError(f"{source}: unknown option {key!r}{hint} (options: {', '.join(known)})")
