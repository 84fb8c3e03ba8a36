"""Contacts of moved blocks (blockmpec.contacts): edge and point contacts, gaps, overlaps, no solver."""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.contacts import CONTACT_LENGTH, contact_structure, find_contacts, max_penetration
from blockmpec.geometry import pad_polygons


def _rect(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)


def _rotate_about(poly, centre, angle):
    c, s = np.cos(angle), np.sin(angle)
    r = poly - centre
    return np.column_stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]]) + centre


def _contacts(polygons, fixed, **kw):
    vertices, n_vertices = pad_polygons(polygons)
    return find_contacts(vertices, n_vertices, np.asarray(fixed, bool), **kw)


def _segments(itf, fixed):
    out = []
    for k in range(len(itf)):
        a, b = int(itf.minus[k]), int(itf.plus[k])
        if fixed[a] and fixed[b]:
            continue
        ends = sorted([tuple(np.round(itf.start[k], 9)), tuple(np.round(itf.end[k], 9))])
        out.append((min(a, b), max(a, b), tuple(ends)))
    return sorted(out)


@pytest.mark.parametrize("structure", [
    bm.cases.single_block(), bm.cases.two_blocks(), bm.cases.round_arch(), bm.cases.arch_on_buttresses(),
    bm.cases.wall(5, 4), bm.cases.wall(10, 5), bm.cases.wall(4, 2, bond="stack"),
], ids=lambda s: f"{s.name}-{s.n_blocks}")
def test_blocks_that_have_not_moved_touch_along_the_structures_interfaces(structure):
    # same segments as detect_interfaces; corners that only meet (stack bond) are no contact
    found = find_contacts(structure.vertices, structure.n_vertices, structure.fixed)
    assert found.n_points == 0
    assert _segments(found.interfaces, structure.fixed) == _segments(structure.interfaces, structure.fixed)
    # every normal points from the minus block into the plus block
    itf = found.interfaces
    side = np.einsum("kd,kd->k", structure.centroid[itf.plus] - structure.centroid[itf.minus], itf.normal)
    assert np.all(side > 0)


def test_a_block_rotated_about_its_toe_touches_its_base_at_the_toe_only():
    base, block = _rect(-1, -1, 2, 0), _rect(0, 0, 1, 2)
    theta = 0.1
    moved = _rotate_about(block, np.array([1.0, 0.0]), -theta)  # toppling towards +x
    c = _contacts([base, moved], [True, False])
    assert len(c) == 1 and c.n_points == 1
    itf = c.interfaces
    assert (itf.minus[0], itf.plus[0]) == (0, 1)  # the base's edge carries the contact
    np.testing.assert_allclose(itf.normal[0], [0.0, 1.0], atol=1e-15)
    # the short interface lies on the base's top edge, ends exactly at the toe and runs under the block
    ends = np.array([itf.start[0], itf.end[0]])
    np.testing.assert_allclose(ends[:, 1], 0.0, atol=1e-15)
    assert ends[:, 0].max() == pytest.approx(1.0, abs=1e-15)
    assert itf.length[0] == pytest.approx(CONTACT_LENGTH * 1.0, rel=1e-12)
    toe = int(np.argmax(ends[:, 0]))
    assert c.touching[0, toe] and not c.touching[0, 1 - toe]
    np.testing.assert_allclose(c.points[0, toe], [1.0, 0.0], atol=1e-15)
    # the heel is open by sin(theta): no force there
    assert c.gap[0, 1 - toe] > 0


@pytest.mark.parametrize(("lift", "contacts"), [(0.5e-3, 1), (2e-3, 0)])
def test_a_gap_within_the_tolerance_touches_and_a_wider_one_does_not(lift, contacts):
    base, block = _rect(-1, -1, 2, 0), _rect(0, lift, 1, 2 + lift)
    c = _contacts([base, block], [True, False], tolerance=1e-3)
    assert len(c) == contacts
    if contacts:
        assert c.n_points == 0 and np.all(c.touching)
        np.testing.assert_allclose(c.gap, lift, rtol=1e-9)


def test_two_corners_that_meet_are_no_contact_but_a_corner_on_an_edge_is():
    a, b = _rect(0, 0, 1, 1), _rect(1, 1, 2, 2)
    assert len(_contacts([a, b], [True, False])) == 0
    # turned a little about its lower-left corner and slid left by a quarter, the upper block rests that
    # corner on the lower block's top edge: a point contact
    c = _contacts([a, _rotate_about(b, np.array([1.0, 1.0]), 0.05) - [0.25, 0.0]], [True, False])
    assert len(c) == 1 and c.n_points == 1


def test_a_hinge_between_two_turned_blocks_is_one_point_at_their_common_corner():
    lower, upper = _rect(0, 0, 1, 1), _rect(0, 1, 1, 2)
    turned = _rotate_about(upper, np.array([1.0, 1.0]), -0.05)
    c = _contacts([_rect(-1, -1, 2, 0), lower, turned], [True, False, False])
    pair = [k for k in range(len(c)) if {c.interfaces.minus[k], c.interfaces.plus[k]} == {1, 2}]
    assert len(pair) == 1 and c.is_point[pair[0]]
    k = pair[0]
    touching = c.feet[k][c.touching[k]]
    np.testing.assert_allclose(touching, [[1.0, 1.0]], atol=1e-15)


def test_overlaps_are_reported_by_depth():
    base, block = _rect(-1, -1, 2, 0), _rect(0, -0.01, 1, 2)
    hits = max_penetration(*pad_polygons([base, block]), np.array([True, False]))
    assert hits.shape == (1, 3) and hits[0, 2] == pytest.approx(0.01, rel=1e-9)
    assert max_penetration(*pad_polygons([base, _rect(0, 0, 1, 2)]), np.array([True, False])).size == 0


def test_contact_structure_keeps_material_overrides_per_pair_of_blocks():
    s = bm.cases.two_blocks()
    itf = s.interfaces
    friction = np.full(len(itf), np.nan)
    pair = int(np.flatnonzero((np.minimum(itf.minus, itf.plus) == 1) & (np.maximum(itf.minus, itf.plus) == 2))[0])
    friction[pair] = 0.3
    s = bm.make_structure([s.polygon(i) for i in range(3)], s.fixed, friction=0.65,
                          interfaces=bm.Interfaces(itf.minus, itf.plus, itf.start, itf.end, friction, itf.dilatancy))
    found = find_contacts(s.vertices, s.n_vertices, s.fixed)
    moved = contact_structure(s, s.vertices, found)
    mu = moved.interface_friction()
    between = (np.minimum(found.interfaces.minus, found.interfaces.plus) == 1)
    between &= np.maximum(found.interfaces.minus, found.interfaces.plus) == 2
    assert np.all(mu[between] == 0.3) and np.all(mu[~between] == 0.65)
    # the same structure solves to the same multiplier through the found contacts
    assert bm.solve(moved, "static-lp").multiplier == pytest.approx(bm.solve(s, "static-lp").multiplier, rel=1e-12)
