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
