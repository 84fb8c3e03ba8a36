"""The built-in irregular wall ``stone-wall`` (issue 42): tiling, determinism, invariance, methods."""

import subprocess
import sys

import numpy as np
import pytest

import blockmpec as bm

SMALL = dict(width=3.0, height=1.5, stone_size=0.4)


def stones(s):
    return [s.polygon(i) for i in range(1, s.n_blocks)]


@pytest.mark.parametrize("irregularity", [0.0, 0.3, 0.7, 1.0])
def test_stones_tile_the_wall_on_a_fixed_base(irregularity):
    s = bm.cases.stone_wall(width=4.0, height=2.0, stone_size=0.3, irregularity=irregularity, seed=4)
    assert s.fixed[0] and not s.fixed[1:].any()
    assert s.metadata["stones"] == s.n_blocks - 1
    np.testing.assert_allclose(s.area[1:].sum(), 8.0, rtol=1e-12)  # no gap (and no overlap: validated)
    pts = np.vstack(stones(s))
    assert pts.min(axis=0).tolist() == [0.0, 0.0] and pts.max(axis=0).tolist() == [4.0, 2.0]
    assert abs(s.metadata["stones"] / (8.0 / 0.3**2) - 1) < 0.2  # about width * height / stone_size**2
    touching_base = s.interfaces.plus[s.interfaces.minus == 0]
    assert touching_base.size >= 8  # the bottom course rests on the base


def test_irregularity_zero_is_running_bond_of_rectangles():
    s = bm.cases.stone_wall(width=4.0, height=2.0, stone_size=0.3, irregularity=0.0)
    assert all(len(p) == 4 for p in stones(s)) and s.metadata["non_convex_stones"] == 0
    heights = {round(np.ptp(p[:, 1]), 12) for p in stones(s)}
    assert len(heights) == 1  # one course height
    widths = sorted({round(np.ptp(p[:, 0]), 12) for p in stones(s)})
    assert len(widths) == 2 and widths[0] == pytest.approx(widths[1] / 2)  # stones and half stones


def test_rubble_has_non_convex_stones():
    s = bm.cases.stone_wall(width=4.0, height=2.0, stone_size=0.3, irregularity=1.0, seed=1)
    assert s.metadata["non_convex_stones"] >= 5


def test_same_seed_same_bits_other_seed_other_wall():
    a = bm.cases.stone_wall(**SMALL, irregularity=0.7, seed=11)
    b = bm.cases.stone_wall(**SMALL, irregularity=0.7, seed=11)
    c = bm.cases.stone_wall(**SMALL, irregularity=0.7, seed=12)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.n_vertices, b.n_vertices)
    assert np.array_equal(a.interfaces.start, b.interfaces.start) and np.array_equal(a.interfaces.end, b.interfaces.end)
    assert a.vertices.shape != c.vertices.shape or not np.array_equal(a.vertices, c.vertices)


def _interface_set(s, block_map=None, mirror=False):
    """Unordered block pairs with unordered segment ends, ends rounded to 1e-12 (mirrored: x -> -x)."""
    out = set()
    for k in range(len(s.interfaces)):
        a, b = int(s.interfaces.minus[k]), int(s.interfaces.plus[k])
        if block_map is not None:
            a, b = block_map[a], block_map[b]
        ends = [s.interfaces.start[k].copy(), s.interfaces.end[k].copy()]
        if mirror:
            for e in ends:
                e[0] = -e[0]
        out.add((min(a, b), max(a, b), frozenset(tuple(np.round(e, 12) + 0.0) for e in ends)))
    return out


def test_interfaces_and_multiplier_do_not_depend_on_the_order_of_the_stones():
    s = bm.cases.stone_wall(**SMALL, irregularity=0.8, seed=5)
    order = np.random.default_rng(0).permutation(s.n_blocks)
    polys = [s.polygon(int(i)) for i in order]
    p = bm.make_structure(polys, s.fixed[order], friction=s.friction)
    assert _interface_set(p, block_map=order.tolist()) == _interface_set(s)
    assert bm.solve(p, "static-lp").multiplier == pytest.approx(bm.solve(s, "static-lp").multiplier, rel=1e-12)


def test_interfaces_and_multiplier_are_mirrored_with_the_drawing():
    s = bm.cases.stone_wall(**SMALL, irregularity=0.8, seed=5)
    polys = [(s.polygon(i) * [-1, 1])[::-1] for i in range(s.n_blocks)]
    m = bm.make_structure(polys, s.fixed, friction=s.friction, live_direction=-1)
    assert _interface_set(m, mirror=True) == _interface_set(s)
    for method in ("static-lp", "fixed-point"):
        assert bm.solve(m, method).multiplier == pytest.approx(bm.solve(s, method).multiplier, rel=1e-9), method


def test_static_and_kinematic_lp_agree_and_fixed_point_is_below_them():
    s = bm.cases.stone_wall(**SMALL, irregularity=0.7, seed=2, mu=0.6)
    static, kinematic = bm.solve(s, "static-lp"), bm.solve(s, "kinematic-lp")
    assert static.success and kinematic.success
    assert kinematic.multiplier == pytest.approx(static.multiplier, rel=1e-8)
    fp = bm.solve(s, "fixed-point")
    assert fp.success, fp.message
    assert fp.multiplier <= static.multiplier * (1 + 1e-9)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"irregularity": 1.5}, r"irregularity: must lie in \[0, 1\]"),
        ({"irregularity": "much"}, r"irregularity: expected a number"),
        ({"seed": -1}, r"seed: must be an integer >= 0"),
        ({"seed": 1.5}, r"seed: must be an integer >= 0"),
        ({"stone_size": 0}, r"stone_size: must be a finite number > 0"),
        ({"stone_size": 1e-4}, r"stone_size: 0.0001 gives about 8e\+08 stones"),
        ({"width": -1}, r"width: must be a finite number > 0"),
    ],
)
def test_bad_parameters_are_named(params, message):
    with pytest.raises(bm.OptionError, match=message):
        bm.cases.stone_wall(**params)


@pytest.mark.slow
def test_cli_solves_a_stone_wall_with_the_fixed_point():
    p = subprocess.run([sys.executable, "-m", "blockmpec.cli", "solve", "stone-wall", "-p", "width=2", "-p", "height=1",
                        "-p", "stone_size=0.3", "-p", "irregularity=0.6", "--method", "fixed-point"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "stone-wall: method=fixed-point" in p.stdout and "success=True" in p.stdout


def _wedged_wall(stones, mu):
    height = 0.3 * np.sqrt(stones / 2.0)
    return bm.cases.stone_wall(width=2 * height, height=height, stone_size=0.3, irregularity=0.5, mu=mu)


def _largest_self_stress(structure):
    """max -sum n over forces in equilibrium with no load that satisfy every row of (1), -n_k <= 1 (HiGHS)."""
    import scipy.sparse as sp
    from scipy.optimize import linprog

    ops = bm.assemble(structure)
    columns = ops.E.shape[1]
    interfaces = columns // 3
    normal = sp.csr_array((np.ones(interfaces), (np.arange(interfaces), np.arange(1, columns, 3))),
                          shape=(interfaces, columns))
    A_ub = sp.vstack([ops.N_u.T, ops.N_f.T, -normal]).tocsr()
    b_ub = np.r_[np.zeros(ops.N_u.shape[1] + ops.N_f.shape[1]), np.ones(interfaces)]
    cost = np.zeros(columns)
    cost[1::3] = 1.0
    out = linprog(cost, A_ub=A_ub, b_ub=b_ub, A_eq=ops.E, b_eq=np.zeros(ops.E.shape[0]), bounds=(None, None),
                  method="highs")
    assert out.status == 0
    return -out.fun


def test_static_lp_falls_back_to_highs_where_self_stress_defeats_the_block_ipm():
    # at mu 1 wedged stones carry a self-stress (none at 0.65): the optimal forces of (1) are unbounded, the block
    # IPM has no end point and fails; auto then solves the LP with HiGHS, which agrees with HiGHS's simplex
    assert _largest_self_stress(_wedged_wall(200, 0.65)) == pytest.approx(0.0, abs=1e-9)
    wall = _wedged_wall(200, 1.0)
    assert _largest_self_stress(wall) > 1.0
    alone = bm.solve(wall, "static-lp", algorithm="block-ipm")
    assert alone.status is bm.Status.NUMERICAL, "the block IPM alone now solves this wall: pick one where it fails"
    auto = bm.solve(wall, "static-lp")
    assert auto.success and auto.status is bm.Status.OPTIMAL
    assert len(auto.extra["plan"]) == 2 and auto.extra["plan"][1] == "static LP (1): HiGHS ipm"  # the fallback ran
    assert "after the block IPM ended numerical" in auto.message
    simplex = bm.solve(wall, "static-lp", algorithm="dual-simplex")
    assert auto.multiplier == pytest.approx(simplex.multiplier, rel=1e-8)
    kinematic = bm.solve(wall, "kinematic-lp")
    assert kinematic.multiplier == pytest.approx(auto.multiplier, rel=1e-6)


@pytest.mark.slow
def test_highs_retries_at_its_default_tolerances_after_a_solve_error():
    # this wall's static LP ends kSolveError/kNotset by every HiGHS algorithm at the library's tolerance 1e-9
    wall = _wedged_wall(300, 1.2)
    res = bm.solve(wall, "static-lp", algorithm="dual-simplex")
    assert "HiGHS ended" in res.message and "its default 1e-07" in res.message
    assert res.status is bm.Status.OPTIMAL and res.success  # verified: residuals of (1) within 1e-6
    assert res.multiplier <= wall.friction + 1e-9  # no more than sliding the wall on its base
