"""Figures of 3D structures and mechanisms (matplotlib's 3D axes), and the mechanism exported as a mesh.

Every figure function takes ``ax=`` (a ``mpl_toolkits.mplot3d`` axes, e.g. ``fig.add_subplot(projection="3d")``)
and returns the axes it drew into; without one it makes a new pyplot figure.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: colours of fixed, resting and moving blocks
FIXED_COLOUR, REST_COLOUR, MOVING_COLOUR = "#b0b0b0", "#f3e3c3", "#e8822a"


def _axes3d(ax=None):
    if ax is not None:
        if getattr(ax, "name", "") != "3d":
            raise TypeError("ax must be a 3D axes: fig.add_subplot(projection='3d')")
        return ax
    import matplotlib.pyplot as plt

    fig = plt.figure(layout="constrained")
    return fig.add_subplot(projection="3d")


def _draw_blocks(ax, polys: list[np.ndarray], faces, colours, alpha=1.0, edge="k", linewidth=0.3) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    tiles, tile_colours = [], []
    for v, fs, col in zip(polys, faces, colours):
        for f in fs:
            tiles.append(np.asarray(v)[np.asarray(f)])
            tile_colours.append(col)
    ax.add_collection3d(Poly3DCollection(tiles, facecolors=tile_colours, edgecolors=edge, linewidths=linewidth,
                                         alpha=alpha))


def _equal_box(ax, points: np.ndarray) -> None:
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo)) or 1.0
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")


def structure_3d(structure, *, ax=None, title: str | None = None):
    """Draw a 3D structure: fixed blocks grey, the others sand; returns the axes."""
    ax = _axes3d(ax)
    colours = [FIXED_COLOUR if f else REST_COLOUR for f in structure.fixed]
    _draw_blocks(ax, list(structure.vertices), structure.faces, colours)
    _equal_box(ax, np.vstack(structure.vertices))
    ax.set_title(title if title is not None else f"{structure.name}: {structure.n_blocks} blocks")
    return ax


def _mechanism(result: Any):
    frame = result if hasattr(result, "columns") else result.mechanism
    return frame


def displaced_vertices(result: Any, structure, amplitude: float = 0.12) -> tuple[list[np.ndarray], float]:
    """Each block's vertices moved along the mechanism, the largest motion ``amplitude`` times the structure's size.

    A block moves rigidly: it turns by the angle ``s |w|`` about the axis ``w`` through its centroid (Rodrigues'
    formula) and translates by ``s u`` (``u`` its centroid velocity, ``w`` its angular velocity, ``s`` the scale
    that gives the largest vertex motion ``amplitude`` times the structure's bounding-box diagonal); fixed and
    resting blocks stay.

    Returns
    -------
    vertices : list of ndarray
        Per block, its moved vertices.
    scale : float
        ``s``.
    """
    frame = _mechanism(result)
    verts = [np.asarray(v, float) for v in structure.vertices]
    if len(frame) == 0:
        return verts, 0.0
    centroid = structure.centroid
    u = np.zeros((structure.n_blocks, 3))
    w = np.zeros((structure.n_blocks, 3))
    blocks = frame["block"].to_numpy()
    u[blocks] = frame[["u_x", "u_y", "u_z"]].to_numpy()
    w[blocks] = frame[["rotation_x", "rotation_y", "rotation_z"]].to_numpy()
    speed = max((float(np.max(np.linalg.norm(u[i] + np.cross(w[i], v - centroid[i]), axis=1))) for i, v in
                 enumerate(verts)), default=0.0)
    allv = np.vstack(verts)
    size = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0)))
    s = amplitude * size / speed if speed > 0 else 0.0
    out = []
    for i, v in enumerate(verts):
        angle = s * float(np.linalg.norm(w[i]))
        r = v - centroid[i]
        if angle > 0:
            k = w[i] / np.linalg.norm(w[i])
            r = r * np.cos(angle) + np.cross(k, r) * np.sin(angle) + np.outer(r @ k, k) * (1 - np.cos(angle))
        out.append(centroid[i] + r + s * u[i])
    return out, s


def mechanism(result: Any, structure, *, ax=None, amplitude: float = 0.12, show_rest: bool = True,
              title: str | None = None):
    """Draw a 3D collapse mechanism: the blocks moved along it (moving blocks orange, resting ones sand, fixed
    ones grey), the structure at rest as faint outlines, and an arrow for the live load; returns the axes.

    Parameters
    ----------
    result : Result or pandas.DataFrame
        A 3D result with a mechanism, or its :attr:`~blockmpec.Result.mechanism` frame.
    structure : Structure3D
    ax : 3D axes, optional
    amplitude : float
        Largest displacement drawn, as a fraction of the structure's size.
    """
    ax = _axes3d(ax)
    frame = _mechanism(result)
    moved, _ = displaced_vertices(frame, structure, amplitude)
    moving = np.zeros(structure.n_blocks, bool)
    if len(frame):
        speed = np.hypot(np.linalg.norm(frame[["u_x", "u_y", "u_z"]].to_numpy(), axis=1),
                         np.linalg.norm(frame[["rotation_x", "rotation_y", "rotation_z"]].to_numpy(), axis=1))
        moving[frame["block"].to_numpy()[speed > 1e-6 * max(float(speed.max()), 1e-300)]] = True
    colours = [FIXED_COLOUR if f else MOVING_COLOUR if m else REST_COLOUR for f, m in zip(structure.fixed, moving)]
    if show_rest:
        _draw_blocks(ax, list(structure.vertices), structure.faces, ["none"] * structure.n_blocks, alpha=0.3,
                     edge="0.5", linewidth=0.2)
    _draw_blocks(ax, moved, structure.faces, colours, alpha=0.95)
    allv = np.vstack(list(structure.vertices) + moved)
    _equal_box(ax, allv)
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    d = np.asarray(structure.live_direction, float)
    start = np.array([lo[0], lo[1], hi[2]]) - 0.15 * (hi - lo).max() * d
    ax.quiver(*start, *(0.12 * (hi - lo).max() * d), color="tab:blue", linewidth=2)
    lam = getattr(result, "multiplier", None)
    ax.set_title(title if title is not None else
                 f"{structure.name}: mechanism" + (f", lambda = {lam:.5g}" if lam is not None else ""))
    return ax


def export_mechanism(result: Any, structure, path, amplitude: float = 0.12) -> None:
    """Write the blocks moved along the mechanism (:func:`displaced_vertices`) as a mesh: OBJ (one object per block,
    named by its id), or STL/PLY (one mesh, by trimesh) by the file's suffix."""
    from pathlib import Path

    from blockmpec.errors import OptionError
    from blockmpec.three_d.meshes import save_obj

    p = Path(path)
    moved, _ = displaced_vertices(result, structure, amplitude)
    suffix = p.suffix.lower()
    if suffix == ".obj":
        save_obj(structure, p, moved)
        return
    if suffix not in (".stl", ".ply"):
        raise OptionError(f"{p}: the mechanism is written as .obj, .stl or .ply; got {p.suffix or 'no suffix'!r}")
    import trimesh

    tris, verts, offset = [], [], 0
    for v, fs in zip(moved, structure.faces):
        verts.append(v)
        tris += [(offset + f[0], offset + f[j], offset + f[j + 1]) for f in fs for j in range(1, len(f) - 1)]
        offset += len(v)
    trimesh.Trimesh(np.vstack(verts), np.asarray(tris), process=False).export(str(p))
