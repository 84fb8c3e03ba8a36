"""Built-in 3D cases, with the closed forms that are known.

Every generator validates its parameters and returns a validated :class:`~blockmpec.three_d.geometry.Structure3D`
with unit density (dead load = weight along ``-z``) and the live load ``live_direction`` times the weight.

* :func:`block_3d` -- one block on a fixed base, the base optionally inclined: ``lam = tan(alpha + min(phi, beta))``
  with ``tan(beta)`` the block's width over its height along the load (sliding up the slope or overturning about
  the toe); on a level base ``min(mu, b/h)`` (:func:`closed_form`).
* :func:`extruded` / :func:`extrude` -- any 2D structure extruded to a thickness, its loads in its plane: the 3D
  associative ``lam`` equals the 2D one (the inscribed pyramid is exact in the plane of the load).
* :func:`corner_wall` -- a wall with a return wall (an L-shaped corner), interlocked at the corner, under an
  out-of-plane load.
* :func:`barrel_vault` -- a semicircular barrel vault of staggered voussoir rings.
* :func:`dome` -- a hemispherical dome of voussoirs with an oculus.
* :func:`arch_3d` -- a round arch with depth under an out-of-plane load.
"""

from __future__ import annotations

import math

import numpy as np

from blockmpec.cases import CASES, CaseSpec, _count, _positive
from blockmpec.errors import OptionError, UnknownNameError
from blockmpec.geometry import DEFAULT_FRICTION
from blockmpec.three_d.geometry import Structure3D, make_structure_3d
from blockmpec.three_d.polyhedra import box, prism


def _angle(name: str, value: float, upper: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name}: expected a number of degrees; got {value!r}") from None
    if not math.isfinite(v) or v < 0 or v >= upper:
        raise OptionError(f"{name}: must be a number of degrees in [0, {upper}); got {value!r}")
    return v


def block_3d(width: float = 1.0, depth: float = 0.5, height: float = 2.0, mu: float = DEFAULT_FRICTION,
             dilatancy: float = 0.0, slope: float = 0.0, live_direction: list = (1.0, 0.0, 0.0),
             pyramid_sides: int = 4) -> Structure3D:
    """One ``width x depth x height`` block (along ``x``, ``y``, ``z``) on a fixed base inclined by ``slope`` degrees
    about ``y`` (rising towards ``+x``).

    Closed form (:func:`closed_form`), for a horizontal live load along ``+x`` and ``tan(slope) <= min(mu, b/h)``:
    ``lam = tan(slope + min(phi, beta))``, ``tan(beta) = width / height``: sliding up the slope
    (``(mu + tan a) / (1 - mu tan a)``) or overturning about the upper toe; the same associative and
    non-associative.  Along ``+y``: ``min(mu, depth / height)`` on a level base.
    """
    b, d, h = _positive("width", width), _positive("depth", depth), _positive("height", height)
    a = math.radians(_angle("slope", slope, 90.0))
    s = np.array([math.cos(a), 0.0, math.sin(a)])
    nu = np.array([-math.sin(a), 0.0, math.cos(a)])
    y = np.array([0.0, 1.0, 0.0])

    def local(v):
        return v[:, :1] * s + v[:, 1:2] * y + v[:, 2:] * nu

    span = 2 * max(b, d)
    base_v, base_f = box((-span, -span, -0.5 * span), (span + b, span + d, 0.0))
    blk_v, blk_f = box((0.0, 0.0, 0.0), (b, d, h))
    return make_structure_3d([(local(base_v), base_f), (local(blk_v), blk_f)], [True, False], friction=mu,
                             dilatancy=dilatancy, live_direction=live_direction, pyramid_sides=pyramid_sides,
                             block_ids=["base", "block"], name="block-3d")


def extrude(structure, thickness: float = 1.0, pyramid_sides: int = 4) -> Structure3D:
    """A 2D :class:`~blockmpec.geometry.Structure` extruded to ``thickness``: 2D ``(x, y)`` becomes 3D ``(x, z)``,
    the thickness runs along ``y`` from 0, the live load stays along ``x`` (its 2D sign and factor kept), densities
    are per unit volume.  Point loads are not carried over (a structure with them raises)."""
    t = _positive("thickness", thickness)
    if structure.point_loads:
        raise OptionError("extrude: a structure with point loads cannot be extruded (give its loads as densities)")
    blocks = []
    for i in range(structure.n_blocks):
        poly = structure.polygon(i)[::-1]  # counter-clockwise about -y in the x-z plane: reversed about +y
        bottom = np.column_stack([poly[:, 0], np.zeros(len(poly)), poly[:, 1]])
        top = bottom + np.array([0.0, t, 0.0])
        blocks.append(prism(bottom, top))
    return make_structure_3d(blocks, structure.fixed, friction=structure.friction, dilatancy=structure.dilatancy,
                             density=structure.density, live_direction=[float(structure.live_direction), 0.0, 0.0],
                             live_factor=structure.live_factor, pyramid_sides=pyramid_sides,
                             name=f"{structure.name}-extruded", metadata={"extruded_from": structure.name,
                                                                       "thickness": t})


def extruded(case: str = "two-blocks", thickness: float = 1.0, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0,
             pyramid_sides: int = 4) -> Structure3D:
    """A built-in 2D case (with its default parameters, ``mu`` and ``dilatancy``) extruded to ``thickness``."""
    from blockmpec.cases import build_case

    if case not in CASES or CASES[case].generator.__module__.startswith("blockmpec.three_d"):
        names = [k for k, v in CASES.items() if not v.generator.__module__.startswith("blockmpec.three_d")]
        raise OptionError(f"case: {case!r} is not a built-in 2D case ({', '.join(names)})")
    params = {"mu": mu}
    if "dilatancy" in CASES[case].parameters:
        params["dilatancy"] = dilatancy
    return extrude(build_case(case, **params), thickness, pyramid_sides)


def corner_wall(length: float = 2.4, return_length: float = 1.6, height: float = 1.6, thickness: float = 0.3,
                courses: int = 4, blocks_per_course: int = 3, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0,
                live_direction: list = (0.0, -1.0, 0.0), pyramid_sides: int = 4) -> Structure3D:
    """An L-shaped corner: a wall along ``x`` (thickness along ``y`` from 0) and a return wall along ``+y`` at
    ``x = 0``, on a fixed base, the corner interlocked (even courses: the main wall's end block covers the corner,
    odd courses: the return wall's); out-of-plane live load (default ``-y``, away from the return wall)."""
    L, R, H, t = (_positive(n, v) for n, v in (("length", length), ("return_length", return_length),
                                                  ("height", height), ("thickness", thickness)))
    n = _count("courses", courses)
    m = _count("blocks_per_course", blocks_per_course)
    if t >= min(L, R):
        raise OptionError("thickness: must be less than length and return_length")
    h = H / n
    blocks, fixed, ids = [box((-0.5, -1.0, -0.5), (L + 0.5, t + R + 0.5, 0.0))], [True], ["base"]
    for k in range(n):
        z0, z1 = k * h, (k + 1) * h
        main_from = 0.0 if k % 2 == 0 else t
        ret_from = t if k % 2 == 0 else 0.0
        for j, x in enumerate(np.linspace(main_from, L, m + 1)[:-1]):
            x1 = main_from + (j + 1) * (L - main_from) / m
            blocks.append(box((x, 0.0, z0), (x1, t, z1)))
            fixed.append(False)
            ids.append(f"main-{k}-{j}")
        for j in range(m):
            y0 = ret_from + j * (t + R - ret_from) / m
            y1 = ret_from + (j + 1) * (t + R - ret_from) / m
            blocks.append(box((0.0, y0, z0), (t, y1, z1)))
            fixed.append(False)
            ids.append(f"return-{k}-{j}")
    return make_structure_3d(blocks, fixed, friction=mu, dilatancy=dilatancy, live_direction=live_direction,
                             pyramid_sides=pyramid_sides, block_ids=ids, name="corner-wall")


def _ring_voussoirs(angles: np.ndarray, r_in: float, r_out: float, y0: float, y1: float) -> list:
    """Voussoirs of a semicircular ring in the ``x-z`` plane between the polar angles ``angles`` (from ``+x``), from
    ``y0`` to ``y1``."""
    out = []
    for a0, a1 in zip(angles[:-1], angles[1:]):
        c0, s0, c1, s1 = math.cos(a0), math.sin(a0), math.cos(a1), math.sin(a1)
        poly = np.array([[r_in * c0, r_in * s0], [r_out * c0, r_out * s0], [r_out * c1, r_out * s1],
                         [r_in * c1, r_in * s1]])  # counter-clockwise in (x, z)
        bottom = np.column_stack([poly[::-1, 0], np.full(4, y0), poly[::-1, 1]])
        out.append(prism(bottom, bottom + np.array([0.0, y1 - y0, 0.0])))
    return out


def barrel_vault(span: float = 4.0, thickness: float = 0.4, length: float = 2.0, voussoirs: int = 7,
                 rings: int = 3, mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0, live_direction: list = (1.0, 0.0, 0.0),
                 pyramid_sides: int = 4) -> Structure3D:
    """A semicircular barrel vault (axis along ``y``) of ``rings`` voussoir rings side by side, every other ring
    staggered by half a voussoir, on two fixed springers; live load along its span by default."""
    span, t, length = _positive("span", span), _positive("thickness", thickness), _positive("length", length)
    n = _count("voussoirs", voussoirs, 2)
    k = _count("rings", rings)
    r_in, r_out = span / 2, span / 2 + t
    if t >= r_in:
        raise OptionError("thickness: must be less than half the span")
    width = length / k
    blocks, fixed, ids = [], [], []
    for side, x0, x1 in (("left", -r_out - t, -r_in + 0.0), ("right", r_in, r_out + t)):
        lo, hi = (x0, 0.0, -t), (x1, length, 0.0)
        blocks.append(box(lo, hi))
        fixed.append(True)
        ids.append(f"springer-{side}")
    step = math.pi / n
    for j in range(k):
        if j % 2 == 0:
            angles = np.linspace(0.0, math.pi, n + 1)
        else:
            angles = np.concatenate([[0.0], step / 2 + step * np.arange(n), [math.pi]])
        for i, v in enumerate(_ring_voussoirs(angles, r_in, r_out, j * width, (j + 1) * width)):
            blocks.append(v)
            fixed.append(False)
            ids.append(f"ring-{j}-{i}")
    return make_structure_3d(blocks, fixed, friction=mu, dilatancy=dilatancy, live_direction=live_direction,
                             pyramid_sides=pyramid_sides, block_ids=ids, name="barrel-vault")


def arch_3d(voussoirs: int = 9, radius: float = 2.0, thickness: float = 0.3, depth: float = 0.6, mu: float = DEFAULT_FRICTION,
            dilatancy: float = 0.0, live_direction: list = (0.0, 1.0, 0.0), pyramid_sides: int = 4) -> Structure3D:
    """A round arch of ``voussoirs`` voussoirs with depth ``depth`` (along ``y``) on two fixed springers, loaded out of
    its plane by default (``+y``)."""
    n = _count("voussoirs", voussoirs, 2)
    r, t, d = _positive("radius", radius), _positive("thickness", thickness), _positive("depth", depth)
    if t >= r:
        raise OptionError("thickness: must be less than the radius")
    r_in, r_out = r - t / 2, r + t / 2
    blocks = [box((-r_out - t, -d, -t), (-r_in, 2 * d, 0.0)), box((r_in, -d, -t), (r_out + t, 2 * d, 0.0))]
    blocks += _ring_voussoirs(np.linspace(0.0, math.pi, n + 1), r_in, r_out, 0.0, d)
    ids = ["springer-left", "springer-right"] + [f"voussoir-{i}" for i in range(n)]
    return make_structure_3d(blocks, [True, True] + [False] * n, friction=mu, dilatancy=dilatancy,
                             live_direction=live_direction, pyramid_sides=pyramid_sides, block_ids=ids, name="arch-3d")


def dome(radius: float = 5.0, thickness: float = 0.5, rings: int = 6, segments: int = 12, oculus: float = 20.0,
         mu: float = DEFAULT_FRICTION, dilatancy: float = 0.0, live_direction: list = (1.0, 0.0, 0.0),
         pyramid_sides: int = 4) -> Structure3D:
    """A hemispherical dome of ``rings x segments`` voussoirs (mid-surface radius ``radius``) with an oculus of
    ``oculus`` degrees half-angle, on a fixed ground block.

    Each voussoir spans two latitudes and two azimuths; its bed joints are radial (conical) and its head joints
    meridian planes.  Its eight corners make planar faces (each an isosceles trapezoid), so the block is a convex
    hexahedron; the segments of neighbouring rings are aligned (a staggered bond would need bed faces split at
    the neighbours' joints)."""
    r, t = _positive("radius", radius), _positive("thickness", thickness)
    nr = _count("rings", rings)
    ns = _count("segments", segments, 3)
    top = 90.0 - _angle("oculus", oculus, 90.0)
    if t >= r:
        raise OptionError("thickness: must be less than the radius")
    r_in, r_out = r - t / 2, r + t / 2
    lat = np.radians(np.linspace(0.0, top, nr + 1))
    az = np.linspace(0.0, 2 * math.pi, ns + 1)

    def point(rad, la, a):
        return np.array([rad * math.cos(la) * math.cos(a), rad * math.cos(la) * math.sin(a), rad * math.sin(la)])

    blocks, ids = [box((-r_out - t, -r_out - t, -t), (r_out + t, r_out + t, 0.0))], ["ground"]
    faces = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [3, 0, 4, 7]]
    for i in range(nr):
        for j in range(ns):
            la0, la1, a0, a1 = lat[i], lat[i + 1], az[j], az[j + 1]
            # a box-like hexahedron: bottom = lower bed (outer/inner, azimuth a0/a1), top = upper bed
            v = np.array([point(r_out, la0, a0), point(r_out, la0, a1), point(r_in, la0, a1), point(r_in, la0, a0),
                          point(r_out, la1, a0), point(r_out, la1, a1), point(r_in, la1, a1), point(r_in, la1, a0)])
            blocks.append((v, faces))
            ids.append(f"ring-{i}-{j}")
    fixed = [True] + [False] * (nr * ns)
    return make_structure_3d(blocks, fixed, friction=mu, dilatancy=dilatancy, live_direction=live_direction,
                             pyramid_sides=pyramid_sides, block_ids=ids, name="dome")


#: The 3D built-in cases, registered with the 2D ones in :data:`blockmpec.cases.CASES` when this module is imported
#: (``import blockmpec`` does).
CASES_3D: dict[str, CaseSpec] = {
    spec.name: spec
    for spec in (
        CaseSpec("block-3d", block_3d, "3D: one block on a fixed base, level or inclined; "
                 "lam = tan(slope + min(phi, atan(b/h)))",
                 closed_form=lambda problem, **params: closed_form("block-3d", problem, **params)),
        CaseSpec("extruded", extruded, "3D: a built-in 2D case extruded to a thickness (lam equals the 2D one)"),
        CaseSpec("corner-wall", corner_wall, "3D: a wall with a return wall (L-shaped corner), out-of-plane load"),
        CaseSpec("barrel-vault", barrel_vault, "3D: a semicircular barrel vault of staggered voussoir rings"),
        CaseSpec("dome", dome, "3D: a hemispherical dome of voussoirs with an oculus"),
        CaseSpec("arch-3d", arch_3d, "3D: a round arch with depth under an out-of-plane load"),
    )
}


CASES.update(CASES_3D)


def closed_form(name: str, problem: str, **params) -> float | None:
    """Closed-form collapse multiplier of a 3D case where one is known (``block-3d`` along ``+x`` or ``+y``), else None;
    the same for both problems (for ``"non-associative"`` the minimum over solutions of (3), given as in 2D only for
    a dilatancy of 0 or ``mu``: :func:`blockmpec.cases.closed_form`)."""
    if problem not in ("associative", "non-associative"):
        raise OptionError(f"problem: must be 'associative' or 'non-associative'; got {problem!r}")
    if name not in CASES_3D:
        raise UnknownNameError(f"unknown 3D case {name!r}; 3D cases: {', '.join(CASES_3D)}")
    if name != "block-3d":
        return None
    p = {**CASES_3D[name].parameters, **params}
    if problem == "non-associative" and float(p["dilatancy"]) not in (0.0, float(p["mu"])):
        return None
    d = np.asarray(p["live_direction"], float)
    d = d / np.linalg.norm(d)
    mu, a = float(p["mu"]), math.radians(float(p["slope"]))
    if np.allclose(d, [1, 0, 0]):
        beta = math.atan(float(p["width"]) / float(p["height"]))
        return math.tan(a + min(math.atan(mu), beta))
    if np.allclose(d, [0, 1, 0]) and a == 0:
        return min(mu, float(p["depth"]) / float(p["height"]))
    return None
