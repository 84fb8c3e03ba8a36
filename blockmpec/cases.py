"""Parametric generators of the reference structures, and the built-in case registry.

Every generator validates its parameters (clear :class:`OptionError` naming the
parameter) and returns a validated :class:`~blockmpec.geometry.Structure`.
Loads are proportional to block area (unit density): dead load = weight,
live load = horizontal body force equal to the weight.
"""

from __future__ import annotations

import inspect
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from blockmpec.errors import BlockmpecError, OptionError, UnknownNameError
from blockmpec.geometry import DEFAULT_FRICTION, Structure, make_structure


def _positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name}: expected a number; got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise OptionError(f"{name}: must be a finite number > 0; got {value!r}")
    return v


def _count(name: str, value: int, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise OptionError(f"{name}: must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _rect(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def single_block(width: float = 1.0, height: float = 2.0, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0) -> Structure:
    """One ``width x height`` block on a fixed base.

    Closed form (associative and non-associative alike): ``lam = min(mu, width/height)``.
    """
    b, h = _positive("width", width), _positive("height", height)
    base = _rect(-b, -0.5 * h, 2 * b, 0.0)
    block = _rect(0.0, 0.0, b, h)
    return make_structure(
        [base, block], [True, False], friction=mu, dilatancy=dilatancy, name="single-block",
        metadata={"case": "single-block", "width": b, "height": h},
    )


def two_blocks(eta: float = 3.0, mu: float = DEFAULT_FRICTION, width: float = 1.0, dilatancy: float = 0.0) -> Structure:
    """The paper's two-block problem: two ``b x h`` blocks side by side on a fixed base.

    ``eta = h / b`` is the slenderness.  Each block carries its weight ``W`` as
    dead load and a horizontal force ``W`` (towards +x) as live load.

    Closed forms: associative ``lam = min(mu, 1/[eta(1-mu^2)+mu], (1+2mu^2)/[eta(1+mu^2)-mu], 2/eta)``
    (rocking terms only where their denominator is positive); non-associative
    minimum ``mu`` if ``mu <= 1/eta`` else ``1/eta``.
    """
    b = _positive("width", width)
    h = _positive("eta", eta) * b
    base = _rect(-b, -0.5 * b, 3 * b, 0.0)
    left = _rect(0.0, 0.0, b, h)
    right = _rect(b, 0.0, 2 * b, h)
    return make_structure(
        [base, left, right], [True, False, False], friction=mu, dilatancy=dilatancy, name="two-blocks",
        metadata={"case": "two-blocks", "eta": float(eta), "width": b},
    )


def _voussoirs(n: int, radius: float, thickness: float, x_centre: float = 0.0, y_centre: float = 0.0) -> list[np.ndarray]:
    """Straight-sided voussoirs of a semicircular arch, from angle 0 (right) to pi (left)."""
    ri, ro = radius - thickness / 2, radius + thickness / 2
    angles = np.linspace(0.0, np.pi, n + 1)
    out = []
    for a0, a1 in zip(angles[:-1], angles[1:]):
        c0, s0, c1, s1 = math.cos(a0), math.sin(a0), math.cos(a1), math.sin(a1)
        poly = np.array([[ri * c0, ri * s0], [ro * c0, ro * s0], [ro * c1, ro * s1], [ri * c1, ri * s1]])
        poly[np.abs(poly) < 1e-15] = 0.0
        out.append(poly + [x_centre, y_centre])
    return out


def round_arch(
    n_voussoirs: int = 10, radius: float = 1.0, thickness: float = 0.15, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0
) -> Structure:
    """Semicircular arch of straight-sided voussoirs on two fixed springings.

    ``radius`` is the centre-line radius.  With the defaults and ``mu = 0.65`` the
    associative collapse multiplier is 0.16034 (the paper's Table 1).
    """
    n = _count("n_voussoirs", n_voussoirs, 2)
    r, t = _positive("radius", radius), _positive("thickness", thickness)
    if t >= 2 * r:
        raise OptionError(f"thickness: must be smaller than twice the radius ({2 * r}); got {t}")
    ri, ro = r - t / 2, r + t / 2
    springs = [_rect(ri, -t, ro, 0.0), _rect(-ro, -t, -ri, 0.0)]
    blocks = springs + _voussoirs(n, r, t)
    fixed = [True, True] + [False] * n
    return make_structure(
        blocks, fixed, friction=mu, dilatancy=dilatancy, name="round-arch",
        metadata={"case": "round-arch", "n_voussoirs": n, "radius": r, "thickness": t},
    )


def arch_on_buttresses(
    n_voussoirs: int = 10,
    radius: float = 1.0,
    thickness: float = 0.15,
    buttress_width: float = 0.5,
    buttress_courses: int = 8,
    mu: float = DEFAULT_FRICTION,
    dilatancy: float = 0.0,
) -> Structure:
    """A round arch springing from two buttresses on a fixed base.

    Each buttress is a column of ``buttress_courses`` blocks of width
    ``buttress_width`` and height ``buttress_width / 2`` (aspect 1:2); its inner
    face is flush with the arch intrados at the springing.  Defaults give 26 free
    blocks.  The paper's exact geometry (its reference [2]) is not given, so the
    multipliers differ from its Table 1.
    """
    n = _count("n_voussoirs", n_voussoirs, 2)
    courses = _count("buttress_courses", buttress_courses)
    r, t = _positive("radius", radius), _positive("thickness", thickness)
    w = _positive("buttress_width", buttress_width)
    if t >= 2 * r:
        raise OptionError(f"thickness: must be smaller than twice the radius ({2 * r}); got {t}")
    ri = r - t / 2
    if w < t:
        raise OptionError(f"buttress_width: must be at least the arch thickness {t}; got {w}")
    h = w / 2
    height = courses * h
    blocks = [_rect(-ri - w - w, -h, ri + w + w, 0.0)]
    for side in (1, -1):
        x_in, x_out = side * ri, side * (ri + w)
        for k in range(courses):
            blocks.append(_rect(min(x_in, x_out), k * h, max(x_in, x_out), (k + 1) * h))
    blocks += _voussoirs(n, r, t, y_centre=height)
    fixed = [True] + [False] * (len(blocks) - 1)
    return make_structure(
        blocks, fixed, friction=mu, dilatancy=dilatancy, name="arch-on-buttresses",
        metadata={"case": "arch-on-buttresses", "n_voussoirs": n, "radius": r, "thickness": t,
                  "buttress_width": w, "buttress_courses": courses},
    )


def wall(
    courses: int = 5,
    blocks_per_course: int = 4,
    bond: str = "running",
    block_length: float = 1.0,
    block_height: float | None = None,
    openings: list | tuple = (),
    mu: float = DEFAULT_FRICTION,
    dilatancy: float = 0.0,
) -> Structure:
    """A masonry wall on a fixed base.

    Parameters
    ----------
    courses, blocks_per_course : int
        Rows of blocks and full blocks per row.
    bond : {"running", "stack"}
        Running bond shifts every other course by half a block, with half blocks
        at both ends (so those courses hold ``blocks_per_course + 1`` blocks).
    block_length, block_height : float
        Block size; height defaults to half the length (aspect 1:2).
    openings : list of (x0, y0, x1, y1)
        Rectangles, in wall coordinates (origin at the bottom-left corner), whose
        blocks are removed: every block with its centroid inside is left out.
    """
    nc, nb = _count("courses", courses), _count("blocks_per_course", blocks_per_course)
    if bond not in ("running", "stack"):
        raise OptionError(f"bond: must be 'running' or 'stack'; got {bond!r}")
    lb = _positive("block_length", block_length)
    hb = lb / 2 if block_height is None else _positive("block_height", block_height)
    total = nb * lb
    holes = []
    for k, o in enumerate(openings):
        try:
            x0, y0, x1, y1 = (float(v) for v in o)
        except (TypeError, ValueError):
            raise OptionError(f"openings[{k}]: expected (x0, y0, x1, y1); got {o!r}") from None
        holes.append((min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)))
    blocks = [_rect(-lb, -hb, total + lb, 0.0)]
    for r in range(nc):
        y0, y1 = r * hb, (r + 1) * hb
        if bond == "running" and r % 2 == 1:
            xs = np.concatenate([[0.0], lb / 2 + lb * np.arange(nb), [total]])
        else:
            xs = lb * np.arange(nb + 1)
        for x0, x1 in zip(xs[:-1], xs[1:]):
            cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            if any(a < cx < c and b < cy < d for a, b, c, d in holes):
                continue
            blocks.append(_rect(x0, y0, x1, y1))
    fixed = [True] + [False] * (len(blocks) - 1)
    return make_structure(
        blocks, fixed, friction=mu, dilatancy=dilatancy, name="wall",
        metadata={"case": "wall", "courses": nc, "blocks_per_course": nb, "bond": bond,
                  "block_length": lb, "block_height": hb, "openings": [list(h) for h in holes]},
    )


#: Ferris & Tin-Loi's six walls as published in MPECLib (``frictionalblock_1`` ... ``_6``): the courses from the
#: bottom up, each a row of ``h`` (half block), ``f`` (full block) and ``_`` (an opening one full block long).
FERRIS_TINLOI_WALLS = {
    1: ("hffffh", "fffff") * 3,
    2: ("hffffh", "fffff") * 5,
    3: ("ffff", "hfffh", "ffff") + ("hf_fh", "fh_hf") * 2 + ("hf_fh", "ffff", "hfffh", "ffff"),
    4: ("hffffh", "fffff", "hffffh") + ("f_f_f", "hh_hh_hh") * 2 + ("f_f_f", "hffffh", "fffff", "hffffh"),
    5: (("hffh", "fff", "hffh") + ("f_f", "hh_hh") * 2 + ("f_f",)) * 2 + ("hffh", "fff", "hffh"),
    6: ("hffffffh", "fffffff") * 2 + ("hf_ff_fh", "fh_hfh_hf") * 2 + ("hf_ff_fh", "fffffff", "hffffffh", "fffffff")
       + ("hf_ff_fh", "fh_hfh_hf") * 2 + ("hf_ff_fh",) + ("fffffff", "hffffffh") * 2,
}


def ferris_tinloi(wall: int = 1, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0) -> Structure:
    """Wall ``wall`` (1-6) of Ferris & Tin-Loi, as published in the MPEC test collection MPECLib.

    M. C. Ferris, F. Tin-Loi, Limit analysis of frictional block assemblies as a mathematical program with
    complementarity constraints, Int. J. Mech. Sci. 43 (2001) 209-224; MPECLib's models ``frictionalblock_1`` ...
    ``frictionalblock_6`` (GAMS-dev/gamsworld, folder MPECLib: the block tables ``fr_block1.dat`` ...
    ``fr_block6.dat`` and the contact generator ``fr_genct.gms``).  Blocks of 0.40 x 0.175 (MPECLib: 4 x 1.75,
    the same multipliers) and half blocks, in running bond on a fixed base, course by course
    (:data:`FERRIS_TINLOI_WALLS`):

    ====  ==========  ==========  ==========  ===================================================
    wall  free blocks  interfaces  courses     layout
    ====  ==========  ==========  ==========  ===================================================
    1     33          83          6           5 full blocks wide (the default)
    2     55          141         10          as wall 1, taller
    3     46          102         11          4 wide, one opening in courses 4-8
    4     55          116         11          5 wide, two openings in courses 4-8 (the seed paper's "2x1 wall")
    5     61          120         19          3 wide, an opening in courses 4-8 and one in 12-16
    6     146         345         21          7 wide, 2 x 2 openings in courses 5-9 and 13-17 (the seed paper's
                                              "2x2 wall")
    ====  ==========  ==========  ==========  ===================================================

    Loads as in :func:`wall`: dead load the weight, live load a horizontal body force equal to the weight.
    The interfaces detected here are MPECLib's contacts one to one (the base counted once per bottom block).
    Associative multipliers at ``mu = 0.65``: 0.6428590033, 0.5799986113, 0.4036941035, 0.3319483952,
    0.2396425252, 0.3478245642 (the seed paper's Table 1 gives 0.33194 and 0.34782 for walls 4 and 6).

    MPECLib's data error: ``fr_genct.gms`` gives the full blocks of the bottom course (its element type ``one``)
    two wrong moment arms, ``elct('one','f3','e1','t') = lx/2`` (the shear on the left face; ``-lx/2`` as for every
    other full block) and ``elct('one','f3','e4','n') = lx/2`` (the normal force on the top-right half; ``lx/4``).
    The GAMS model is then not the equilibrium of any wall: it changes wall 3's associative multiplier from
    0.4036941 to 0.3738285 (the other walls' stay).  The geometry here is the walls' own, so it has the
    correct arms.
    """
    number = _count("wall", wall)
    if number not in FERRIS_TINLOI_WALLS:
        raise OptionError(f"wall: must be one of {', '.join(map(str, FERRIS_TINLOI_WALLS))}; got {wall!r}")
    lb, hb = 0.40, 0.175
    size = {"h": lb / 2, "f": lb, "_": lb}
    courses = FERRIS_TINLOI_WALLS[number]
    total = sum(size[c] for c in courses[0])
    blocks = [_rect(-lb, -hb, total + lb, 0.0)]
    for r, course in enumerate(courses):
        x = 0.0
        for c in course:
            if c != "_":
                blocks.append(_rect(x, r * hb, x + size[c], (r + 1) * hb))
            x += size[c]
    fixed = [True] + [False] * (len(blocks) - 1)
    return make_structure(
        blocks, fixed, friction=mu, dilatancy=dilatancy, name="ferris-tinloi",
        metadata={"case": "ferris-tinloi", "wall": number, "courses": len(courses),
                  "blocks_per_course": round(total / lb), "block_length": lb, "block_height": hb},
    )


# --------------------------------------------------------------------------- irregular stone walls

#: Largest number of stones ``stone-wall`` builds (beyond it, ask for a larger stone_size).
STONE_WALL_MAX_STONES = 1_000_000


def stone_wall(
    width: float = 4.0,
    height: float = 2.0,
    stone_size: float = 0.3,
    irregularity: float = 0.5,
    seed: int = 0,
    mu: float = DEFAULT_FRICTION,
    dilatancy: float = 0.0,
) -> Structure:
    """An irregular stone wall on a fixed base: stones that tile ``width x height`` with shared edges.

    The stones are the cells of a seeded, relaxed Voronoi tessellation of the wall, some merged in
    pairs into non-convex stones.  ``irregularity`` ``r`` in [0, 1] sets how far the wall is from
    regular courses:

    * the tessellation is taken in coordinates stretched vertically by ``a = min(50, 1 + 2 (1 - r) / r)``,
      which flattens the cells into courses (``a = 1`` at ``r = 1``: an isotropic Voronoi diagram);
    * seeds start on a running-bond lattice of stones ``sqrt(2) s x s / sqrt(2)`` (mean area ``s**2``,
      ``s`` the stone size; courses and stones per course rounded to fill the wall exactly), and move
      by ``r`` times a uniform random offset of up to half a lattice cell, vertically divided by
      ``a**2`` (which is how much more the stretch tilts the joints to the neighbours);
    * two Lloyd steps move each seed by ``r`` times the way to its cell's centroid (relaxation);
    * edges shorter than 5 % of the stone size are collapsed (so no sliver of an interface remains);
    * a fraction ``0.2 r / (1 + 0.2 r)`` of the cells is merged pairwise across their longest edge
      (non-convex stones; the lattice is made that much finer, so the mean stone area stays ``s**2``).

    ``r = 0`` gives exact running bond (half stones at the ends of every other course); ``r = 1``
    random rubble.  The same parameters give the same stones bit for bit (numpy's ``default_rng(seed)``
    and Qhull are deterministic).  About ``width * height / stone_size**2`` stones.

    Parameters
    ----------
    width, height : float
        Size of the wall; its bottom-left corner is the origin, the base lies below ``y = 0``.
    stone_size : float
        Mean stone size ``s`` (square root of the mean stone area).
    irregularity : float
        0 (regular courses) ... 1 (random rubble).
    seed : int
        Seed of the random generator.
    mu, dilatancy : float
        ``tan(phi)`` and ``tan(psi)``.
    """
    w, h = _positive("width", width), _positive("height", height)
    size = _positive("stone_size", stone_size)
    try:
        r = float(irregularity)
    except (TypeError, ValueError):
        raise OptionError(f"irregularity: expected a number in [0, 1]; got {irregularity!r}") from None
    if not 0.0 <= r <= 1.0:
        raise OptionError(f"irregularity: must lie in [0, 1] (0 = regular courses, 1 = random rubble); got {irregularity!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise OptionError(f"seed: must be an integer >= 0; got {seed!r}")
    expected = w * h / size**2
    if expected > STONE_WALL_MAX_STONES:
        raise OptionError(f"stone_size: {size} gives about {expected:.3g} stones in a {w} x {h} wall; "
                          f"at most {STONE_WALL_MAX_STONES:,} (give a larger stone_size)")
    stones = _stone_wall_stones(w, h, size, r, int(seed))
    base_height = min(h, size)
    base = _rect(-size, -base_height, w + size, 0.0)
    polygons = [base] + stones
    n_non_convex = sum(1 for p in stones if not _is_convex(p))
    return make_structure(
        polygons, [True] + [False] * len(stones), friction=mu, dilatancy=dilatancy, name="stone-wall",
        metadata={"case": "stone-wall", "width": w, "height": h, "stone_size": size, "irregularity": r,
                  "seed": int(seed), "stones": len(stones), "non_convex_stones": n_non_convex},
    )


def _is_convex(poly: np.ndarray) -> bool:
    e = np.diff(poly, axis=0, append=poly[:1])
    f = np.vstack([e[1:], e[:1]])
    return bool(np.all(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0] >= 0))


def _stone_wall_stones(w: float, h: float, size: float, r: float, seed: int) -> list[np.ndarray]:
    """The stones of :func:`stone_wall` (counter-clockwise vertex arrays), bottom course first."""
    merge_fraction = 0.2 * r
    cell = size / math.sqrt(1.0 + merge_fraction)  # lattice cell side: merging restores the mean area
    courses = max(1, round(h / (cell / math.sqrt(2.0))))
    per_course = max(1, round(w / (cell * math.sqrt(2.0))))
    course_h, stone_l = h / courses, w / per_course
    if r == 0.0:
        stones = []
        for row in range(courses):
            y0, y1 = row * course_h, (row + 1) * course_h
            if row % 2 and per_course > 1:
                xs = np.concatenate([[0.0], stone_l * (np.arange(per_course) + 0.5), [w]])
                xs[-1] = w
            else:
                xs = stone_l * np.arange(per_course + 1)
                xs[-1] = w
            stones += [_rect(x0, y0, x1, y1) for x0, x1 in zip(xs[:-1], xs[1:])]
        return stones
    rng = np.random.default_rng(seed)
    seeds = []
    inset = 0.01 * stone_l  # end seeds of the odd courses: just inside the wall (half stones)
    for row in range(courses):
        y = (row + 0.5) * course_h
        if row % 2 and per_course > 1:
            xs = np.concatenate([[inset], stone_l * np.arange(1, per_course), [w - inset]])
        else:
            xs = stone_l * (np.arange(per_course) + 0.5)
        seeds += [(x, y) for x in xs]
    seeds = np.array(seeds)
    stretch = min(50.0, 1.0 + 2.0 * (1.0 - r) / r)
    # a seed's height offset tilts the joints to its neighbours by ~stretch**2 times as much
    seeds += r * (rng.random(seeds.shape) - 0.5) * [stone_l, course_h / stretch**2]
    margin = np.array([0.01 * stone_l, 0.01 * course_h])
    seeds = np.clip(seeds, margin, [w, h] - margin)
    for _ in range(2):  # Lloyd relaxation, by r of the way
        points, cells = _voronoi_in_rectangle(seeds * [1.0, stretch], w, h * stretch)
        centroid = np.array([_centroid(points[c]) for c in cells]) / [1.0, stretch]
        seeds = np.clip(seeds + r * (centroid - seeds), margin, [w, h] - margin)
    points, cells = _voronoi_in_rectangle(seeds * [1.0, stretch], w, h * stretch)
    top = points[:, 1] == h * stretch
    points = points / [1.0, stretch]
    points[top, 1] = h
    points, cells = _collapse_short_edges(points, cells, 0.05 * size, w, h)
    cells = _merge_pairs(points, cells, merge_fraction / (1.0 + merge_fraction), rng)
    return [points[c] for c in cells]


def _centroid(p: np.ndarray) -> np.ndarray:
    q = np.vstack([p[1:], p[:1]])
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    a = cross.sum() / 2
    return np.array([((p[:, 0] + q[:, 0]) * cross).sum(), ((p[:, 1] + q[:, 1]) * cross).sum()]) / (6 * a)


def _voronoi_in_rectangle(seeds: np.ndarray, w: float, h: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """Voronoi cells of ``seeds`` inside ``[0, w] x [0, h]``: vertices and counter-clockwise vertex-index
    lists, cells in the order of the seeds.

    The seeds are mirrored across the four sides, so the cells of the seeds end exactly on the sides
    and neighbouring cells share vertex indices (no clipping, whose intersections would differ in the
    last bits between the two cells of an edge); vertices within round-off of a side are put on it."""
    from scipy.spatial import Voronoi

    n = seeds.shape[0]
    mirrored = [seeds, seeds * [-1, 1], seeds * [-1, 1] + [2 * w, 0], seeds * [1, -1], seeds * [1, -1] + [0, 2 * h]]
    vor = Voronoi(np.vstack(mirrored))
    points = vor.vertices.copy()
    eps = 1e-9 * max(w, h)
    for axis, side in ((0, 0.0), (0, w), (1, 0.0), (1, h)):
        points[np.abs(points[:, axis] - side) <= eps, axis] = side
    cells = []
    regions, point_region = vor.regions, vor.point_region  # properties: computed on each access
    for i in range(n):
        region = np.array(regions[point_region[i]])
        if region.size < 3 or np.any(region < 0):  # pragma: no cover - mirrored seeds bound every cell
            raise RuntimeError(f"stone-wall: the Voronoi cell of seed {i} is not bounded")
        p = points[region]
        q = np.roll(p, -1, axis=0)
        if (p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]).sum() < 0:
            region = region[::-1]
        cells.append(region)
    return points, cells


def _collapse_short_edges(points: np.ndarray, cells: list[np.ndarray], shortest: float, w: float,
                          h: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """Merge the two ends of every edge shorter than ``shortest`` (in every cell that has them): the
    merged vertex is the mean of the merged ones, kept on a side of the wall that one of them is on."""
    edges = {}
    for c in cells:
        for u, v in zip(c, np.roll(c, -1)):
            edges[(min(u, v), max(u, v))] = None
    pairs = np.array(sorted(edges), dtype=int).reshape(-1, 2)
    length = np.hypot(*(points[pairs[:, 0]] - points[pairs[:, 1]]).T)
    parent = np.arange(points.shape[0])

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for k in np.lexsort((pairs[:, 1], pairs[:, 0], length)):
        if length[k] >= shortest:
            break
        a, b = root(pairs[k, 0]), root(pairs[k, 1])
        if a != b:
            parent[max(a, b)] = min(a, b)
    roots = np.array([root(i) for i in range(points.shape[0])])
    merged = points.copy()
    for g in np.unique(roots[roots != np.arange(points.shape[0])]):
        members = points[roots == g]
        p = members.mean(axis=0)
        for axis, side in ((0, 0.0), (0, w), (1, 0.0), (1, h)):
            if np.any(members[:, axis] == side):
                p[axis] = side
        merged[g] = p
    out = []
    for c in cells:
        ids = roots[c]
        keep = ids != np.roll(ids, 1)
        ids = ids[keep] if keep.any() else ids[:1]
        if ids.size >= 3:
            out.append(ids)
    return merged, out


def _merge_pairs(points: np.ndarray, cells: list[np.ndarray], fraction: float,
                 rng: np.random.Generator) -> list[np.ndarray]:
    """Merge ``fraction`` of the cells pairwise, each with the unmerged neighbour across its longest edge
    (cells visited in a random order); a merge that would not give a simple polygon is skipped."""
    target = int(round(fraction * len(cells)))
    if target == 0:
        return cells
    owner: dict[tuple[int, int], int] = {}
    for k, c in enumerate(cells):
        for u, v in zip(c, np.roll(c, -1)):
            owner[(int(u), int(v))] = k
    merged_into = {}
    out = list(cells)
    done = 0
    for k in rng.permutation(len(cells)):
        if done >= target:
            break
        if k in merged_into:
            continue
        c = cells[k]
        best, best_len = None, 0.0
        for u, v in zip(c, np.roll(c, -1)):
            other = owner.get((int(v), int(u)))
            if other is None or other in merged_into or other == k:
                continue
            length = float(np.hypot(*(points[u] - points[v])))
            if length > best_len:
                best, best_len = (other, int(u), int(v)), length
        if best is None:
            continue
        other, u, v = best
        a, b = list(map(int, c)), list(map(int, cells[other]))
        i, j = a.index(u), b.index(v)
        loop = a[i + 1 :] + a[: i + 1] + (b[j + 1 :] + b[: j + 1])[1:-1]  # v ... u, then u's successors to before v
        if len(set(loop)) != len(loop):
            continue
        out[k] = np.array(loop)
        out[other] = None
        merged_into[k] = merged_into[other] = True
        done += 1
    return [c for c in out if c is not None]


# --------------------------------------------------------------------------- registry


@dataclass(frozen=True)
class CaseSpec:
    """A built-in case: CLI name, generator and its keyword parameters with defaults; ``closed_form(problem,
    **params)``, when given, is the case's known multiplier or None (:func:`closed_form`)."""

    name: str
    generator: Callable[..., Structure]
    summary: str
    closed_form: Callable[..., float | None] | None = None

    @property
    def parameters(self) -> dict[str, Any]:
        """Parameter name -> default value."""
        sig = inspect.signature(self.generator)
        return {k: p.default for k, p in sig.parameters.items()}

    def build(self, **params: Any) -> Structure:
        """Build the case; unknown keys raise OptionError listing the valid ones."""
        known = self.parameters
        unknown = sorted(set(params) - set(known))
        if unknown:
            raise OptionError(
                f"case {self.name!r} has no parameter {unknown[0]!r}; valid parameters: {', '.join(known)}"
            )
        return self.generator(**params)


CASES: dict[str, CaseSpec] = {
    spec.name: spec
    for spec in (
        CaseSpec("two-blocks", two_blocks, "two b x h blocks side by side on a fixed base (paper Sect. 3)"),
        CaseSpec("single-block", single_block, "one block on a fixed base; lam = min(mu, b/h)"),
        CaseSpec("round-arch", round_arch, "semicircular arch on two fixed springings (paper Fig. 7)"),
        CaseSpec("arch-on-buttresses", arch_on_buttresses, "round arch on two block buttresses (paper Fig. 8)"),
        CaseSpec("wall", wall, "running- or stack-bond wall on a fixed base (paper Figs 9-10)"),
        CaseSpec("ferris-tinloi", ferris_tinloi, "Ferris & Tin-Loi's walls 1-6 as in MPECLib (wall=1..6): 33 to 146 "
                 "free blocks of 0.40 x 0.175 in running bond, walls 3-6 with openings"),
        CaseSpec("stone-wall", stone_wall, "irregular stone wall on a fixed base: seeded Voronoi stones, "
                 "irregularity 0 (courses) ... 1 (rubble)"),
    )
}


def closed_form(name: str, problem: str, **params: Any) -> float | None:
    """Closed-form collapse multiplier of a built-in case, where one is known.

    Parameters
    ----------
    name : str
        Case name.
    problem : {"associative", "non-associative"}
        For "non-associative" the value is the *minimum* over solutions of (3)
        (zero dilatancy assumed; None when ``dilatancy`` is not 0).
    **params
        The case's parameters (defaults filled in).

    Returns
    -------
    float or None
        ``None`` when no closed form is known.  For the associative two-block
        problem the paper's formula is returned only where it holds (not for
        ``mu > 1`` with ``eta < 1``; see tests/test_extreme.py).
    """
    spec = get_case(name)
    if spec.closed_form is not None:  # a case registered with its own closed form (the 3D cases)
        return spec.closed_form(problem, **params)
    p = {**spec.parameters, **params}
    if problem not in ("associative", "non-associative"):
        raise OptionError(f"problem: must be 'associative' or 'non-associative'; got {problem!r}")
    mu = float(p["mu"])
    if problem == "non-associative" and float(p.get("dilatancy", 0.0)) not in (0.0, mu):
        return None
    associative = problem == "associative" or float(p.get("dilatancy", 0.0)) == mu
    if name == "single-block":
        return min(mu, float(p["width"]) / float(p["height"]))
    if name == "two-blocks":
        eta = float(p["eta"])
        if associative and mu > 1 and eta < 1:
            # The paper's A2-1 expression 1/[eta(1-mu^2)+mu] falls below the LP optimum here, and the
            # LP optimum is bracketed by an admissible stress field and a mechanism (both verified):
            # the four-mechanism formula is not valid for squat blocks with mu > 1.
            return None
        if not associative:
            return mu if mu <= 1.0 / eta else 1.0 / eta
        candidates = [mu, 2.0 / eta]
        d1 = eta * (1 - mu**2) + mu
        if d1 > 0:
            candidates.append(1.0 / d1)
        d2 = eta * (1 + mu**2) - mu
        if d2 > 0:
            candidates.append((1 + 2 * mu**2) / d2)
        return min(candidates)
    return None


def get_case(name: str) -> CaseSpec:
    """Look up a built-in case by name."""
    try:
        return CASES[name]
    except KeyError:
        raise UnknownNameError(f"unknown case {name!r}; built-in cases: {', '.join(CASES)}") from None


def build_case(name: str, **params: Any) -> Structure:
    """Build a built-in case by name with parameters."""
    return get_case(name).build(**params)


def _is_number(v: Any) -> bool:
    """A number that is not a bool."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def check_case_params(case: str, params: dict[str, Any], known: dict[str, Any]) -> None:
    """Each value of ``params`` must have the type of its default in ``known`` (a number for a
    number or None, a string for a string, a list for a list); else an OptionError naming it."""
    for key, value in params.items():
        if key not in known:
            continue  # the case names the unknown key itself, with the valid ones
        default = known[key]
        if _is_number(default) or default is None:
            ok = _is_number(value) or (default is None and value is None)
            want = "a number"
        elif isinstance(default, str):
            ok, want = isinstance(value, str), "a string"
        elif isinstance(default, (list, tuple)):
            ok, want = isinstance(value, (list, tuple)), "a list"
        else:
            ok, want = True, ""
        if not ok:
            raise OptionError(f"-p {key}={json.dumps(value) if not isinstance(value, str) else value}: "
                              f"case {case!r} expects {want} for {key}")


def load_case(case: str, params: dict[str, Any]) -> Structure:
    """A built-in case name or a structure file path, with parameters applied (bad values: OptionError)."""
    if case in CASES:
        spec = get_case(case)
        check_case_params(case, params, spec.parameters)
        try:
            return spec.build(**params)
        except BlockmpecError:
            raise
        except (TypeError, ValueError, ArithmeticError, IndexError, KeyError) as exc:
            raise OptionError(f"case {case!r} with {params}: {type(exc).__name__}: {exc}") from None
    path = Path(case)
    from blockmpec.three_d.meshes import is_3d_file, read_3d_file

    if is_3d_file(path):  # a mesh (.obj, .stl, .ply) or a 3D structure file: -p sets its material and loads
        return read_3d_file(path, params)
    from blockmpec.drawings import is_drawing, read_structure

    if is_drawing(path):  # DXF, SVG or image: -p sets the reader's options (blockmpec import --help)
        return read_structure(path, **params)
    if path.suffix.lower() == ".json" or path.exists():
        from blockmpec.structure_file import load_structure

        structure = load_structure(path)
        unknown = sorted(set(params) - {"mu", "dilatancy"})
        if unknown:
            raise OptionError(f"structure file {case}: only mu and dilatancy can be set with -p; got {unknown[0]!r}")
        check_case_params(case, params, {"mu": None, "dilatancy": None})
        return structure.with_material(params.get("mu"), params.get("dilatancy"))
    raise OptionError(f"unknown case {case!r}: not a built-in case ({', '.join(CASES)}) nor a structure file "
                      "(.json) nor a drawing (.dxf, .svg, an image) nor a 3D mesh (.obj, .stl, .ply)")
