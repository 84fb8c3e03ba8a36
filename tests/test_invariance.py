"""lam does not depend on units, position, file order or handedness (hypothesis + fixed cases).

A structure and its image under

* a change of length unit by ``a`` (1e-100 ... 1e100) and of density unit by ``r``
  (1e-100 ... 1e100), point loads scaled by ``r a^2`` with the weights;
* a translation by up to 1e15 block sizes (coordinates on a dyadic grid, so that the
  translated file holds exactly the same geometry);
* a permutation of the blocks in the file;
* a mirror image ``x -> -x`` with the live load reversed;

have the same collapse multiplier.  Each transformed run must return the unit-scale
``lam`` (to 1e-9) with the same status, or a clear one-line error naming a block or a
field.  The structures are small stacks and walls, loaded by their weights or (the
"point-load-only" family) near-massless and loaded by point loads.

Every method is invariant by construction: the assembly works in units of the
structure, in a canonical frame (``x`` along the live load) with snapped coordinates
(:mod:`blockmpec.units`) and in canonical order (:func:`blockmpec.operators.assemble`),
so a transformed structure assembles to the same bits.  The heuristics that pick one
of many solutions of (3) are tested on the fixed cases of issue 16; where one is not
invariant the test is an ``xfail(strict=True)`` naming what its owner must change.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

import blockmpec as bm

#: about 0.04 s an example (measured; the conftest profile derandomises them): 25 examples, about a second a test
SETTINGS = settings(max_examples=25)
LP_METHODS = ("static-lp", "kinematic-lp")
TOL = 1e-9


# ---------------------------------------------------------------- structures as plain data

def spec_to_structure(spec: dict) -> bm.Structure:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bm.PrecisionWarning)  # dyadic coordinates lose nothing
        return bm.make_structure(
            spec["polys"], spec["fixed"], friction=spec["mu"], density=spec["density"],
            live_direction=spec["direction"], live_factor=spec["factor"],
            point_loads=[bm.PointLoad(b, tuple(p), tuple(f), k) for b, p, f, k in spec["loads"]],
        )


def scaled(spec: dict, a: float, r: float) -> dict:
    """Lengths times ``a``, densities times ``r``, point-load forces times ``r a^2``."""
    out = dict(spec)
    out["polys"] = [[[x * a, y * a] for x, y in poly] for poly in spec["polys"]]
    out["density"] = [d * r for d in spec["density"]]
    out["loads"] = [(b, [p[0] * a, p[1] * a], [f[0] * r * a * a, f[1] * r * a * a], k) for b, p, f, k in spec["loads"]]
    return out


def translated(spec: dict, dx: float, dy: float) -> dict:
    out = dict(spec)
    out["polys"] = [[[x + dx, y + dy] for x, y in poly] for poly in spec["polys"]]
    out["loads"] = [(b, [p[0] + dx, p[1] + dy], f, k) for b, p, f, k in spec["loads"]]
    return out


def mirrored(spec: dict) -> dict:
    """``x -> -x`` (vertex order reversed to stay counter-clockwise), live load and forces mirrored."""
    out = dict(spec)
    out["polys"] = [[[-x, y] for x, y in reversed(poly)] for poly in spec["polys"]]
    out["direction"] = -spec["direction"]
    out["loads"] = [(b, [-p[0], p[1]], [-f[0], f[1]], k) for b, p, f, k in spec["loads"]]
    return out


def permuted(spec: dict, order: list[int]) -> dict:
    """Blocks in the file in ``order`` (new block ``i`` is old block ``order[i]``)."""
    new_index = {old: new for new, old in enumerate(order)}
    out = dict(spec)
    for key in ("polys", "fixed", "density"):
        out[key] = [spec[key][i] for i in order]
    out["loads"] = [(new_index[b], p, f, k) for b, p, f, k in spec["loads"]]
    return out


# ---------------------------------------------------------------- random small structures

GRID = 0.125  # coordinates on a dyadic grid: translations up to 2^50 keep them exact


@st.composite
def small_specs(draw, point_load_only: bool | None = None):
    """A fixed base with 1-4 rectangles: a stack with overhangs or a row of two stacks; dyadic
    coordinates; per-block densities; optional point loads (all of them with near-massless
    blocks in the point-load-only family)."""
    if point_load_only is None:
        point_load_only = draw(st.booleans())
    q = lambda lo, hi: GRID * draw(st.integers(int(lo / GRID), int(hi / GRID)))  # noqa: E731
    polys = [[[-8.0, -1.0], [8.0, -1.0], [8.0, 0.0], [-8.0, 0.0]]]
    for column in range(draw(st.integers(1, 2))):
        x0, y, width = -3.0 + 4.0 * column, 0.0, 1.0
        for _ in range(draw(st.integers(1, 2))):
            w, h = q(0.5, 1.5), q(0.25, 1.5)
            shift = q(-0.25, 0.25)
            lo = x0 + (width - w) / 2 + shift
            polys.append([[lo, y], [lo + w, y], [lo + w, y + h], [lo, y + h]])
            x0, width, y = lo, w, y + h
    n = len(polys)
    density = [1.0] + [q(0.5, 2.0) for _ in range(n - 1)]
    loads = []
    if point_load_only:
        density = [1.0] + [1e-12] * (n - 1)  # far below the LP engines' 1e-9 zero threshold in every unit
        for i in range(1, n):
            (x_lo, y_lo), (x_hi, _), (_, y_hi) = polys[i][0], polys[i][1], polys[i][2]
            loads.append((i, [0.5 * (x_lo + x_hi), y_hi], [0.0, -q(0.5, 2.0)], "dead"))
            loads.append((i, [q(0, 1) * (x_hi - x_lo) + x_lo, 0.5 * (y_lo + y_hi)], [q(0.25, 1.0), 0.0], "live"))
    elif draw(st.booleans()):
        i = draw(st.integers(1, n - 1))
        (x_lo, _), (x_hi, _), (_, y_hi) = polys[i][0], polys[i][1], polys[i][2]
        loads.append((i, [x_lo + 0.25 * (x_hi - x_lo), y_hi], [0.0, -q(0.25, 2.0)], "dead"))
    return {
        "polys": polys, "fixed": [True] + [False] * (n - 1), "density": density,
        "mu": q(0.25, 1.0), "direction": draw(st.sampled_from([1, -1])), "factor": 1.0, "loads": loads,
    }


def outcome(spec: dict, method: str):
    """(status, lam) of a run, or ("error", message) for a clear error (one line naming a block or field)."""
    try:
        structure = spec_to_structure(spec)
    except bm.BlockmpecError as exc:
        msg = str(exc)
        assert "\n" not in msg and any(w in msg for w in ("block", "interface", "point load", "density", "live")), msg
        return "error", msg
    res = bm.solve(structure, method)
    if res.status is bm.Status.OPTIMAL:
        assert res.success, (res.message, res.residuals)
    return res.status, res.multiplier


def assert_same(ref, got):
    note(f"reference {ref}, transformed {got}")
    if ref[0] == "error":
        assert got[0] == "error"
        return
    assert got[0] == ref[0]
    if ref[0] is bm.Status.OPTIMAL:
        assert abs(got[1] - ref[1]) <= TOL * max(1.0, abs(ref[1])), (ref, got)


# ---------------------------------------------------------------- properties (LP methods)

@SETTINGS
@given(small_specs(), st.floats(-100, 100), st.floats(-100, 100), st.sampled_from(LP_METHODS))
def test_lam_independent_of_length_and_density_units(spec, log_a, log_r, method):
    ref = outcome(spec, method)
    assert_same(ref, outcome(scaled(spec, 10.0**log_a, 10.0**log_r), method))


@SETTINGS
@given(small_specs(), st.integers(-(10**15), 10**15), st.integers(-(10**15), 10**15), st.sampled_from(LP_METHODS))
def test_lam_independent_of_position_up_to_1e15(spec, dx, dy, method):
    moved = translated(spec, float(dx), float(dy))
    if translation_is_exact(spec, moved, float(dx), float(dy)):
        ref = outcome(spec, method)
        assert_same(ref, outcome(moved, method))
    else:
        # the offset itself rounded some coordinate: the moved structure is another structure; either
        # the user is told that digits of the input were lost (the 1e15 case), or the rounding
        # was too small to move lam
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            bm.make_structure(
                moved["polys"], moved["fixed"], friction=moved["mu"], density=moved["density"],
                live_direction=moved["direction"], live_factor=moved["factor"],
                point_loads=[bm.PointLoad(b, tuple(p), tuple(f), k) for b, p, f, k in moved["loads"]],
            )
        if not any(issubclass(w.category, bm.PrecisionWarning) for w in caught):
            assert_same(outcome(spec, method), outcome(moved, method))


def translation_is_exact(spec: dict, moved: dict, dx: float, dy: float) -> bool:
    """True when every vertex and load point of ``moved`` is exactly ``spec``'s plus (dx, dy)."""
    pairs = [(p, q) for a, b in zip(spec["polys"], moved["polys"]) for p, q in zip(a, b)]
    pairs += [(a[1], b[1]) for a, b in zip(spec["loads"], moved["loads"])]
    return all(q[0] - dx == p[0] and q[1] - dy == p[1] for p, q in pairs)


@SETTINGS
@given(small_specs(), st.randoms(use_true_random=False), st.sampled_from(LP_METHODS))
def test_lam_independent_of_block_order_in_the_file(spec, rnd, method):
    order = list(range(len(spec["polys"])))
    rnd.shuffle(order)
    ref = outcome(spec, method)
    assert_same(ref, outcome(permuted(spec, order), method))


@SETTINGS
@given(small_specs(), st.sampled_from(LP_METHODS))
def test_lam_independent_of_handedness(spec, method):
    ref = outcome(spec, method)
    assert_same(ref, outcome(mirrored(spec), method))


@SETTINGS
@given(small_specs(point_load_only=True), st.integers(-332, 332), st.floats(-100, 100),
       st.integers(-(10**12), 10**12), st.booleans(), st.sampled_from(LP_METHODS))
def test_point_load_only_structures_under_every_transformation_at_once(spec, log2_a, log_r, shift, mirror, method):
    """Translated (exactly, on the dyadic grid), then scaled by a power of two (exact: an inexact
    scale of coordinates 1e12 block sizes from the origin would itself move the blocks by 1e-4 of
    their size), densities and forces by any factor, and mirrored."""
    ref = outcome(spec, method)
    other = scaled(translated(spec, float(shift), 0.0), 2.0**log2_a, 10.0**log_r)
    other = mirrored(other) if mirror else other
    assert_same(ref, outcome(other, method))


# ---------------------------------------------------------------- the cases of issue 16

@pytest.mark.parametrize("width", [1e-150, 1e-108, 1e-110, 1.0, 1e140, 1e150])
@pytest.mark.parametrize("method", ["static-lp", "kinematic-lp", "fixed-point"])
def test_two_blocks_at_extreme_widths_give_the_closed_form(width, method):
    """Before units: width 1e-108 gave 0.36967 'optimal', 1e-110 gave 0.65, 1e140 NaN operators (HiGHS segfault)."""
    problem = "non-associative" if method == "fixed-point" else "associative"  # fixed point: the minimum, 1/3
    expected = bm.cases.closed_form("two-blocks", problem, eta=3.0, mu=0.65)
    res = bm.solve(bm.cases.two_blocks(eta=3.0, mu=0.65, width=width), method)
    assert res.success, res.message
    assert res.multiplier == pytest.approx(expected, rel=1e-12)
    ops = bm.assemble(bm.cases.two_blocks(eta=3.0, mu=0.65, width=width))
    assert np.all(np.isfinite(ops.E.data)) and np.all(np.isfinite(ops.f_d)) and np.all(np.isfinite(ops.f_l))


def _wall_spec(**kw) -> dict:
    return _spec_of(bm.cases.wall(**kw))


def _spec_of(s: bm.Structure) -> dict:
    return {
        "polys": [s.polygon(i).tolist() for i in range(s.n_blocks)], "fixed": s.fixed.tolist(),
        "density": s.density.tolist(), "mu": s.friction, "direction": s.live_direction, "factor": s.live_factor,
        "loads": [],
    }


WALL = _wall_spec(courses=10, blocks_per_course=5)
TRANSFORMS = {
    "translate (3.7, -2.1)": lambda s: translated(s, 3.7, -2.1),
    "mirror": mirrored,
    "reverse block order": lambda s: permuted(s, list(range(len(s["polys"])))[::-1]),
    "scale 1e-100": lambda s: scaled(s, 1e-100, 1.0),
}


@functools.lru_cache(maxsize=None)
def _wall_lam(method: str, transform: str | None) -> float:
    spec = WALL if transform is None else TRANSFORMS[transform](WALL)
    res = bm.solve(spec_to_structure(spec), method)
    assert res.success, res.message
    return res.multiplier


@pytest.mark.parametrize("transform", list(TRANSFORMS))
@pytest.mark.parametrize("method", LP_METHODS)
def test_wall_10x5_lp_methods_invariant(method, transform):
    assert abs(_wall_lam(method, transform) - _wall_lam(method, None)) <= TOL


def _same_bits(a, b) -> None:
    for name in ("f_d", "f_l", "length", "friction", "dilatancy", "block_area", "minus_dof", "plus_dof"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for name in ("E", "N_u", "N_f", "V_f"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and (x != y).nnz == 0, name


@pytest.mark.parametrize("transform", list(TRANSFORMS))
@pytest.mark.parametrize("case", ["wall-10x5", "round-arch"])
def test_canonical_frame_assembles_the_same_bits(case, transform):
    """Canonical frame (x along the live load, origin at the centre, unit the median block side) and
    snapped coordinates: the transformed structures are the same problem bit for bit, so every
    deterministic method returns the same lam."""
    spec = WALL if case == "wall-10x5" else _spec_of(bm.cases.round_arch())
    _same_bits(bm.assemble(spec_to_structure(spec)), bm.assemble(spec_to_structure(TRANSFORMS[transform](spec))))


#: |dlam| on the 10x5 wall per (method, transformation), from `python tests/test_invariance.py`, with the
#: canonical frame and snapped coordinates (blockmpec.units): every heuristic gives the same bits
HEURISTIC_MEASURED: dict[tuple[str, str], float] = {
    (m, t): 0.0 for m in ("fixed-point", "mcp-newton") for t in TRANSFORMS}

#: what to change where a heuristic is not invariant (none today)
HEURISTIC_XFAIL = {
    "fixed-point": "fixed point: the step LP and its 'closest' tie-break are not unique on running-bond walls; "
                   "round-off in the data picks another optimal vertex (solvers/fixed_point.py, lp_sequence.py)",
    "mcp-newton": "semismooth Newton: least-squares steps and the Armijo search depend on round-off in the data "
                  "(solvers/mcp_newton.py, engines/newton_system.py)",
}


def _heuristic_case(method: str, transform: str):
    measured = HEURISTIC_MEASURED.get((method, transform))
    if measured is None or measured <= TOL:
        return pytest.param(method, transform, id=f"{method}-{transform}")
    return pytest.param(method, transform, id=f"{method}-{transform}",
                        marks=pytest.mark.xfail(strict=True, reason=f"{HEURISTIC_XFAIL[method]}; |dlam| = {measured:.1e}"))


@pytest.mark.slow
@pytest.mark.parametrize(("method", "transform"), [
    _heuristic_case(m, t) for m in ("fixed-point", "mcp-newton") for t in TRANSFORMS])
def test_wall_10x5_heuristics_invariant(method, transform):
    assert abs(_wall_lam(method, transform) - _wall_lam(method, None)) <= TOL


if __name__ == "__main__":  # the invariance figures of the report
    for method in ("static-lp", "kinematic-lp", "fixed-point", "mcp-newton", "slp"):
        ref = bm.solve(spec_to_structure(WALL), method).multiplier
        row = []
        for name, fn in TRANSFORMS.items():
            res = bm.solve(spec_to_structure(fn(WALL)), method)
            row.append(f"{name}: {abs(res.multiplier - ref):.1e}")
        print(f"{method:13s} lam={ref:.9f}  " + ", ".join(row))
