"""The same structure in another frame, order or units: what no method's answer may depend on.

Each function returns a new, validated :class:`~blockmpec.geometry.Structure` holding exactly the transformed data
of ``structure`` (blocks, interfaces as given, point loads, live load), built through its structure-file form
(:func:`blockmpec.structure_to_dict`).  The collapse multiplier of the result is that of ``structure``; its forces
and mechanism are the transformed ones.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from blockmpec.geometry import Structure
from blockmpec.structure_file import structure_from_dict, structure_to_dict


def _mapped(structure: Structure, point: Callable[[list[float]], list[float]], note: str) -> dict[str, Any]:
    """The structure-file form of ``structure`` with every vertex, interface end and load point mapped by ``point``."""
    data = structure_to_dict(structure)
    for block in data["blocks"]:
        block["vertices"] = [point(v) for v in block["vertices"]]
    for interface in data["interfaces"]:
        interface["start"], interface["end"] = point(interface["start"]), point(interface["end"])
    for load in data["point_loads"]:
        load["point"] = point(load["point"])
    data["metadata"] = {"transformed_from": structure.name, "transform": note}
    return data


def translated(structure: Structure, dx: float, dy: float) -> Structure:
    """``structure`` moved by ``(dx, dy)`` (choose offsets that keep its coordinates exact, e.g. powers of two)."""
    return structure_from_dict(_mapped(structure, lambda p: [p[0] + dx, p[1] + dy], f"translated by ({dx}, {dy})"))


def mirrored(structure: Structure) -> Structure:
    """The mirror image ``x -> -x`` of ``structure``, its live load reversed: the same problem seen from behind.

    Vertices are listed in reverse (to stay counter-clockwise) and each interface's ends swapped (so that its normal
    still points from its minus into its plus block); point-load forces are mirrored too."""
    data = _mapped(structure, lambda p: [-p[0], p[1]], "mirrored x -> -x")
    for block in data["blocks"]:
        block["vertices"].reverse()
    for interface in data["interfaces"]:
        interface["start"], interface["end"] = interface["end"], interface["start"]
    for load in data["point_loads"]:
        load["force"] = [-load["force"][0], load["force"][1]]
    data["live_load"]["direction"] = -data["live_load"]["direction"]
    return structure_from_dict(data)


def reordered(structure: Structure, order: Sequence[int] | None = None) -> Structure:
    """``structure`` with its blocks listed in ``order`` (new block ``i`` is old block ``order[i]``; default: the
    reverse order) and its interfaces in the reverse order."""
    n = structure.n_blocks
    order = list(range(n))[::-1] if order is None else [int(i) for i in order]
    if sorted(order) != list(range(n)):
        raise ValueError(f"order must be a permutation of 0 ... {n - 1}; got {order}")
    new = {old: i for i, old in enumerate(order)}
    data = structure_to_dict(structure)
    data["blocks"] = [data["blocks"][old] for old in order]
    data["interfaces"] = [{**itf, "minus": new[itf["minus"]], "plus": new[itf["plus"]]}
                          for itf in reversed(data["interfaces"])]
    data["point_loads"] = [{**load, "block": new[load["block"]]} for load in data["point_loads"]]
    data["metadata"] = {"transformed_from": structure.name, "transform": f"blocks in the order {order}"}
    return structure_from_dict(data)


def rescaled(structure: Structure, length: float, density: float) -> Structure:
    """``structure`` in other units: lengths times ``length``, densities times ``density``, point-load forces times
    ``density * length**2`` (as the weights).  Forces of the result scale by ``density * length**2``, moments by
    ``density * length**3``; the multiplier does not change."""
    data = _mapped(structure, lambda p: [p[0] * length, p[1] * length],
                   f"lengths x {length:g}, densities x {density:g}")
    for block in data["blocks"]:
        block["density"] = block["density"] * density
    for load in data["point_loads"]:
        load["force"] = [f * density * length**2 for f in load["force"]]
    return structure_from_dict(data)
