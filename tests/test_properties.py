"""Property tests over random small structures (hypothesis).

Invariants of the associative problem: lam is unchanged by a rigid motion of the
whole structure with its loads moved alike, by a mirror image with the live
load reversed, and by uniform scaling; the static and kinematic LPs agree.

The static LP against an independent statement of it (``tests/independent.py``: operators
written from the geometry, scipy's linprog): the same status and ``lam`` on random stacks.

Orderings of the non-associative problem (psi = 0), on structures small enough for
the ``milp`` method to certify within seconds:

* every verified heuristic multiplier is at least the certified global minimum
  of the MPEC (4), ``lam_milp <= lam_method``;
* the associative multiplier bounds every non-associative one from above: the
  force part ``x`` of any solution of (3) lies in the statically admissible set
  ``S`` of the LP (1), whose largest ``lam`` is the associative multiplier; the
  certified maximum over (3) (``milp``, ``sense="max"``) equals it (the paper's
  statement, Sect. 3); and an empty ``S`` (static LP infeasible) leaves (3)
  without any solution, so no method may return a verified one.

A heuristic that returns no verified solution must say so (``assert_failure_reported``): no
success, a message, and never ``infeasible`` where ``milp`` found a solution of (3).

The examples are the same on every run (the ``blockmpec`` settings profile of conftest.py:
``derandomize=True``).  Each drawn structure is kept: where ``milp`` does not certify within its
time limit the example is skipped (``assume``): no reference.
"""

import dataclasses

import independent
import numpy as np
import pytest
from hypothesis import assume, given, note, settings
from hypothesis import strategies as st

import blockmpec as bm
from helpers import CERTIFIED_TOL, HEURISTIC_TOL, HEURISTICS, margin, solve_with

#: the LP properties: a few LPs per example, 0.06 s (measured): 40 examples each, ~2.5 s a test
SETTINGS = settings(max_examples=40)
#: the multi-solver properties run seven solves per example (milp up to ~1 s): 30 examples, in the slow suite
MULTI_SOLVER_SETTINGS = settings(max_examples=30)
MILP_TIME_LIMIT = 20.0
#: static-lp against the independent LP on random stacks: 3e-12 at most measured, relative
INDEPENDENT_LP = 1e-9


def assert_failure_reported(res: bm.Result, has_solution: bool) -> None:
    """A run that returns no verified solution of (3) says so: no success, a message, and no claim of infeasibility
    where (3) has a solution (``has_solution``: milp found one)."""
    assert not res.success
    assert res.message, res.status
    if has_solution:
        assert res.status is not bm.Status.INFEASIBLE, res.message


@st.composite
def stacks(draw, max_columns=2, max_blocks=3):
    """Columns of rectangles of random size, each resting on the one below with a random offset.

    Offsets up to 70 % of the narrower width: many stacks overhang, need a reversed
    live load (lam < 0) or cannot stand at all (static LP infeasible).
    """
    n_columns = draw(st.integers(1, max_columns))
    mu = draw(st.floats(0.2, 1.2))
    polys = [np.array([[-10.0, -1.0], [10.0, -1.0], [10.0, 0.0], [-10.0, 0.0]])]
    x0 = -3.0
    for _ in range(n_columns):
        y = 0.0
        left, width = x0, 1.0
        for _ in range(draw(st.integers(1, max_blocks))):
            w = draw(st.floats(0.3, 1.5))
            h = draw(st.floats(0.2, 1.2))
            # overlap the block below by at least 30 % of the narrower width
            shift = draw(st.floats(-0.7, 0.7)) * min(w, width)
            lo = left + width / 2 - w / 2 + shift
            polys.append(np.array([[lo, y], [lo + w, y], [lo + w, y + h], [lo, y + h]]))
            left, width, y = lo, w, y + h
        x0 += 4.0
    return polys, mu


@st.composite
def walls(draw, max_courses=4, max_blocks_per_course=4):
    return bm.cases.wall(
        courses=draw(st.integers(1, max_courses)),
        blocks_per_course=draw(st.integers(1, max_blocks_per_course)),
        bond=draw(st.sampled_from(["running", "stack"])),
        block_height=draw(st.floats(0.2, 1.0)),
        mu=draw(st.floats(0.2, 1.2)),
    )


@st.composite
def small_structures(draw):
    """Structures the ``milp`` method certifies within seconds: one column of 1-3 blocks or a wall of
    at most 2 x 2 blocks (a 2 x 3 wall already takes ~9 s)."""
    if draw(st.booleans()):
        return _structure(*draw(stacks(max_columns=1, max_blocks=3)))
    return draw(walls(max_courses=2, max_blocks_per_course=2))


def _structure(polys, mu, **kw):
    return bm.make_structure(polys, [True] + [False] * (len(polys) - 1), friction=mu, **kw)


def _lam(structure_or_ops, method="static-lp"):
    res = bm.solve(structure_or_ops, method)
    assert res.status in (bm.Status.OPTIMAL, bm.Status.UNBOUNDED, bm.Status.INFEASIBLE), (res.status, res.message)
    if res.status is bm.Status.OPTIMAL:
        assert res.success, res.residuals
        return res.multiplier
    return res.status


def _rotate(points, angle, shift):
    c, s = np.cos(angle), np.sin(angle)
    return np.asarray(points) @ np.array([[c, s], [-s, c]]) + shift


@SETTINGS
@given(stacks(), st.floats(-np.pi, np.pi), st.floats(-50, 50), st.floats(-50, 50))
def test_rigid_motion_with_loads_moved_alike(stack, angle, dx, dy):
    polys, mu = stack
    ref = _structure(polys, mu)
    moved = _structure([_rotate(p, angle, (dx, dy)) for p in polys], mu)
    ops_ref, ops = bm.assemble(ref), bm.assemble(moved)
    # rotate the load vectors: force components turn with the structure, moments do not change
    c, s = np.cos(angle), np.sin(angle)
    rot = lambda f: np.column_stack([c * f[0::3] - s * f[1::3], s * f[0::3] + c * f[1::3], f[2::3]]).ravel()
    # rows are in canonical (position) order, which a rotation changes: match them by structure block
    row = {int(j): i for i, j in enumerate(ops_ref.free_blocks)}
    perm = (3 * np.array([row[int(j)] for j in ops.free_blocks])[:, None] + np.arange(3)).ravel()
    ops = dataclasses.replace(ops, f_d=rot(ops_ref.f_d)[perm], f_l=rot(ops_ref.f_l)[perm])
    a, b = _lam(ops_ref), _lam(ops)
    if isinstance(a, float):  # 1.6e-12 at most measured (60 examples): the rotated frame is not snapped bit for bit
        assert b == pytest.approx(a, rel=1e-9, abs=1e-9)
    else:
        assert a == b


@SETTINGS
@given(stacks())
def test_mirror_with_live_load_reversed(stack):
    polys, mu = stack
    mirrored = [np.column_stack([-p[::-1, 0], p[::-1, 1]]) for p in polys]  # reflect and keep CCW order
    a = _lam(_structure(polys, mu))
    b = _lam(_structure(mirrored, mu, live_direction=-1))
    if isinstance(a, float):  # 0 measured: the canonical frame turns x along the live load, the same bits
        assert b == pytest.approx(a, rel=1e-12, abs=1e-12)
    else:
        assert a == b


@SETTINGS
@given(walls(), st.sampled_from([1e-3, 1e-1, 1e1, 1e3]))
def test_uniform_scaling(wall, factor):
    scaled = bm.make_structure([wall.polygon(i) * factor for i in range(wall.n_blocks)], wall.fixed,
                               friction=wall.friction)
    a, b = _lam(wall), _lam(scaled)
    assert b == pytest.approx(a, rel=1e-12)  # 0 measured: the canonical length unit, the same bits


@SETTINGS
@given(walls())
def test_static_equals_kinematic(wall):
    assert _lam(wall, "kinematic-lp") == pytest.approx(_lam(wall, "static-lp"), rel=1e-9)  # 3.7e-15 measured


@pytest.mark.slow
@settings(max_examples=200)
@given(stacks())
def test_static_lp_is_the_independent_lp_on_random_stacks(stack):
    """static-lp's status and lam are those of the independent statement (tests/independent.py), on stacks that
    collapse, overhang (lam < 0) or cannot stand at all (infeasible)."""
    polys, mu = stack
    structure = _structure(polys, mu)
    status, lam = independent.static_lp(structure)
    res = bm.solve(structure, "static-lp")
    note(f"independent: {status} {lam}; static-lp: {res.status.value} {res.multiplier}")
    assert res.status.value == status, res.message
    if status == "optimal":
        assert res.success, res.residuals
        assert res.multiplier == pytest.approx(lam, rel=INDEPENDENT_LP, abs=INDEPENDENT_LP)


@pytest.mark.slow
@MULTI_SOLVER_SETTINGS
@given(small_structures())
def test_no_verified_heuristic_below_the_certified_minimum(structure):
    ops = bm.assemble(structure)
    minimum = bm.solve(ops, "milp", time_limit=MILP_TIME_LIMIT)
    note(f"milp: {minimum.status.value} {minimum.multiplier} ({minimum.message})")
    if minimum.status is bm.Status.INFEASIBLE:  # (3) has no solution (a proof): nothing may verify
        for method in HEURISTICS:
            res = bm.solve(ops, method)
            note(f"{method}: {res.status.value} {res.multiplier}")
            assert_failure_reported(res, has_solution=False)
        return
    assume(minimum.status is bm.Status.OPTIMAL)  # not certified within the time limit: no reference
    assert minimum.success, minimum.residuals
    for method in HEURISTICS:
        res = bm.solve(ops, method)
        note(f"{method}: {res.status.value} {res.multiplier}")
        if not res.success:
            assert_failure_reported(res, has_solution=True)
            continue
        assert res.multiplier >= minimum.multiplier - margin(HEURISTIC_TOL, minimum.multiplier), (
            method, res.multiplier, minimum.multiplier)


@pytest.mark.slow
@MULTI_SOLVER_SETTINGS
@given(small_structures())
def test_associative_multiplier_bounds_every_non_associative_one(structure):
    ops = bm.assemble(structure)
    assoc = bm.solve(ops, "static-lp")
    results = {method: bm.solve(ops, method) for method in HEURISTICS}
    results["milp"] = bm.solve(ops, "milp", time_limit=MILP_TIME_LIMIT)
    maximum = bm.solve(ops, "milp", sense="max", time_limit=MILP_TIME_LIMIT)
    for method, res in {**results, "milp max": maximum}.items():
        note(f"{method}: {res.status.value} {res.multiplier}")
    if assoc.status is bm.Status.INFEASIBLE:
        # S is empty and x of any solution of (3) would lie in S
        for res in (*results.values(), maximum):
            assert_failure_reported(res, has_solution=False)
        return
    assert assoc.status is bm.Status.OPTIMAL, assoc.message  # (UNBOUNDED: no collapse; not drawn from these strategies)
    assert assoc.success, assoc.residuals
    has_solution = results["milp"].status is bm.Status.OPTIMAL
    for method, res in results.items():
        if not res.success:
            assert_failure_reported(res, has_solution)
            continue
        tol = CERTIFIED_TOL if method == "milp" else HEURISTIC_TOL
        assert res.multiplier <= assoc.multiplier + margin(tol, assoc.multiplier), (
            method, res.multiplier, assoc.multiplier)
    assume(maximum.status is bm.Status.OPTIMAL)  # not certified within the time limit: no maximum to compare
    assert maximum.success, maximum.residuals
    assert abs(maximum.multiplier - assoc.multiplier) <= margin(CERTIFIED_TOL, assoc.multiplier), (
        maximum.multiplier, assoc.multiplier)


#: fixed-point strategies of studies/lab/fixed_point_strategies.py besides the default (run above); engine settings
#: under "settings" (``solve_with``)
FIXED_POINT_STRATEGIES = [
    {"start": "associative", "tie_break": "closest"},
    {"start": "associative", "tie_break": "min-lambda"},
    {"start": "dead-load", "tie_break": "least-compressed"},
    {"start": "random", "seed": 1, "tie_break": "least-compressed", "settings": {"acceleration": "anderson"}},
    {"multistart": 3},
]


@pytest.mark.slow
@settings(max_examples=16)
@given(small_structures())
def test_no_fixed_point_strategy_below_the_certified_minimum(structure):
    """Starts, tie-breaks, acceleration and multistart aim lower, but never below the certificate."""
    ops = bm.assemble(structure)
    minimum = bm.solve(ops, "milp", time_limit=MILP_TIME_LIMIT)
    assume(minimum.status in (bm.Status.OPTIMAL, bm.Status.INFEASIBLE))  # else no reference
    for options in FIXED_POINT_STRATEGIES:
        res = solve_with(ops, "fixed-point", **options)
        note(f"{options}: {res.status.value} {res.multiplier}")
        if not res.success:
            assert_failure_reported(res, has_solution=minimum.status is bm.Status.OPTIMAL)
            continue
        assert minimum.status is bm.Status.OPTIMAL, "a verified point where (3) has none"
        assert res.multiplier >= minimum.multiplier - margin(HEURISTIC_TOL, minimum.multiplier), (
            options, res.multiplier, minimum.multiplier)
        assert res.residuals["friction_admissibility"] <= 1e-6
