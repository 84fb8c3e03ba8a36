"""Geometry, interface detection, operator assembly and loads."""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.geometry import detect_interfaces
from helpers import block_on_block


def test_two_blocks_interfaces_and_normals():
    s = bm.cases.two_blocks(eta=3)
    itf = s.interfaces
    assert len(itf) == 3
    centroid = s.centroid
    # the normal points from the minus block into the plus block
    for k in range(len(itf)):
        d = centroid[itf.plus[k]] - centroid[itf.minus[k]]
        assert d @ itf.normal[k] > 0
    np.testing.assert_allclose(sorted(itf.length), [1.0, 1.0, 3.0])


@pytest.mark.parametrize(("courses", "per"), [(1, 1), (2, 3), (5, 4), (6, 7)])
def test_running_bond_interface_count(courses, per):
    s = bm.cases.wall(courses=courses, blocks_per_course=per)
    n_long = courses // 2  # offset courses hold per + 1 blocks
    assert s.n_free == courses * per + n_long
    vertical = courses * (per - 1) + n_long  # joints within a course
    bed = per  # base to first course
    for r in range(1, courses):
        bed += 2 * per  # between an aligned and an offset course every block meets two
    assert len(s.interfaces) == vertical + bed


def test_stack_bond_interface_count():
    s = bm.cases.wall(courses=3, blocks_per_course=4, bond="stack")
    assert len(s.interfaces) == 3 * 3 + 3 * 4


def test_opening_removes_blocks():
    full = bm.cases.wall(courses=6, blocks_per_course=6, bond="stack")
    holed = bm.cases.wall(courses=6, blocks_per_course=6, bond="stack", openings=[(2, 1, 4, 2)])
    assert full.n_free - holed.n_free == 4


def test_arch_geometry_and_weight():
    s = bm.cases.round_arch()
    assert s.n_free == 10 and len(s.interfaces) == 11
    # straight-sided voussoirs: total area is slightly less than the annulus' half
    annulus = 0.5 * np.pi * ((1.075) ** 2 - (0.925) ** 2)
    area = s.area[~s.fixed].sum()
    assert 0.98 * annulus < area < annulus


def test_arch_on_buttresses_has_26_free_blocks():
    s = bm.cases.arch_on_buttresses()
    assert s.n_free == 26


def test_operators_shapes_and_sparsity():
    s = bm.cases.wall()
    ops = bm.assemble(s)
    # 18 full blocks (1 x 0.5) and 4 half blocks: the length unit is the median shorter side, mean weight 10/22
    assert ops.length_scale == 0.5 and ops.force_scale == pytest.approx(10 / 22)
    b, c = s.n_free, len(s.interfaces)
    assert ops.E.shape == (3 * b, 3 * c)
    assert ops.N_u.shape == ops.N_f.shape == ops.V_f.shape == (3 * c, 2 * c)
    assert ops.E.nnz <= 2 * 7 * c
    # f_d is the weight, f_l the horizontal body force of the same size
    np.testing.assert_allclose(-ops.f_d[1::3] * ops.force_scale, s.weight[ops.free_blocks])
    np.testing.assert_allclose(ops.f_l[0::3] * ops.force_scale, s.weight[ops.free_blocks])


def test_equilibrium_operator_is_minus_jump_transpose():
    # for a rigid motion of a free block, the jump at its interfaces is the block's velocity at the midpoint
    s = bm.cases.two_blocks(eta=2)
    ops = bm.assemble(s)
    u = np.zeros(6)
    u[3:6] = [0.3, -0.2, 0.5]  # move the right block (free block 1 = structure block 2)
    jump = -(ops.E.T @ u)  # B u, per interface (tau, nu, rotation) of plus relative to minus
    itf = s.interfaces
    g = s.centroid[2]
    assert ops.length_scale == 1.0  # the blocks' shorter side
    ell = ops.length_scale
    for k in range(3):
        sign = int(itf.plus[k] == 2) - int(itf.minus[k] == 2)
        r = (itf.midpoint[k] - g) / ell  # arms in the nondimensional problem
        v = np.array([0.3 - 0.5 * r[1], -0.2 + 0.5 * r[0]])
        np.testing.assert_allclose(jump[3 * k : 3 * k + 2], sign * np.array([v @ itf.tangent[k], v @ itf.normal[k]]), atol=1e-12)
        assert jump[3 * k + 2] == pytest.approx(sign * 0.5)


def test_point_loads_enter_load_vectors():
    s0 = bm.cases.single_block(width=1, height=2)
    s = bm.make_structure(
        [s0.polygon(0), s0.polygon(1)], s0.fixed, friction=0.65,
        point_loads=[bm.PointLoad(1, (0.5, 2.0), (1.0, 0.0), "live"), bm.PointLoad(1, (1.0, 1.0), (0.0, -3.0), "dead")],
    )
    ops = bm.assemble(s)
    force, moment = ops.force_scale, ops.force_scale * ops.length_scale
    unit = np.array([force, force, moment])
    np.testing.assert_allclose(ops.f_l * unit, [2.0 + 1.0, 0.0, -1.0])  # body force W=2 plus 1 at height 2 (arm 1)
    np.testing.assert_allclose(ops.f_d * unit, [0.0, -2.0 - 3.0, -1.5])  # weight plus 3 down at arm +0.5


def test_uniform_scaling_keeps_multiplier():
    base = bm.cases.wall(courses=3, blocks_per_course=3)
    ref = bm.solve(base, "static-lp").multiplier
    for factor in (1e-3, 1e3):
        polys = [base.polygon(i) * factor for i in range(base.n_blocks)]
        s = bm.make_structure(polys, base.fixed, friction=base.friction)
        assert bm.solve(s, "static-lp").multiplier == pytest.approx(ref, rel=1e-7)


def test_interfaces_found_between_blocks_of_very_different_size():
    big = [[-100, -1], [100, -1], [100, 0], [-100, 0]]
    tiny = [[0, 0], [0.01, 0], [0.01, 0.01], [0, 0.01]]
    vertices, n_vertices = bm.geometry.pad_polygons([big, tiny])
    itf = detect_interfaces(vertices, n_vertices)
    assert len(itf) == 1 and itf.length[0] == pytest.approx(0.01)


def test_large_wall_assembles_quickly_enough_to_test():
    s = bm.cases.wall(courses=50, blocks_per_course=50)
    ops = bm.assemble(s)
    assert ops.E.shape[0] == 3 * s.n_free


# ---------------------------------------------------------------- units and canonical order (issue 16)

def _shifted_scaled(s, scale=1.0, dx=0.0, dy=0.0):
    polys = [(s.polygon(i) + (dx, dy)) * scale for i in range(s.n_blocks)]
    return bm.make_structure(polys, s.fixed, friction=s.friction)


def _same_operators(a, b):
    for name in ("f_d", "f_l", "length", "friction"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert (a.E != b.E).nnz == 0 and (a.N_u != b.N_u).nnz == 0


@pytest.mark.parametrize("k", [-500, -360, -100, 0, 100, 465])
def test_power_of_two_scaling_gives_bitwise_identical_operators(k):
    """Lengths 2^k (1e-150 ... 1e140): areas, centroids and arms are computed in the structure's units
    without ever forming a product of two lengths, so the nondimensional operators are the same bits."""
    ref = bm.cases.two_blocks(eta=3.0, mu=0.65)
    _same_operators(bm.assemble(ref), bm.assemble(_shifted_scaled(ref, scale=2.0**k)))


@pytest.mark.filterwarnings("ignore::blockmpec.PrecisionWarning")  # dyadic coordinates: nothing is lost
@pytest.mark.parametrize("offset", [2.0**20, 2.0**40, 2.0**49])
def test_exact_translation_gives_bitwise_identical_operators(offset):
    """The origin is the structure's centre and the coordinates are snapped to a dyadic grid."""
    ref = bm.cases.wall(courses=3, blocks_per_course=3)
    _same_operators(bm.assemble(ref), bm.assemble(_shifted_scaled(ref, dx=offset, dy=-offset / 2)))


def test_canonical_order_ignores_the_block_order_of_the_file():
    ref = bm.cases.wall(courses=3, blocks_per_course=3)
    order = np.random.default_rng(1).permutation(ref.n_blocks)
    shuffled = bm.make_structure([ref.polygon(i) for i in order], ref.fixed[order], friction=ref.friction)
    a, b = bm.assemble(ref), bm.assemble(shuffled)
    _same_operators(a, b)
    np.testing.assert_array_equal(order[b.free_blocks], a.free_blocks)


def test_canonical_order_rows_by_height_then_along_the_live_load():
    s = bm.cases.wall(courses=3, blocks_per_course=2, bond="stack")
    ops = bm.assemble(s)
    c = s.centroid[ops.free_blocks]
    key = list(zip(np.round(c[:, 1], 9), np.round(c[:, 0], 9)))
    assert key == sorted(key)
    assert np.all(ops.minus_dof < ops.plus_dof)  # oriented from the earlier (or fixed, -1) block


def test_units_object_serves_the_scalings():
    from blockmpec.units import block_load

    s = block_on_block(1.0, 1e-3)
    ops = bm.assemble(s)
    u = ops.units
    np.testing.assert_allclose(u.block_load, block_load(ops.f_d, ops.f_l))
    side = np.column_stack([ops.minus_dof, ops.plus_dof])
    expect = np.where(side >= 0, u.block_load[np.maximum(side, 0)], np.inf).min(axis=1)
    np.testing.assert_array_equal(u.interface_force, expect)
    assert u.load_spread == pytest.approx(1 / 2e-6, rel=1e-9)
    # the weights are those of the snapped geometry: every vertex moved by less than 2^-40 of the smallest
    # block side (blockmpec.units), so the area of a rectangle by less than 4 * 2^-40 (measured: 3.9e-13)
    np.testing.assert_allclose(-ops.f_d[1::3] * u.force_scale, s.weight[ops.free_blocks], rtol=4 * 2.0**-40)


def test_force_unit_includes_point_loads_for_near_massless_blocks():
    base = [[-1, -1], [3, -1], [3, 0], [-1, 0]]
    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    loads = [bm.PointLoad(1, (0.5, 1.0), (0.0, -2.0)), bm.PointLoad(1, (0.0, 0.5), (1.0, 0.0), "live")]
    s = bm.make_structure([base, square], [True, False], friction=0.5, density=1e-12, point_loads=loads)
    ops = bm.assemble(s)
    assert ops.force_scale == pytest.approx(1.0, rel=1e-9)  # the live point load, not the 1e-12 weight
    assert abs(ops.f_d[1]) == pytest.approx(2.0, rel=1e-9) and abs(ops.f_l[0]) == pytest.approx(1.0, rel=1e-9)


def test_mirror_image_assembles_in_the_mirrored_canonical_frame():
    """A mirror image with the live load reversed has x along -x: the same operators, and its mechanism
    mapped to the structure's axes is the mirror image of the original's."""
    ref = bm.cases.two_blocks(eta=3.0, mu=0.65)
    polys = [[[-x, y] for x, y in ref.polygon(i)[::-1]] for i in range(ref.n_blocks)]
    mirrored = bm.make_structure(polys, ref.fixed, friction=ref.friction, live_direction=-1)
    a, b = bm.assemble(ref), bm.assemble(mirrored)
    assert a.mirror == 1.0 and b.mirror == -1.0
    _same_operators(a, b)
    u_ref = a.velocities_to_structure(bm.solve(ref, "kinematic-lp").solution.u).reshape(-1, 3)
    u_mir = b.velocities_to_structure(bm.solve(mirrored, "kinematic-lp").solution.u).reshape(-1, 3)
    np.testing.assert_array_equal(u_mir, u_ref * [-1.0, 1.0, -1.0])
    assert u_ref[:, 0].max() > 0  # the original moves along +x with its live load
