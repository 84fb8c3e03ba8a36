"""3D structures from files: the JSON 3D structure file and OBJ, STL and PLY meshes.

JSON (``"format": "blockmpec-3d"``, ``"version": 1``)::

    {"format": "blockmpec-3d", "version": 1, "name": "vault",
     "friction": 0.65, "dilatancy": 0.0,                         # tan(phi), tan(psi)
     "live_load": {"direction": [1, 0, 0], "factor": 1.0},       # optional
     "pyramid_sides": 4,                                         # optional
     "blocks": [{"id": "base", "vertices": [[x, y, z], ...], "faces": [[0, 3, 2, 1], ...],
                 "fixed": true, "density": 1.0}, ...]}

Faces list vertex indices counter-clockwise seen from outside.  ``id`` (default: the block's position),
``fixed`` (default false) and ``density`` (default 1) are optional.

Meshes (``z`` up): in an OBJ file each object ``o`` (or, without objects, each group ``g``) is a block, and the
blocks named ``fixed`` (``fixed_names``, matched as whole names or name prefixes such as ``fixed.001``) are
supports; a file without objects or groups is one mesh.  STL and PLY files hold one mesh (read by trimesh, their
duplicate vertices merged).  One mesh is split into its connected components, one block each; the supports are
then the blocks whose lowest point is the lowest of the structure.  The live load's direction is a 3-vector
(``live_direction``, default ``+x``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blockmpec.errors import OptionError, StructureFileError
from blockmpec.geometry import DEFAULT_FRICTION
from blockmpec.three_d.geometry import Structure3D, make_structure_3d

FORMAT_3D = "blockmpec-3d"
MESH_SUFFIXES = (".obj", ".stl", ".ply")
_TOP = {"format", "version", "name", "friction", "dilatancy", "live_load", "pyramid_sides", "blocks", "metadata"}
_BLOCK = {"id", "vertices", "faces", "fixed", "density"}


def is_3d_file(path: str | Path) -> bool:
    """Whether ``path`` is a mesh, or a JSON file whose ``format`` is ``blockmpec-3d``."""
    p = Path(path)
    if p.suffix.lower() in MESH_SUFFIXES:
        return True
    if p.suffix.lower() != ".json" or not p.is_file():
        return False
    try:
        return json.loads(p.read_text()).get("format") == FORMAT_3D
    except (ValueError, AttributeError, OSError):
        return False


def structure_3d_to_dict(s: Structure3D) -> dict:
    """A structure as the JSON-ready dict of a 3D structure file."""
    return {
        "format": FORMAT_3D, "version": 1, "name": s.name, "friction": s.friction, "dilatancy": s.dilatancy,
        "live_load": {"direction": [float(v) for v in s.live_direction], "factor": s.live_factor},
        "pyramid_sides": s.pyramid_sides,
        "blocks": [{"id": bid, "vertices": v.tolist(), "faces": [f.tolist() for f in fs], "fixed": bool(fx),
                    "density": float(d)}
                   for bid, v, fs, fx, d in zip(s.block_ids, s.vertices, s.faces, s.fixed, s.density)],
    }


def save_structure_3d(s: Structure3D, path: str | Path) -> None:
    """Write a 3D structure file."""
    Path(path).write_text(json.dumps(structure_3d_to_dict(s), indent=1))


def _field(data: dict, key: str, kind, source: str, default=None):
    value = data.get(key, default)
    if kind is float and (isinstance(value, bool) or not isinstance(value, (int, float))):
        raise StructureFileError(f"{source}: {key} must be a number; got {json.dumps(value)}")
    return value


def structure_3d_from_dict(data, source: str = "structure file") -> Structure3D:
    """A validated :class:`Structure3D` from the dict of a 3D structure file (errors name the field or block)."""
    if not isinstance(data, dict):
        raise StructureFileError(f"{source}: expected a JSON object at the top level")
    unknown = sorted(set(data) - _TOP)
    if unknown:
        raise StructureFileError(f"{source}: unknown field {unknown[0]!r}; valid fields: {', '.join(sorted(_TOP))}")
    if data.get("format") != FORMAT_3D:
        raise StructureFileError(f"{source}: format must be {FORMAT_3D!r}; got {json.dumps(data.get('format'))}")
    if data.get("version", 1) != 1:
        raise StructureFileError(f"{source}: version must be 1; got {json.dumps(data.get('version'))}")
    friction = _field(data, "friction", float, source)
    dilatancy = _field(data, "dilatancy", float, source, 0.0)
    live = data.get("live_load", {})
    if not isinstance(live, dict) or set(live) - {"direction", "factor"}:
        raise StructureFileError(f"{source}: live_load must be an object with direction and factor")
    blocks = data.get("blocks")
    if not isinstance(blocks, list) or not blocks:
        raise StructureFileError(f"{source}: blocks must be a non-empty list")
    geometry, fixed, density, ids = [], [], [], []
    for i, blk in enumerate(blocks):
        where = f"{source}: blocks[{i}]"
        if not isinstance(blk, dict):
            raise StructureFileError(f"{where} must be an object with vertices and faces")
        bad = sorted(set(blk) - _BLOCK)
        if bad:
            raise StructureFileError(f"{where}: unknown field {bad[0]!r}; valid fields: {', '.join(sorted(_BLOCK))}")
        if "vertices" not in blk or "faces" not in blk:
            raise StructureFileError(f"{where}: needs vertices and faces")
        if not isinstance(blk.get("fixed", False), bool):
            raise StructureFileError(f"{where}: fixed must be true or false")
        geometry.append((blk["vertices"], blk["faces"]))
        fixed.append(blk.get("fixed", False))
        density.append(_field(blk, "density", float, where, 1.0))
        ids.append(str(blk.get("id", i)))
    if len(set(ids)) != len(ids):
        dup = next(x for x in ids if ids.count(x) > 1)
        raise StructureFileError(f"{source}: block id {dup!r} is used twice")
    return make_structure_3d(geometry, fixed, friction=friction, dilatancy=dilatancy, density=density,
                             live_direction=live.get("direction", (1.0, 0.0, 0.0)),
                             live_factor=live.get("factor", 1.0), pyramid_sides=data.get("pyramid_sides", 4),
                             block_ids=ids, name=str(data.get("name", "structure")), metadata=data.get("metadata"))


def load_structure_3d(path: str | Path) -> Structure3D:
    """Read a 3D structure file (JSON)."""
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except OSError as exc:
        raise StructureFileError(f"{p}: cannot be read ({exc.strerror})") from None
    except ValueError as exc:
        raise StructureFileError(f"{p}: not valid JSON ({exc})") from None
    return structure_3d_from_dict(data, str(p))


# --------------------------------------------------------------------------- meshes


def _obj_blocks(path: Path) -> list[tuple[str, np.ndarray, list]]:
    """``(name, vertices, faces)`` per object (or group) of an OBJ file; faces index the block's own vertices."""
    vertices, parts, current = [], {}, None
    use_groups = None
    with path.open() as fh:
        lines = fh.read().splitlines()
    if any(line.startswith("o ") for line in lines):
        use_groups = False
    elif any(line.startswith("g ") for line in lines):
        use_groups = True
    for number, line in enumerate(lines, 1):
        tokens = line.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        tag = tokens[0]
        if tag == "v":
            try:
                vertices.append([float(t) for t in tokens[1:4]])
            except ValueError:
                raise StructureFileError(f"{path}:{number}: a vertex needs three numbers; got {line!r}") from None
        elif (tag == "o" and use_groups is False) or (tag == "g" and use_groups):
            current = " ".join(tokens[1:]) or f"block{len(parts)}"
            parts.setdefault(current, [])
        elif tag == "f":
            try:
                face = [int(t.split("/")[0]) for t in tokens[1:]]
            except ValueError:
                raise StructureFileError(f"{path}:{number}: a face lists vertex numbers; got {line!r}") from None
            face = [i - 1 if i > 0 else len(vertices) + i for i in face]
            parts.setdefault(current if current is not None else path.stem, []).append(face)
    if not vertices:
        raise StructureFileError(f"{path}: no vertex (v) in the file")
    verts = np.asarray(vertices, float)
    out = []
    for name, faces in parts.items():
        if not faces:
            continue
        used = np.unique(np.concatenate([np.asarray(f) for f in faces]))
        if used.min() < 0 or used.max() >= len(verts):
            raise StructureFileError(f"{path}: block {name!r} refers to a vertex that does not exist")
        remap = -np.ones(len(verts), int)
        remap[used] = np.arange(used.size)
        out.append((name, verts[used], [remap[np.asarray(f)].tolist() for f in faces]))
    return out


def _merged_components(vertices: np.ndarray, faces: np.ndarray) -> list[tuple[np.ndarray, list]]:
    """A triangle mesh split into its connected components (trimesh), each with its own vertices."""
    import trimesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=True)
    parts = mesh.split(only_watertight=False)
    return [(np.asarray(p.vertices, float), np.asarray(p.faces, int).tolist()) for p in parts]


def read_mesh(path: str | Path, *, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0, density: float = 1.0,
              live_direction=(1.0, 0.0, 0.0), live_factor: float = 1.0, pyramid_sides: int = 4,
              fixed_names=("fixed",), scale: float = 1.0) -> Structure3D:
    """A 3D structure from an OBJ, STL or PLY mesh (see the module docstring).

    Parameters
    ----------
    mu, dilatancy : float
        ``tan(phi)`` and ``tan(psi)``.
    density : float
        Weight per unit volume of every block.
    live_direction : 3-vector
        Direction of the live body force (default ``+x``).
    fixed_names : sequence of str
        OBJ object (or group) names of the supports.
    scale : float
        Length unit of the file in the structure's units (e.g. 0.001 for a file in mm read in m).
    """
    p = Path(path)
    if not p.is_file():
        raise OptionError(f"{p}: no such file")
    suffix = p.suffix.lower()
    if isinstance(fixed_names, str):
        fixed_names = (fixed_names,)
    names = None
    if suffix == ".obj":
        found = _obj_blocks(p)
        if len(found) > 1:
            names = [name for name, _, _ in found]
            blocks = [(v * scale, f) for _, v, f in found]
        else:
            _, v, f = found[0]
            blocks = _triangulated_components(v * scale, f)
    elif suffix in (".stl", ".ply"):
        import trimesh

        try:
            mesh = trimesh.load_mesh(str(p), process=False)
        except Exception as exc:  # a backend's parse error, whatever its type
            raise StructureFileError(f"{p}: cannot be read as a mesh ({type(exc).__name__}: {exc})") from None
        blocks = _merged_components(np.asarray(mesh.vertices, float) * scale, np.asarray(mesh.faces, int))
    else:
        raise OptionError(f"{p}: not a mesh file ({', '.join(MESH_SUFFIXES)})")
    if names is not None:
        fixed = [any(n == f or n.startswith(f + ".") or n.startswith(f + "_") for f in fixed_names) for n in names]
    else:
        lowest = np.array([v[:, 2].min() for v, _ in blocks])
        size = max(float(np.ptp(np.vstack([v for v, _ in blocks]), axis=0).max()), 1e-300)
        fixed = list(lowest <= lowest.min() + 1e-6 * size)
        names = [f"{p.stem}{i}" for i in range(len(blocks))]
    return make_structure_3d(blocks, fixed, friction=mu, dilatancy=dilatancy, density=density,
                             live_direction=live_direction, live_factor=live_factor, pyramid_sides=pyramid_sides,
                             block_ids=names, name=p.stem)


def _triangulated_components(vertices: np.ndarray, faces: list) -> list[tuple[np.ndarray, list]]:
    """One OBJ mesh split into connected components: polygons fanned into triangles first."""
    tris = [(f[0], f[j], f[j + 1]) for f in faces for j in range(1, len(f) - 1)]
    return _merged_components(vertices, np.asarray(tris, int))


def save_obj(s: Structure3D, path: str | Path, vertices: list[np.ndarray] | None = None) -> None:
    """Write the blocks as an OBJ file, one object per block named by its id (``vertices``: other positions of the
    blocks' vertices, e.g. moved along a mechanism)."""
    lines, offset = [f"# {s.name}: {s.n_blocks} blocks (blockmpec)"], 1
    for i, (bid, v, faces) in enumerate(zip(s.block_ids, s.vertices if vertices is None else vertices, s.faces)):
        lines.append(f"o {'fixed' if s.fixed[i] and bid == 'fixed' else bid}")
        lines += [f"v {x:.12g} {y:.12g} {z:.12g}" for x, y, z in np.asarray(v, float)]
        lines += ["f " + " ".join(str(int(k) + offset) for k in f) for f in faces]
        offset += len(v)
    Path(path).write_text("\n".join(lines) + "\n")


#: ``-p`` keys of a mesh (:func:`read_mesh`) and of a 3D structure file
MESH_PARAMETERS = ("mu", "dilatancy", "density", "live_direction", "live_factor", "pyramid_sides", "fixed_names",
                   "scale")
FILE_PARAMETERS = ("mu", "dilatancy", "live_direction", "live_factor", "pyramid_sides")


def read_3d_file(path: str | Path, params: dict) -> Structure3D:
    """A mesh or a 3D structure file with the command line's ``-p`` parameters applied (bad keys: OptionError)."""
    p = Path(path)
    mesh = p.suffix.lower() in MESH_SUFFIXES
    allowed = MESH_PARAMETERS if mesh else FILE_PARAMETERS
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise OptionError(f"{p}: no parameter {unknown[0]!r}; valid parameters: {', '.join(allowed)}")
    if mesh:
        return read_mesh(p, **params)
    s = load_structure_3d(p)
    s = s.with_material(params.get("mu"), params.get("dilatancy"))
    return s.with_loads(params.get("live_direction"), params.get("live_factor"), params.get("pyramid_sides"))
