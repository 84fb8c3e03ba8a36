"""JSON structure files: load and save losslessly.

Format (``"format": "blockmpec-structure"``, ``"version": 1``)::

    {
      "format": "blockmpec-structure",
      "version": 1,
      "name": "my-wall",                              # optional
      "friction": 0.65,                               # required: tan(phi)
      "dilatancy": 0.0,                               # optional: tan(psi), default 0
      "live_load": {"direction": 1, "factor": 1.0},   # optional: direction (+1/-1) x factor (>= 0) x weight
      "blocks": [                                     # required, >= 1
        {"vertices": [[0, 0], [1, 0], [1, 1], [0, 1]],  # a simple polygon, counter-clockwise
         "fixed": false,                                # optional, default false
         "density": 1.0}                                # optional, default 1
      ],
      "interfaces": [                                 # optional: omitted = detected automatically
        {"minus": 0, "plus": 1, "start": [1, 0], "end": [0, 0],   # normal = rot90(end - start), minus -> plus
         "friction": null, "dilatancy": null}          # optional per-interface overrides
      ],
      "point_loads": [                                # optional; point inside its block or on its boundary
        {"block": 1, "point": [0.5, 1], "force": [0, -2], "kind": "dead"}     # kind "dead" or "live"
      ],
      "metadata": {}                                  # optional, free-form
    }

Blocks may be non-convex (any simple polygon).  ``metadata`` is free-form; blockmpec itself writes
``metadata["snapping"]`` (what :func:`blockmpec.make_structure` with ``snap`` moved: ``snap``,
``distance``, ``largest`` and ``vertices``, a list of ``[block, x_before, y_before, x_after, y_after]``)
and, for a structure read from a drawing, ``metadata["drawing"]`` (the file's ``format``, ``scale``
in metres per drawing unit, ``flip_y``, ``source`` and the ``entities`` the blocks came from), which the
export of results into drawings reads.

Unknown or misspelled keys are errors (with a suggestion), so a typo never
silently falls back to a default.  A negative ``live_load.factor`` is an error:
the sign of the live load is ``direction``.  Every error is one line naming the
file and the field, block, interface or point load (``tests/data/bad_inputs``
holds a corpus of bad files with their errors).  Floats are written with ``repr`` precision,
so load(save(s)) reproduces ``s`` exactly.
"""

from __future__ import annotations

import difflib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from blockmpec.errors import BlockmpecError, StructureFileError
from blockmpec.geometry import Interfaces, PointLoad, Structure, make_structure

FORMAT = "blockmpec-structure"
VERSION = 1

_TOP = {"format", "version", "name", "friction", "dilatancy", "live_load", "blocks", "interfaces", "point_loads", "metadata"}
_BLOCK = {"vertices", "fixed", "density"}
_INTERFACE = {"minus", "plus", "start", "end", "friction", "dilatancy"}
_POINT_LOAD = {"block", "point", "force", "kind"}
_LIVE = {"direction", "factor"}


def _check_keys(obj: Any, allowed: set[str], required: set[str], where: str) -> None:
    if not isinstance(obj, dict):
        raise StructureFileError(f"{where}: expected a JSON object; got {type(obj).__name__}")
    for key in obj:
        if key not in allowed:
            close = difflib.get_close_matches(key, sorted(allowed), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f"; allowed fields: {', '.join(sorted(allowed))}"
            raise StructureFileError(f"{where}: unknown field {key!r}{hint}")
    for key in sorted(required):
        if key not in obj:
            raise StructureFileError(f"{where}: missing required field {key!r}")


def _number(value: Any, where: str, allow_null: bool = False) -> float:
    if value is None and allow_null:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise StructureFileError(f"{where}: expected a number; got {value!r}")
    return float(value)


def _point(value: Any, where: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise StructureFileError(f"{where}: expected [x, y]; got {value!r}")
    return (_number(value[0], where), _number(value[1], where))


def structure_from_dict(data: dict[str, Any], source: str = "structure") -> Structure:
    """Build and validate a structure from the JSON object described in the module docstring."""
    _check_keys(data, _TOP, {"format", "blocks", "friction"}, source)
    if data["format"] != FORMAT:
        raise StructureFileError(f"{source}: field 'format' must be {FORMAT!r}; got {data['format']!r}")
    version = data.get("version", VERSION)
    if version != VERSION:
        raise StructureFileError(f"{source}: unsupported version {version!r}; this blockmpec reads version {VERSION}")
    polygons, fixed, density = _blocks_of(data["blocks"], source)
    live = data.get("live_load", {})
    _check_keys(live, _LIVE, set(), f"{source}: live_load")
    interfaces = _interfaces_of(data["interfaces"], source) if "interfaces" in data else None
    loads = _point_loads_of(data.get("point_loads", []), source)
    direction, factor = _live_load_of(live, source)
    metadata = data.get("metadata", {})
    if not isinstance(metadata, dict):
        raise StructureFileError(f"{source}: field 'metadata' must be an object")
    return make_structure(
        polygons, fixed,
        friction=_number(data["friction"], f"{source}: friction"),
        dilatancy=_number(data.get("dilatancy", 0.0), f"{source}: dilatancy"),
        density=density, interfaces=interfaces, live_direction=direction,
        live_factor=factor,
        point_loads=loads, name=str(data.get("name", "structure")), metadata=metadata,
    )


def _blocks_of(blocks: Any, source: str) -> tuple[list, list, list]:
    """``(polygons, fixed, density)`` of the field ``blocks``."""
    if not isinstance(blocks, list) or not blocks:
        raise StructureFileError(f"{source}: field 'blocks' must be a non-empty list")
    polygons, fixed, density = [], [], []
    for i, blk in enumerate(blocks):
        where = f"{source}: blocks[{i}]"
        _check_keys(blk, _BLOCK, {"vertices"}, where)
        verts = blk["vertices"]
        if not isinstance(verts, list):
            raise StructureFileError(f"{where}.vertices: expected a list of [x, y]; got {verts!r}")
        polygons.append([_point(p, f"{where}.vertices[{j}]") for j, p in enumerate(verts)])
        f = blk.get("fixed", False)
        if not isinstance(f, bool):
            raise StructureFileError(f"{where}.fixed: expected true or false; got {f!r}")
        fixed.append(f)
        density.append(_number(blk.get("density", 1.0), f"{where}.density"))
    return polygons, fixed, density


def _interfaces_of(items: Any, source: str) -> Interfaces:
    """The :class:`Interfaces` of the field ``interfaces``."""
    if not isinstance(items, list):
        raise StructureFileError(f"{source}: field 'interfaces' must be a list")
    cols: dict[str, list] = {k: [] for k in _INTERFACE}
    for k, it in enumerate(items):
        where = f"{source}: interfaces[{k}]"
        _check_keys(it, _INTERFACE, {"minus", "plus", "start", "end"}, where)
        for side in ("minus", "plus"):
            if isinstance(it[side], bool) or not isinstance(it[side], int):
                raise StructureFileError(f"{where}.{side}: expected a block index; got {it[side]!r}")
            cols[side].append(it[side])
        cols["start"].append(_point(it["start"], f"{where}.start"))
        cols["end"].append(_point(it["end"], f"{where}.end"))
        cols["friction"].append(_number(it.get("friction"), f"{where}.friction", allow_null=True))
        cols["dilatancy"].append(_number(it.get("dilatancy"), f"{where}.dilatancy", allow_null=True))
    return Interfaces(
        np.array(cols["minus"], dtype=int), np.array(cols["plus"], dtype=int),
        np.array(cols["start"], dtype=float).reshape(-1, 2), np.array(cols["end"], dtype=float).reshape(-1, 2),
        np.array(cols["friction"], dtype=float), np.array(cols["dilatancy"], dtype=float),
    )


def _point_loads_of(point_loads: Any, source: str) -> list[PointLoad]:
    """The :class:`PointLoad` s of the field ``point_loads``."""
    if not isinstance(point_loads, list):
        raise StructureFileError(f"{source}: field 'point_loads' must be a list")
    loads = []
    for k, pl in enumerate(point_loads):
        where = f"{source}: point_loads[{k}]"
        _check_keys(pl, _POINT_LOAD, {"block", "point", "force"}, where)
        if isinstance(pl["block"], bool) or not isinstance(pl["block"], int):
            raise StructureFileError(f"{where}.block: expected a block index; got {pl['block']!r}")
        kind = pl.get("kind", "dead")
        if kind not in ("dead", "live"):
            raise StructureFileError(f"{where}.kind: expected \"dead\" or \"live\"; got {kind!r}")
        loads.append(PointLoad(pl["block"], _point(pl["point"], f"{where}.point"),
                               _point(pl["force"], f"{where}.force"), kind))
    return loads


def _live_load_of(live: dict, source: str) -> tuple[int, float]:
    """``(direction, factor)`` of the field ``live_load``."""
    direction = live.get("direction", 1)
    if direction not in (1, -1) or isinstance(direction, bool):
        raise StructureFileError(f"{source}: live_load.direction must be 1 or -1; got {direction!r}")
    factor = _number(live.get("factor", 1.0), f"{source}: live_load.factor")
    if not (math.isfinite(factor) and factor >= 0):
        raise StructureFileError(
            f"{source}: live_load.factor must be a finite number >= 0; got {factor!r} "
            "(the sign of the live load is live_load.direction, 1 or -1)"
        )
    return direction, factor


def _opt(v: float) -> float | None:
    return None if math.isnan(v) else float(v)


def structure_to_dict(s: Structure) -> dict[str, Any]:
    """The JSON object of a structure (interfaces written explicitly)."""
    itf = s.interfaces
    return {
        "format": FORMAT,
        "version": VERSION,
        "name": s.name,
        "friction": s.friction,
        "dilatancy": s.dilatancy,
        "live_load": {"direction": s.live_direction, "factor": s.live_factor},
        "blocks": [
            {"vertices": s.polygon(i).tolist(), "fixed": bool(s.fixed[i]), "density": float(s.density[i])}
            for i in range(s.n_blocks)
        ],
        "interfaces": [
            {"minus": int(itf.minus[k]), "plus": int(itf.plus[k]), "start": itf.start[k].tolist(),
             "end": itf.end[k].tolist(), "friction": _opt(itf.friction[k]), "dilatancy": _opt(itf.dilatancy[k])}
            for k in range(len(itf))
        ],
        "point_loads": [
            {"block": pl.block, "point": list(pl.point), "force": list(pl.force), "kind": pl.kind}
            for pl in s.point_loads
        ],
        "metadata": s.metadata,
    }


def load_structure(path: str | Path) -> Structure:
    """Read a structure file; errors name the file and the offending field.  A 3D structure file
    (``"format": "blockmpec-3d"``) gives a :class:`~blockmpec.three_d.Structure3D`
    (:func:`blockmpec.three_d.meshes.load_structure_3d`)."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise StructureFileError(f"{p}: cannot read structure file ({exc.strerror})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise StructureFileError(f"{p}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    if isinstance(data, dict) and data.get("format") == "blockmpec-3d":
        from blockmpec.three_d.meshes import structure_3d_from_dict

        return structure_3d_from_dict(data, source=str(p))
    try:
        return structure_from_dict(data, source=str(p))
    except StructureFileError:
        raise
    except BlockmpecError as exc:
        raise type(exc)(f"{p}: {exc}") from None


def save_structure(s: Structure, path: str | Path) -> None:
    """Write a structure file (a 3D structure file for a :class:`~blockmpec.three_d.Structure3D`)."""
    if getattr(s, "dim", 2) == 3:
        from blockmpec.three_d.meshes import save_structure_3d

        save_structure_3d(s, path)
        return
    Path(path).write_text(json.dumps(structure_to_dict(s), indent=1) + "\n")
